/* The STM32F405's own peripherals that the image touches, at register level (RM0090, rev 19):
 * RCC (section 7.3), the flash interface's ACR (3.9), PWR (5.4), GPIO A..I (8.4), TIM2 (18.4), IWDG
 * (19.4), USART1/2/3/6 (30.6) and SYSCFG (9.2). Registers the image writes and reads back hold their
 * values; the behaviour is what the image waits for or measures: oscillators and the PLL that become
 * ready, the system clock switch, the timer's update events, the watchdog's timeout and the console's
 * transmit flags. */
#include <string.h>

#include "mcu.h"

#define RCC_BASE 0x40023800u
#define FLASH_IF_BASE 0x40023C00u
#define PWR_BASE 0x40007000u
#define GPIO_BASE 0x40020000u
#define TIM2_BASE 0x40000000u
#define IWDG_BASE 0x40003000u
#define SYSCFG_BASE 0x40013800u

#define HSI_HZ 16000000u
#define LSI_HZ 32000u /* nominal (datasheet: 17..47 kHz); the watchdog's timing follows it */
#define PLL_LOCK_US 100u /* PLLRDY this long after PLLON (datasheet: PLL lock time, up to 100 us) */

#define US(m) ((uint64_t)(m) * (MCU_TIME_HZ / 1000000u))

/* ---- RCC (7.3): oscillators, PLL, clock switch, enables; CSR's reset flags ---- */

#define CR_HSION (1u << 0)
#define CR_HSIRDY (1u << 1)
#define CR_HSEON (1u << 16)
#define CR_HSERDY (1u << 17)
#define CR_PLLON (1u << 24)
#define CR_PLLRDY (1u << 25)
#define CSR_LSION (1u << 0)
#define CSR_LSIRDY (1u << 1)
#define CSR_RMVF (1u << 24)
#define CSR_PORRSTF (1u << 27)
#define CSR_PINRSTF (1u << 26)

struct rcc {
	uint32_t r[0x90 / 4];
	uint64_t hse_ready_at, pll_ready_at; /* MCU_NEVER: not coming */
	uint32_t hse_hz, hse_delay_us;
	uint32_t sws; /* the source in use: 0 HSI, 1 HSE, 2 PLL */
};

#define RCC_CR 0
#define RCC_PLLCFGR 1
#define RCC_CFGR 2
#define RCC_CSR (0x74 / 4)

static uint32_t ahb_div(uint32_t hpre)
{
	static const uint32_t d[8] = { 2, 4, 8, 16, 64, 128, 256, 512 };

	return hpre & 8u ? d[hpre & 7u] : 1u;
}

static uint32_t apb_div(uint32_t ppre)
{
	return ppre & 4u ? 2u << (ppre & 3u) : 1u;
}

/* The clocks from the source in use and the prescalers (7.2, figure 21). */
static void rcc_clocks(struct mcu *m, struct rcc *c)
{
	uint32_t cfgr = c->r[RCC_CFGR], pll = c->r[RCC_PLLCFGR], src_hz, sys, hclk, d1, d2;

	if (c->sws == 2) {
		uint32_t pm = pll & 0x3Fu, pn = (pll >> 6) & 0x1FFu, pp = 2u * (((pll >> 16) & 3u) + 1u);

		src_hz = pll & (1u << 22) ? c->hse_hz : HSI_HZ;
		sys = pm ? (uint32_t)((uint64_t)src_hz / pm * pn / pp) : HSI_HZ;
	} else {
		sys = c->sws == 1 ? c->hse_hz : HSI_HZ;
	}
	hclk = sys / ahb_div((cfgr >> 4) & 0xFu);
	d1 = apb_div((cfgr >> 10) & 7u);
	d2 = apb_div((cfgr >> 13) & 7u);
	m->clk.sysclk_hz = hclk;
	m->clk.pclk1_hz = hclk / d1;
	m->clk.pclk2_hz = hclk / d2;
	m->clk.tim_apb1_hz = d1 == 1 ? hclk : 2u * (hclk / d1);
	if (!hclk || MCU_TIME_HZ % hclk) {
		fprintf(m->report, "swell-mcu: HCLK %u Hz does not divide the %llu Hz time base: timing rounded\n",
			hclk, (unsigned long long)MCU_TIME_HZ);
	}
	m->clk.units_per_cycle = hclk ? (uint32_t)(MCU_TIME_HZ / hclk) : 21u;
	if (!m->clk.units_per_cycle)
		m->clk.units_per_cycle = 1;
}

static void rcc_advance(struct mcu *m, void *ctx, uint64_t now)
{
	struct rcc *c = ctx;
	uint32_t *cr = &c->r[RCC_CR], sw = c->r[RCC_CFGR] & 3u;

	if (now >= c->hse_ready_at) {
		*cr |= CR_HSERDY;
		c->hse_ready_at = MCU_NEVER;
	}
	if (now >= c->pll_ready_at) {
		*cr |= CR_PLLRDY;
		c->pll_ready_at = MCU_NEVER;
	}
	/* SWS follows SW once the source is ready (7.3.3) */
	if (sw != c->sws &&
	    ((sw == 0 && (*cr & CR_HSIRDY)) || (sw == 1 && (*cr & CR_HSERDY)) || (sw == 2 && (*cr & CR_PLLRDY)))) {
		c->sws = sw;
		rcc_clocks(m, c);
	}
}

static uint64_t rcc_next_event(struct mcu *m, void *ctx)
{
	struct rcc *c = ctx;

	(void)m;
	return c->hse_ready_at < c->pll_ready_at ? c->hse_ready_at : c->pll_ready_at;
}

static uint32_t rcc_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct rcc *c = ctx;

	(void)size;
	if (off / 4 >= sizeof(c->r) / 4) {
		mcu_unmodelled(m, "RCC", RCC_BASE + off, 0, 0);
		return 0;
	}
	if (off / 4 == RCC_CFGR)
		return (c->r[RCC_CFGR] & ~0xCu) | c->sws << 2;
	return c->r[off / 4];
}

static void rcc_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct rcc *c = ctx;
	uint32_t *cr = &c->r[RCC_CR];

	(void)size;
	if (off / 4 >= sizeof(c->r) / 4) {
		mcu_unmodelled(m, "RCC", RCC_BASE + off, 1, v);
		return;
	}
	switch (off / 4) {
	case RCC_CR: {
		uint32_t was = *cr;

		*cr = (v & ~(CR_HSIRDY | CR_HSERDY | CR_PLLRDY | (1u << 27))) |
			(was & (CR_HSIRDY | CR_HSERDY | CR_PLLRDY));
		if (!(v & CR_HSEON)) {
			*cr &= ~CR_HSERDY;
			c->hse_ready_at = MCU_NEVER;
		} else if (!(was & CR_HSEON) && c->hse_hz) {
			c->hse_ready_at = m->now + US(c->hse_delay_us);
		}
		if (!(v & CR_PLLON)) {
			*cr &= ~CR_PLLRDY;
			c->pll_ready_at = MCU_NEVER;
		} else if (!(was & CR_PLLON)) {
			uint32_t src_ready = c->r[RCC_PLLCFGR] & (1u << 22) ? (*cr & CR_HSERDY) : (*cr & CR_HSIRDY);

			c->pll_ready_at = src_ready ? m->now + US(PLL_LOCK_US) : MCU_NEVER;
		}
		*cr |= CR_HSIRDY; /* HSI is on from reset and the image never turns it off */
		break;
	}
	case RCC_CSR:
		c->r[RCC_CSR] = (c->r[RCC_CSR] & 0xFE000000u) | (v & 0x01000001u) | ((v & CSR_LSION) ? CSR_LSIRDY : 0);
		if (v & CSR_RMVF)
			c->r[RCC_CSR] &= ~(0xFE000000u | CSR_RMVF);
		break;
	case 0x10 / 4:
	case 0x14 / 4:
	case 0x18 / 4:
	case 0x20 / 4:
	case 0x24 / 4: /* reset registers: a bit going to 1 resets its peripheral's model */
		for (unsigned i = 0; i < m->n_rcc_reset; i++)
			if (m->rcc_reset[i].off == off && (v & m->rcc_reset[i].bit) &&
			    !(c->r[off / 4] & m->rcc_reset[i].bit))
				m->rcc_reset[i].fn(m, m->rcc_reset[i].ctx);
		c->r[off / 4] = v;
		break;
	default:
		for (unsigned i = 0; i < m->n_rcc_enable; i++)
			if (m->rcc_enable[i].off == off && ((v ^ c->r[off / 4]) & m->rcc_enable[i].bit))
				m->rcc_enable[i].fn(m, m->rcc_enable[i].ctx, (v & m->rcc_enable[i].bit) != 0);
		c->r[off / 4] = v;
	}
	rcc_advance(m, c, m->now);
}

/* ---- FLASH interface (3.9.1: ACR) and PWR (5.4.1: CR, CSR) ---- */

struct plain_regs {
	const char *name;
	uint32_t base, n_modelled;
	uint32_t r[8];
};

static uint32_t plain_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct plain_regs *p = ctx;

	(void)size;
	if (off / 4 >= p->n_modelled) {
		mcu_unmodelled(m, p->name, p->base + off, 0, 0);
		return 0;
	}
	return p->r[off / 4];
}

static void plain_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct plain_regs *p = ctx;

	(void)size;
	if (off / 4 >= p->n_modelled) {
		mcu_unmodelled(m, p->name, p->base + off, 1, v);
		return;
	}
	p->r[off / 4] = v;
	if (p->base == PWR_BASE && off == 0)
		p->r[1] |= 1u << 14; /* CSR.VOSRDY: the regulator scale is ready at once */
}

/* ---- GPIO (8.4): the registers, ODR through BSRR; IDR reads the output latch of output pins ---- */

struct gpio {
	uint32_t r[10]; /* MODER OTYPER OSPEEDR PUPDR IDR ODR BSRR LCKR AFRL AFRH */
	uint32_t port;
};

static uint32_t gpio_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct gpio *g = ctx;
	uint32_t out = 0;

	(void)size;
	if (off / 4 >= 10) {
		mcu_unmodelled(m, "GPIO", GPIO_BASE + 0x400u * g->port + off, 0, 0);
		return 0;
	}
	if (off == 0x10) { /* IDR: outputs read back; inputs are not driven (read 0) */
		for (unsigned p = 0; p < 16; p++)
			if (((g->r[0] >> (2 * p)) & 3u) == 1u)
				out |= g->r[5] & (1u << p);
		return out;
	}
	if (off == 0x18)
		return 0; /* BSRR is write-only */
	return g->r[off / 4];
}

static void gpio_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct gpio *g = ctx;

	(void)size;
	if (off / 4 >= 10) {
		mcu_unmodelled(m, "GPIO", GPIO_BASE + 0x400u * g->port + off, 1, v);
		return;
	}
	if (off == 0x18) {
		g->r[5] = (g->r[5] | (v & 0xFFFFu)) & ~((v >> 16) & ~v & 0xFFFFu); /* set wins over reset */
		return;
	}
	if (off != 0x10)
		g->r[off / 4] = v;
}

/* ---- TIM2 (18.4), up-counting: CNT from virtual time, update events at overflow ---- */

#define TIM_CR1_CEN 1u
#define TIM_CR1_UDIS 2u
#define TIM_CR1_URS 4u
#define TIM_SR_UIF 1u
#define TIM2_IRQ 28u

struct tim {
	uint32_t cr1, dier, sr, psc, psc_active, arr, cnt0;
	uint64_t t0, per; /* CNT = cnt0 + (now - t0) / per while counting */
	uint64_t next_update;
	uint64_t stop_at; /* injected: the counter stops here (MCU_NEVER: never) */
	uint32_t other[24]; /* CR2, SMCR, CCMRx, CCER, CCRx, ... held, not modelled */
};

static uint64_t tim_per(struct mcu *m, const struct tim *t)
{
	uint64_t clk = m->clk.tim_apb1_hz ? m->clk.tim_apb1_hz : HSI_HZ;

	return (uint64_t)(t->psc_active + 1u) * (MCU_TIME_HZ / clk);
}

static uint64_t tim_counts(const struct tim *t, uint64_t now)
{
	if (now > t->stop_at)
		now = t->stop_at;
	return (t->cr1 & TIM_CR1_CEN) && now > t->t0 ? (now - t->t0) / t->per : 0u;
}

/* The counts from cnt0 to the next overflow (ARR -> 0). */
static uint64_t tim_to_overflow(const struct tim *t)
{
	if (t->cnt0 <= t->arr)
		return (uint64_t)t->arr + 1u - t->cnt0;
	return ((uint64_t)1 << 32) - t->cnt0 + t->arr + 1u;
}

/* Keep the prescaler's phase: t0 moves by whole counts. */
static void tim_rebase(struct mcu *m, struct tim *t)
{
	uint64_t k = tim_counts(t, m->now);

	t->cnt0 = (uint32_t)(t->cnt0 + k);
	t->t0 += k * t->per;
	if (!(t->cr1 & TIM_CR1_CEN) || t->t0 > m->now)
		t->t0 = m->now;
	t->next_update = (t->cr1 & TIM_CR1_CEN) ? t->t0 + tim_to_overflow(t) * t->per : MCU_NEVER;
}

static void tim_irq(struct mcu *m, const struct tim *t)
{
	mcu_irq_line(m, TIM2_IRQ, (t->sr & t->dier & TIM_SR_UIF) != 0);
}

static void tim_advance(struct mcu *m, void *ctx, uint64_t now)
{
	struct tim *t = ctx;

	while (t->next_update <= now && t->next_update <= t->stop_at) {
		/* update event: CNT 0, the prescaler's preload taken, UIF unless UDIS */
		t->t0 = t->next_update;
		t->cnt0 = 0;
		t->psc_active = t->psc;
		t->per = tim_per(m, t);
		if (!(t->cr1 & TIM_CR1_UDIS))
			t->sr |= TIM_SR_UIF;
		t->next_update = t->t0 + tim_to_overflow(t) * t->per;
	}
	tim_irq(m, t);
}

static uint64_t tim_next_event(struct mcu *m, void *ctx)
{
	const struct tim *t = ctx;

	(void)m;
	return t->next_update <= t->stop_at ? t->next_update : MCU_NEVER;
}

static uint32_t tim_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct tim *t = ctx;

	(void)size;
	switch (off) {
	case 0x00:
		return t->cr1;
	case 0x0C:
		return t->dier;
	case 0x10:
		return t->sr;
	case 0x14:
		return 0;
	case 0x24:
		return (uint32_t)(t->cnt0 + tim_counts(t, m->now));
	case 0x28:
		return t->psc;
	case 0x2C:
		return t->arr;
	default:
		if (off < 0x60) {
			mcu_unmodelled(m, "TIM2 (held, not modelled)", TIM2_BASE + off, 0, 0);
			return t->other[off / 4 % 24];
		}
		mcu_unmodelled(m, "TIM2", TIM2_BASE + off, 0, 0);
		return 0;
	}
}

static void tim_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct tim *t = ctx;

	(void)size;
	tim_rebase(m, t);
	switch (off) {
	case 0x00:
		if (v & ~(TIM_CR1_CEN | TIM_CR1_UDIS | TIM_CR1_URS | (1u << 7)))
			mcu_unmodelled(m, "TIM2 CR1 (one-pulse, down or centre counting)", TIM2_BASE, 1, v);
		t->cr1 = v & 0x3FFu;
		t->per = tim_per(m, t);
		break;
	case 0x0C:
		if (v & ~TIM_SR_UIF)
			mcu_unmodelled(m, "TIM2 DIER (capture/compare, DMA, trigger)", TIM2_BASE + off, 1, v);
		t->dier = v;
		break;
	case 0x10:
		t->sr &= v; /* rc_w0 */
		break;
	case 0x14:
		if (v & 1u) { /* UG: re-initialise the counter, load the preloads; UIF unless URS */
			t->cnt0 = 0;
			t->psc_active = t->psc;
			t->per = tim_per(m, t);
			t->t0 = m->now;
			if (!(t->cr1 & TIM_CR1_URS) && !(t->cr1 & TIM_CR1_UDIS))
				t->sr |= TIM_SR_UIF;
		}
		if (v & ~1u)
			mcu_unmodelled(m, "TIM2 EGR (capture/compare, trigger)", TIM2_BASE + off, 1, v);
		break;
	case 0x24:
		t->cnt0 = v;
		t->t0 = m->now;
		break;
	case 0x28:
		t->psc = v & 0xFFFFu; /* taken at the next update event */
		break;
	case 0x2C:
		t->arr = v; /* ARPE = 0: at once (ARPE = 1 would buffer it; the image leaves it 0) */
		break;
	default:
		mcu_unmodelled(m, "TIM2 (held, not modelled)", TIM2_BASE + off, 1, v);
		if (off < 0x60)
			t->other[off / 4 % 24] = v;
	}
	tim_rebase(m, t);
	tim_irq(m, t);
}

/* ---- IWDG (19.4): a down counter on the LSI; a reset when it reaches 0 ---- */

#define IWDG_PVU 1u
#define IWDG_RVU 2u
#define IWDG_UPDATE_LSI 5u /* SR.PVU/RVU stay set this many LSI periods after a write (19.4.4) */

struct iwdg {
	int running, unlocked;
	uint32_t pr, rlr, sr;
	uint64_t bite_at, sr_clear_at, last_reload;
};

static uint64_t lsi_units(void)
{
	return MCU_TIME_HZ / LSI_HZ;
}

static void iwdg_reload(struct mcu *m, struct iwdg *w)
{
	uint32_t div = 4u << (w->pr > 6 ? 6 : w->pr);

	w->last_reload = m->now;
	w->bite_at = m->now + (uint64_t)(w->rlr + 1u) * div * lsi_units();
}

static void iwdg_advance(struct mcu *m, void *ctx, uint64_t now)
{
	struct iwdg *w = ctx;

	if (now >= w->sr_clear_at) {
		w->sr = 0;
		w->sr_clear_at = MCU_NEVER;
	}
	if (w->running && now >= w->bite_at && !m->watchdog_bit) {
		m->watchdog_bit = 1;
		m->now = w->bite_at;
		fprintf(m->report, "swell-mcu: watchdog reset at %.6f s: the IWDG was last refreshed at %.6f s\n",
			mcu_seconds(w->bite_at), mcu_seconds(w->last_reload));
	}
}

static uint64_t iwdg_next_event(struct mcu *m, void *ctx)
{
	struct iwdg *w = ctx;
	uint64_t t = w->running ? w->bite_at : MCU_NEVER;

	(void)m;
	return w->sr_clear_at < t ? w->sr_clear_at : t;
}

static uint32_t iwdg_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct iwdg *w = ctx;

	(void)size;
	switch (off) {
	case 0x0:
		return 0;
	case 0x4:
		return w->pr;
	case 0x8:
		return w->rlr;
	case 0xC:
		return w->sr;
	default:
		mcu_unmodelled(m, "IWDG", IWDG_BASE + off, 0, 0);
		return 0;
	}
}

static void iwdg_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct iwdg *w = ctx;

	(void)size;
	switch (off) {
	case 0x0:
		v &= 0xFFFFu;
		w->unlocked = v == 0x5555u;
		if (v == 0xCCCCu && !w->running) {
			w->running = 1;
			iwdg_reload(m, w);
		} else if (v == 0xAAAAu && w->running) {
			iwdg_reload(m, w);
			m->iwdg_refreshes++;
		}
		break;
	case 0x4:
	case 0x8:
		if (!w->unlocked)
			break; /* write-protected without the 0x5555 key */
		if (off == 0x4)
			w->pr = v & 7u;
		else
			w->rlr = v & 0xFFFu;
		w->sr |= off == 0x4 ? IWDG_PVU : IWDG_RVU;
		w->sr_clear_at = m->now + IWDG_UPDATE_LSI * lsi_units();
		break;
	default:
		mcu_unmodelled(m, "IWDG", IWDG_BASE + off, 1, v);
	}
}

/* ---- USART (30.6): transmitter only; a character takes 10 bit times of BRR / fPCLK ---- */

#define USART_TXE (1u << 7)
#define USART_TC (1u << 6)
#define USART_UE (1u << 13)
#define USART_TE (1u << 3)

struct usart {
	uint32_t base, apb2;
	uint32_t brr, cr1, cr2, cr3, gtpr;
	int tdr_full, shifting;
	uint8_t tdr;
	uint64_t shift_done;
	FILE *out;
};

static uint64_t usart_char_units(struct mcu *m, const struct usart *u)
{
	uint32_t pclk = u->apb2 ? m->clk.pclk2_hz : m->clk.pclk1_hz;
	uint32_t brr = u->brr ? u->brr : 16u;

	return (uint64_t)10u * brr * (MCU_TIME_HZ / (pclk ? pclk : HSI_HZ));
}

static void usart_shift(struct mcu *m, struct usart *u, uint8_t byte, uint64_t at)
{
	if (u->out) {
		fputc(byte, u->out);
		if (byte == '\n')
			fflush(u->out);
	}
	u->shifting = 1;
	u->shift_done = at + usart_char_units(m, u);
}

static void usart_advance(struct mcu *m, void *ctx, uint64_t now)
{
	struct usart *u = ctx;

	while (u->shifting && now >= u->shift_done) {
		u->shifting = 0;
		if (u->tdr_full) {
			u->tdr_full = 0;
			usart_shift(m, u, u->tdr, u->shift_done);
		}
	}
}

static uint64_t usart_next_event(struct mcu *m, void *ctx)
{
	struct usart *u = ctx;

	(void)m;
	return u->shifting ? u->shift_done : MCU_NEVER;
}

static uint32_t usart_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct usart *u = ctx;

	(void)size;
	switch (off) {
	case 0x00:
		return (u->tdr_full ? 0 : USART_TXE) | (u->shifting || u->tdr_full ? 0 : USART_TC);
	case 0x04:
		return 0; /* nothing received: the receiver is not modelled */
	case 0x08:
		return u->brr;
	case 0x0C:
		return u->cr1;
	case 0x10:
		return u->cr2;
	case 0x14:
		return u->cr3;
	case 0x18:
		return u->gtpr;
	default:
		mcu_unmodelled(m, "USART", u->base + off, 0, 0);
		return 0;
	}
}

static void usart_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct usart *u = ctx;

	(void)size;
	switch (off) {
	case 0x00:
		break; /* the flags here are read-only or cleared by the sequence above */
	case 0x04:
		if (!(u->cr1 & USART_UE) || !(u->cr1 & USART_TE))
			break;
		if (!u->shifting)
			usart_shift(m, u, (uint8_t)v, m->now);
		else if (!u->tdr_full) {
			u->tdr = (uint8_t)v;
			u->tdr_full = 1;
		} /* a write with TXE clear overwrites nothing on silicon either: lost */
		break;
	case 0x08:
		u->brr = v & 0xFFFFu;
		break;
	case 0x0C:
		if (v & 0x1F4u) /* RE, RXNEIE, TCIE, TXEIE, PEIE... */
			mcu_unmodelled(m, "USART CR1 (receiver or interrupts)", u->base + off, 1, v);
		u->cr1 = v;
		break;
	case 0x10:
		u->cr2 = v;
		break;
	case 0x14:
		u->cr3 = v;
		break;
	case 0x18:
		u->gtpr = v;
		break;
	default:
		mcu_unmodelled(m, "USART", u->base + off, 1, v);
	}
}

/* ---- the set ---- */

static struct {
	struct mcu_stm32_opts opts;
	struct rcc rcc;
	struct plain_regs flash, pwr, syscfg;
	struct gpio gpio[9];
	struct tim tim2;
	struct iwdg iwdg;
	struct usart usart[4];
} st32; /* one emulated MCU per process */

/* Power-on or system reset (RM0090 7.1): the reset values; RCC_CSR keeps its flags and gains the
 * reset's own (power-on and pin at power-on). An injected TIM2 stop lasts until a reset. */
static void stm32_reset(struct mcu *m, void *ctx)
{
	static const uint32_t usart_base[4] = { 0x40011000u, 0x40004400u, 0x40004800u, 0x40011400u };
	static const uint32_t gpio_moder[9] = { 0xA8000000u, 0x00000280u };
	const struct mcu_stm32_opts *o = &st32.opts;
	uint32_t csr = m->resets ? (st32.rcc.r[RCC_CSR] & 0xFE000000u) | m->reset_flags : CSR_PORRSTF | CSR_PINRSTF;

	(void)ctx;
	memset(&st32.rcc, 0, sizeof(st32.rcc));
	st32.rcc.r[RCC_CR] = 0x83u | CR_HSIRDY;
	st32.rcc.r[RCC_PLLCFGR] = 0x24003010u;
	st32.rcc.r[0x30 / 4] = 0x00100000u; /* AHB1ENR: CCMDATARAMEN */
	st32.rcc.r[RCC_CSR] = csr;
	st32.rcc.hse_hz = o->hse_hz;
	st32.rcc.hse_delay_us = o->hse_delay_us;
	st32.rcc.hse_ready_at = st32.rcc.pll_ready_at = MCU_NEVER;
	st32.flash = (struct plain_regs){ "FLASH", FLASH_IF_BASE, 1, { 0 } }; /* ACR only */
	st32.pwr = (struct plain_regs){ "PWR", PWR_BASE, 2, { 0x4000u, 0 } };
	st32.syscfg = (struct plain_regs){ "SYSCFG", SYSCFG_BASE, 1, { 0 } }; /* MEMRMP only */
	st32.tim2 = (struct tim){ .arr = 0xFFFFFFFFu, .next_update = MCU_NEVER, .per = 1 };
	st32.tim2.stop_at = m->resets ? MCU_NEVER : m->tim2_stop_at;
	st32.iwdg = (struct iwdg){ .rlr = 0xFFFu, .bite_at = MCU_NEVER, .sr_clear_at = MCU_NEVER };
	for (unsigned i = 0; i < 9; i++)
		st32.gpio[i] = (struct gpio){ .port = i, .r = { gpio_moder[i] } };
	for (unsigned i = 0; i < 4; i++)
		st32.usart[i] = (struct usart){ .base = usart_base[i], .apb2 = i == 0 || i == 3, .out = o->console };
	mcu_irq_line(m, TIM2_IRQ, 0);
}

int mcu_stm32_add(struct mcu *m, const struct mcu_stm32_opts *o)
{
	static const uint32_t usart_base[4] = { 0x40011000u, 0x40004400u, 0x40004800u, 0x40011400u };
	static const char *const usart_name[4] = { "USART1", "USART2", "USART3", "USART6" };
	static const char *const gpio_name[9] = { "GPIOA", "GPIOB", "GPIOC", "GPIOD", "GPIOE",
						  "GPIOF", "GPIOG", "GPIOH", "GPIOI" };
	int err = 0;

	memset(&st32, 0, sizeof(st32));
	st32.opts = *o;
	stm32_reset(m, &st32);
	{
		const struct mcu_periph p[] = {
			{ "RCC", RCC_BASE, 0x400, &st32.rcc, rcc_read, rcc_write, rcc_advance, rcc_next_event, 0 },
			{ "FLASH", FLASH_IF_BASE, 0x400, &st32.flash, plain_read, plain_write, 0, 0, 0 },
			{ "PWR", PWR_BASE, 0x400, &st32.pwr, plain_read, plain_write, 0, 0, 0 },
			{ "SYSCFG", SYSCFG_BASE, 0x400, &st32.syscfg, plain_read, plain_write, 0, 0, 0 },
			{ "TIM2", TIM2_BASE, 0x400, &st32.tim2, tim_read, tim_write, tim_advance, tim_next_event, 0 },
			{ "IWDG", IWDG_BASE, 0x400, &st32.iwdg, iwdg_read, iwdg_write, iwdg_advance, iwdg_next_event,
			  0 },
		};

		for (size_t i = 0; i < sizeof(p) / sizeof(p[0]); i++)
			err |= mcu_add_periph(m, &p[i]);
	}
	for (unsigned i = 0; i < 9; i++) {
		const struct mcu_periph p = {
			gpio_name[i], GPIO_BASE + 0x400u * i, 0x400, &st32.gpio[i], gpio_read, gpio_write, 0, 0, 0
		};

		err |= mcu_add_periph(m, &p);
	}
	for (unsigned i = 0; i < 4; i++) {
		const struct mcu_periph p = { usart_name[i],  usart_base[i],    0x400,
					      &st32.usart[i], usart_read,       usart_write,
					      usart_advance,  usart_next_event, 0 };

		err |= mcu_add_periph(m, &p);
	}
	return err || mcu_on_system_reset(m, stm32_reset, &st32) ? -1 : 0;
}
