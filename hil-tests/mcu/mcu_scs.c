/* The Cortex-M4 system control space at 0xE000E000 (ARMv7-M ARM B3.2: SCB; B3.3: SysTick; B3.4:
 * NVIC) with CoreDebug's DEMCR (C1.6.5), and the DWT's CTRL and CYCCNT at 0xE0001000 (C1.8). The
 * exception state itself (pending, active, priorities) is the CPU's (mcu_cpu.c); these are its
 * registers. */
#include "mcu.h"

#define SCS_BASE 0xE000E000u
#define DWT_BASE 0xE0001000u

#define CPUID_M4_R0P1 0x410FC241u /* Cortex-M4 r0p1, the F405's core (RM0090 38.6.1: DBGMCU, CPUID) */
#define CSR_ENABLE 1u
#define CSR_TICKINT 2u
#define CSR_CLKSOURCE 4u
#define CSR_COUNTFLAG (1u << 16)
#define ICSR_PENDSTSET (1u << 26)
#define ICSR_PENDSTCLR (1u << 25)
#define ICSR_PENDSVSET (1u << 28)
#define ICSR_PENDSVCLR (1u << 27)
#define ICSR_NMIPENDSET (1u << 31)
#define AIRCR_VECTKEY 0x05FAu
#define AIRCR_SYSRESETREQ (1u << 2)
#define DEMCR_TRCENA (1u << 24)
#define DWT_CTRL_CYCCNTENA 1u
#define DWT_CTRL_NUMCOMP_4 (4u << 28)
#define EXC_SYSTICK 15u

/* SysTick (B3.3): a 24-bit down counter from the processor clock (CLKSOURCE = 1) or the STM32's
 * external reference, HCLK / 8 (RM0090 6.2, figure 21). The count is computed from virtual time:
 * `val0` at `t0`, counting one every `per` units. Reaching 0 from 1 sets COUNTFLAG and, with TICKINT,
 * pends the SysTick exception; the next count reloads RVR. */
struct systick {
	uint32_t csr, rvr, val0, per;
	uint64_t t0, next_zero; /* next_zero: counts after t0 at which it reads 0 from 1 next */
};

struct scs {
	struct systick st;
	uint32_t dwt_cyccnt0; /* CYCCNT = dwt_cyccnt0 + (cycles - cycles0) while counting */
	uint64_t cycles0;
	int cyccnt_on;
	uint32_t fpccr;
};

static struct scs scs_state; /* one emulated MCU per process */

/* The counter's value k counts after t0. */
static uint32_t st_value_at(const struct systick *s, uint64_t k)
{
	uint64_t period = (uint64_t)s->rvr + 1u;

	if (k <= s->val0)
		return s->val0 - (uint32_t)k;
	return s->rvr - (uint32_t)((k - s->val0 - 1u) % period);
}

static uint64_t st_elapsed(const struct systick *s, uint64_t now)
{
	return (now - s->t0) / s->per;
}

static uint32_t st_value(const struct systick *s, uint64_t now)
{
	if (!(s->csr & CSR_ENABLE) || !s->per)
		return s->val0;
	return st_value_at(s, st_elapsed(s, now));
}

/* The first count index after t0, at or after `from`, at which the counter reads 0 coming from 1. */
static uint64_t st_first_zero(const struct systick *s, uint64_t from)
{
	uint64_t period = (uint64_t)s->rvr + 1u, z;

	if (!s->rvr)
		return MCU_NEVER; /* RVR 0: the counter stops at 0 (B3.3.1) */
	z = s->val0 ? s->val0 : s->val0 + period; /* a start at 0 reloads first */
	if (from <= z)
		return z;
	return z + (from - z + period - 1u) / period * period;
}

static void st_rebase(struct mcu *m, struct systick *s)
{
	s->val0 = st_value(s, m->now);
	s->t0 = m->now;
	s->per = (s->csr & CSR_CLKSOURCE) ? m->clk.units_per_cycle : m->clk.units_per_cycle * 8u;
	s->next_zero = st_first_zero(s, 1);
}

static void scs_advance(struct mcu *m, void *ctx, uint64_t now)
{
	struct scs *c = ctx;
	struct systick *s = &c->st;

	if (!(s->csr & CSR_ENABLE) || s->next_zero == MCU_NEVER)
		return;
	if (st_elapsed(s, now) >= s->next_zero) {
		s->csr |= CSR_COUNTFLAG;
		if (s->csr & CSR_TICKINT)
			mcu_exc_pend(m, EXC_SYSTICK);
		s->next_zero = st_first_zero(s, st_elapsed(s, now) + 1u);
	}
}

static uint64_t scs_next_event(struct mcu *m, void *ctx)
{
	struct scs *c = ctx;
	const struct systick *s = &c->st;

	(void)m;
	if (!(s->csr & CSR_ENABLE) || s->next_zero == MCU_NEVER)
		return MCU_NEVER;
	return s->t0 + s->next_zero * s->per;
}

static uint32_t icsr(struct mcu *m)
{
	uint32_t v = 0, pend = 0;
	int best = 1000;

	if (m->nvic.depth)
		v |= m->nvic.stack[m->nvic.depth - 1];
	if (m->nvic.depth <= 1)
		v |= 1u << 11; /* RETTOBASE */
	for (unsigned e = 2; e < MCU_EXCS; e++)
		if ((m->nvic.pending[e] || (e >= 16 && m->nvic.line[e])) && m->nvic.prio[e] < best) {
			best = m->nvic.prio[e];
			pend = e;
		}
	v |= pend << 12;
	for (unsigned e = 16; e < MCU_EXCS; e++)
		if (m->nvic.pending[e] || m->nvic.line[e])
			v |= 1u << 22; /* ISRPENDING */
	if (m->nvic.pending[EXC_SYSTICK])
		v |= ICSR_PENDSTSET;
	if (m->nvic.pending[14])
		v |= ICSR_PENDSVSET;
	return v;
}

/* NVIC bit arrays: ISER/ICER (enable), ISPR/ICPR (pending), IABR (active), 32 interrupts a word. */
static uint32_t nvic_bits(const uint8_t *a, uint32_t word)
{
	uint32_t v = 0;

	for (unsigned b = 0; b < 32; b++) {
		unsigned irq = word * 32u + b;

		if (irq < MCU_IRQS && a[16 + irq])
			v |= 1u << b;
	}
	return v;
}

static void nvic_write_bits(uint8_t *a, uint32_t word, uint32_t v, uint8_t to)
{
	for (unsigned b = 0; b < 32; b++) {
		unsigned irq = word * 32u + b;

		if (irq < MCU_IRQS && (v >> b & 1u))
			a[16 + irq] = to;
	}
}

static uint32_t scs_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct scs *c = ctx;
	uint32_t v;

	if (off >= 0x400 && off < 0x400 + MCU_IRQS) { /* NVIC_IPR, byte-addressable */
		v = 0;
		for (unsigned i = 0; i < size && off + i < 0x400 + MCU_IRQS; i++)
			v |= (uint32_t)m->nvic.prio[16 + off - 0x400 + i] << (8 * i);
		return v;
	}
	if (off >= 0xD18 && off < 0xD24) { /* SHPR1-3: exceptions 4..15 */
		v = 0;
		for (unsigned i = 0; i < size && off + i < 0xD24; i++)
			v |= (uint32_t)m->nvic.prio[4 + off - 0xD18 + i] << (8 * i);
		return v;
	}
	if (off >= 0x100 && off < 0x120)
		return nvic_bits(m->nvic.enabled, (off - 0x100) / 4);
	if (off >= 0x180 && off < 0x1A0)
		return nvic_bits(m->nvic.enabled, (off - 0x180) / 4);
	if (off >= 0x200 && off < 0x220)
		return nvic_bits(m->nvic.pending, (off - 0x200) / 4) | nvic_bits(m->nvic.line, (off - 0x200) / 4);
	if (off >= 0x280 && off < 0x2A0)
		return nvic_bits(m->nvic.pending, (off - 0x280) / 4) | nvic_bits(m->nvic.line, (off - 0x280) / 4);
	if (off >= 0x300 && off < 0x320)
		return nvic_bits(m->nvic.active, (off - 0x300) / 4);
	switch (off) {
	case 0x004: /* ICTR: lines in groups of 32, minus one */
		return (MCU_IRQS + 31u) / 32u - 1u;
	case 0x010:
		v = c->st.csr;
		c->st.csr &= ~CSR_COUNTFLAG; /* cleared by the read */
		return v;
	case 0x014:
		return c->st.rvr;
	case 0x018:
		return st_value(&c->st, m->now);
	case 0x01C: /* CALIB: NOREF and SKEW set, no TENMS value given (not modelled) */
		return 0xC0000000u;
	case 0xD00:
		return CPUID_M4_R0P1;
	case 0xD04:
		return icsr(m);
	case 0xD08:
		return m->vtor;
	case 0xD0C:
		return 0xFA050000u | m->nvic.prigroup << 8;
	case 0xD10:
		return 0;
	case 0xD14:
		return m->ccr;
	case 0xD24:
		return m->shcsr;
	case 0xD28:
		return m->cfsr;
	case 0xD2C:
		return m->hfsr;
	case 0xD34: /* MMFAR: no MPU, never valid */
		return 0;
	case 0xD38:
		return m->bfar;
	case 0xD88:
		return m->cpacr;
	case 0xDFC:
		return m->demcr;
	case 0xF34:
		return c->fpccr;
	default:
		mcu_unmodelled(m, "SCS", SCS_BASE + off, 0, 0);
		return 0;
	}
}

static void scs_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct scs *c = ctx;

	if (off >= 0x400 && off < 0x400 + MCU_IRQS) {
		for (unsigned i = 0; i < size && off + i < 0x400 + MCU_IRQS; i++)
			m->nvic.prio[16 + off - 0x400 + i] = (uint8_t)(v >> (8 * i)) & 0xF0u; /* 4 bits implemented */
		return;
	}
	if (off >= 0xD18 && off < 0xD24) {
		for (unsigned i = 0; i < size && off + i < 0xD24; i++)
			m->nvic.prio[4 + off - 0xD18 + i] = (uint8_t)(v >> (8 * i)) & 0xF0u;
		return;
	}
	if (off >= 0x100 && off < 0x120) {
		nvic_write_bits(m->nvic.enabled, (off - 0x100) / 4, v, 1);
		return;
	}
	if (off >= 0x180 && off < 0x1A0) {
		nvic_write_bits(m->nvic.enabled, (off - 0x180) / 4, v, 0);
		return;
	}
	if (off >= 0x200 && off < 0x220) {
		nvic_write_bits(m->nvic.pending, (off - 0x200) / 4, v, 1);
		return;
	}
	if (off >= 0x280 && off < 0x2A0) {
		nvic_write_bits(m->nvic.pending, (off - 0x280) / 4, v, 0);
		return;
	}
	switch (off) {
	case 0x010:
		c->st.val0 = st_value(&c->st, m->now);
		c->st.csr = (c->st.csr & CSR_COUNTFLAG) | (v & (CSR_ENABLE | CSR_TICKINT | CSR_CLKSOURCE));
		st_rebase(m, &c->st);
		return;
	case 0x014:
		st_rebase(m, &c->st);
		c->st.rvr = v & 0x00FFFFFFu;
		c->st.next_zero = st_first_zero(&c->st, 1);
		return;
	case 0x018: /* any write clears the counter and COUNTFLAG */
		c->st.csr &= ~CSR_COUNTFLAG;
		c->st.val0 = 0;
		c->st.t0 = m->now;
		st_rebase(m, &c->st);
		return;
	case 0xD04:
		if (v & ICSR_PENDSTSET)
			mcu_exc_pend(m, EXC_SYSTICK);
		if (v & ICSR_PENDSTCLR)
			m->nvic.pending[EXC_SYSTICK] = 0;
		if (v & ICSR_PENDSVSET)
			mcu_exc_pend(m, 14);
		if (v & ICSR_PENDSVCLR)
			m->nvic.pending[14] = 0;
		if (v & ICSR_NMIPENDSET)
			mcu_exc_pend(m, 2);
		return;
	case 0xD08:
		m->vtor = v & 0x3FFFFE00u; /* TBLOFF, bits 29:9 (B3.2.5) */
		return;
	case 0xD0C:
		if ((v >> 16) != AIRCR_VECTKEY)
			return; /* ignored without the key */
		m->nvic.prigroup = (v >> 8) & 7u;
		if (v & AIRCR_SYSRESETREQ)
			m->reset_req = 1;
		return;
	case 0xD10:
		if (v)
			mcu_unmodelled(m, "SCB SCR (sleep-on-exit, deep sleep)", SCS_BASE + off, 1, v);
		return;
	case 0xD14:
		m->ccr = v;
		return;
	case 0xD24:
		m->shcsr = v;
		return;
	case 0xD28:
		m->cfsr &= ~v; /* write 1 to clear */
		return;
	case 0xD2C:
		m->hfsr &= ~v;
		return;
	case 0xD38:
		m->bfar = v;
		return;
	case 0xD88:
		m->cpacr = v;
		return;
	case 0xDFC:
		m->demcr = v;
		return;
	case 0xF34:
		c->fpccr = v;
		return;
	default:
		mcu_unmodelled(m, "SCS", SCS_BASE + off, 1, v);
	}
}

/* DWT (C1.8): CTRL (NUMCOMP 4, CYCCNT present) and CYCCNT, counting the CPU's cycles while
 * DEMCR.TRCENA and CTRL.CYCCNTENA are set; the comparators and profiling counters are not modelled. */
static uint32_t dwt_now(struct mcu *m, struct scs *c)
{
	return c->cyccnt_on ? c->dwt_cyccnt0 + (uint32_t)(m->cycles - c->cycles0) : c->dwt_cyccnt0;
}

static void dwt_update(struct mcu *m, struct scs *c)
{
	int on = (m->demcr & DEMCR_TRCENA) && (m->dwt_ctrl & DWT_CTRL_CYCCNTENA);

	c->dwt_cyccnt0 = dwt_now(m, c);
	c->cycles0 = m->cycles;
	c->cyccnt_on = on;
}

static uint32_t dwt_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct scs *c = ctx;

	(void)size;
	if (off == 0)
		return DWT_CTRL_NUMCOMP_4 | m->dwt_ctrl;
	if (off == 4) {
		int on = (m->demcr & DEMCR_TRCENA) && (m->dwt_ctrl & DWT_CTRL_CYCCNTENA);

		if (on != c->cyccnt_on)
			dwt_update(m, c);
		return dwt_now(m, c);
	}
	mcu_unmodelled(m, "DWT", DWT_BASE + off, 0, 0);
	return 0;
}

static void dwt_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct scs *c = ctx;

	(void)size;
	if (off == 0) {
		dwt_update(m, c);
		m->dwt_ctrl = v & 0x1FFFu;
		dwt_update(m, c);
	} else if (off == 4) {
		dwt_update(m, c);
		c->dwt_cyccnt0 = v;
	} else {
		mcu_unmodelled(m, "DWT", DWT_BASE + off, 1, v);
	}
}

static void scs_reset(struct mcu *m, void *ctx)
{
	struct scs *c = ctx;

	*c = (struct scs){ .fpccr = 0xC0000000u };
	c->st.per = m->clk.units_per_cycle * 8u;
	c->st.next_zero = MCU_NEVER;
}

int mcu_scs_add(struct mcu *m)
{
	struct scs *c = &scs_state;
	const struct mcu_periph scs = {
		"SCS", SCS_BASE, 0x1000, c, scs_read, scs_write, scs_advance, scs_next_event, 0
	};
	const struct mcu_periph dwt = { "DWT", DWT_BASE, 0x1000, c, dwt_read, dwt_write, 0, 0, 0 };

	scs_reset(m, c);
	m->ccr = 0x200u; /* STKALIGN */
	return mcu_add_periph(m, &scs) || mcu_add_periph(m, &dwt) || mcu_on_system_reset(m, scs_reset, c) ? -1 : 0;
}
