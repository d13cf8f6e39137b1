/* The CPU: unicorn's Cortex-M4 (Thumb-2, FPv4-SP) with the memory map, virtual time and the exception
 * model the emulator adds (unicorn executes instructions; it neither takes nor returns from
 * exceptions on an M-profile core by itself).
 *
 * Memory (RM0090 section 2.3, figure 5): flash 1 MiB at 0x08000000, aliased at 0 (BOOT0 low); SRAM1
 * and SRAM2, 128 KiB at 0x20000000; CCM data RAM 64 KiB at 0x10000000; system memory at 0x1FFF0000
 * reads 0 (the ROM bootloader is not modelled: the image finds no bootloader's vector table there and
 * starts itself, as its boot code expects of a part without one). Peripheral blocks are models
 * (mcu_add_periph); an access to a peripheral address nothing models reads 0, is dropped if a write,
 * and is reported once.
 *
 * Time: each instruction is charged cpi_milli / 1000 cycles before it executes (a code hook: it
 * costs about 10 % over unicorn's own speed and keeps the PC exact in the peripheral models); the
 * block hook stops the CPU at the start of the first translated block after virtual time reaches the
 * next event. Exceptions are taken there, between blocks, so a run is the same bit for bit each time. WFI (ARMv7-M ARM B1.5.19): the CPU sleeps until an
 * exception that would preempt ignoring PRIMASK is pending; virtual time jumps to the next event,
 * CYCCNT does not count (the core clock is gated in Sleep mode, RM0090 5.3.3).
 *
 * Exceptions (ARMv7-M ARM B1.5): the emulator keeps the active exceptions and their priorities (and
 * sets the CPU's IPSR to the active one, which only MRS reads: unicorn takes the handler mode's
 * EXC_RETURN branch to the same exception-exit trap and leaves the return to us), stacks the frame
 * (B1.5.6 PushStack: 8 words r0-r3, r12, lr, return address, xPSR on MSP, 8-byte aligned with xPSR
 * bit 9 recording the padding; the extended 26-word frame with s0-s15 and FPSCR when CONTROL.FPCA is
 * set), sets LR to EXC_RETURN and PC to the vector at VTOR. A branch to an EXC_RETURN value reaches
 * unicorn's exception-exit trap (it fakes one at the magic addresses), where the emulator unstacks
 * (B1.5.8) or tail-chains into a pending exception that may preempt the context returned to.
 * The image executes FP instructions (VLDR/VSTR of doubles, in the solver and the body's code) from
 * thread mode and from the tick interrupt, so FP state can be live when an interrupt comes: the
 * extended frame is stacked at entry, as with FPCCR.LSPEN = 0 (no lazy stacking; the image never
 * reads FPCCR, so the difference is not visible to it). Execution priority (B1.5.4): the group
 * priority of the active exceptions, PRIMASK (0) and BASEPRI, with AIRCR.PRIGROUP splitting group and
 * subpriority; among pending exceptions the lowest priority value wins, then the lowest number. */
#include <stdlib.h>
#include <string.h>

#include "mcu.h"

#define FLASH_BASE 0x08000000u
#define FLASH_SIZE (1024u * 1024u)
#define SRAM_BASE 0x20000000u
#define SRAM_SIZE (128u * 1024u)
#define CCM_BASE 0x10000000u
#define CCM_SIZE (64u * 1024u)
#define SYSMEM_BASE 0x1FFF0000u /* system memory: the ST ROM bootloader, not modelled (reads 0) */
#define SYSMEM_SIZE 0x8000u
#define EXC_RETURN_PAGE 0xFFFFF000u

#define QEMU_EXCP_EXCEPTION_EXIT 8 /* unicorn's interrupt number of a return through EXC_RETURN */

struct cpu_state {
	uint8_t *flash;
	uc_hook h_block, h_code, h_intr, h_unmapped;
	uint64_t stop_at; /* the block start the CPU stops at, before its first instruction (UINT64_MAX: none) */
	void *unmodelled_pages[64]; /* the pages mapped for unmodelled peripheral addresses, freed at the end */
	unsigned n_unmodelled_pages;
};

static struct cpu_state *state_of(struct mcu *m)
{
	return (struct cpu_state *)m->cpu;
}

static uint32_t reg(struct mcu *m, int r)
{
	uint32_t v = 0;

	uc_reg_read(m->uc, r, &v);
	return v;
}

static void set_reg(struct mcu *m, int r, uint32_t v)
{
	uc_reg_write(m->uc, r, &v);
}

static uint32_t rd32(struct mcu *m, uint32_t addr, int *ok)
{
	uint8_t b[4];

	if (uc_mem_read(m->uc, addr, b, 4) != UC_ERR_OK) {
		*ok = 0;
		return 0;
	}
	return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

static void wr32(struct mcu *m, uint32_t addr, uint32_t v, int *ok)
{
	uint8_t b[4] = { (uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24) };

	if (uc_mem_write(m->uc, addr, b, 4) != UC_ERR_OK)
		*ok = 0;
}

/* ---- time ---- */

static void charge(struct mcu *m, uint32_t ninsn)
{
	uint64_t milli = (uint64_t)ninsn * m->cpi_milli + m->cpi_acc;
	uint64_t cyc = milli / 1000u;

	m->cpi_acc = (uint32_t)(milli % 1000u);
	m->cycles += cyc;
	m->now += cyc * m->clk.units_per_cycle;
	m->insns += ninsn;
}

static int primask_set(struct mcu *m)
{
	return reg(m, UC_ARM_REG_PRIMASK) & 1u;
}

/* Group priority of a priority value (B1.5.4): the bits above the PRIGROUP split. */
static int group_of(const struct mcu *m, int prio)
{
	if (prio < 0)
		return prio;
	return prio & ~(int)((2u << m->nvic.prigroup) - 1u);
}

static int prio_of(const struct mcu *m, unsigned exc)
{
	if (exc == 2)
		return -2; /* NMI */
	if (exc == 3)
		return -1; /* HardFault */
	return m->nvic.prio[exc];
}

/* Execution priority (B1.5.4): the active exceptions' group priorities, BASEPRI, PRIMASK. */
static int exec_prio(struct mcu *m, int with_primask, unsigned skip_top)
{
	int p = 256;
	uint32_t basepri;

	for (uint32_t i = 0; i + skip_top < m->nvic.depth; i++) {
		int g = group_of(m, prio_of(m, m->nvic.stack[i]));

		if (g < p)
			p = g;
	}
	basepri = reg(m, UC_ARM_REG_BASEPRI) & 0xF0u;
	if (basepri && group_of(m, (int)basepri) < p)
		p = group_of(m, (int)basepri);
	if (with_primask && primask_set(m) && p > 0)
		p = 0;
	return p;
}

/* Level-sensitive lines pend their interrupt while asserted and not active (B3.4.1). */
static void latch_lines(struct mcu *m)
{
	for (unsigned e = 16; e < MCU_EXCS; e++)
		if (m->nvic.line[e] && !m->nvic.active[e])
			m->nvic.pending[e] = 1;
}

/* The pending, enabled exception that comes first (0: none). */
static unsigned first_pending(struct mcu *m)
{
	unsigned best = 0;
	int bp = 1000;

	latch_lines(m);
	for (unsigned e = 2; e < MCU_EXCS; e++) {
		int p;

		if (!m->nvic.pending[e] || (e >= 16 && !m->nvic.enabled[e]) || m->nvic.active[e])
			continue;
		p = prio_of(m, e);
		if (p < bp) {
			bp = p;
			best = e;
		}
	}
	return best;
}

void mcu_exc_pend(struct mcu *m, unsigned exc)
{
	if (exc < MCU_EXCS) {
		m->nvic.pending[exc] = 1;
		m->deadline = m->now; /* looked at from the next block on */
	}
}

void mcu_irq_line(struct mcu *m, unsigned irq, int level)
{
	if (irq >= MCU_IRQS)
		return;
	if (level && !m->nvic.line[16 + irq])
		m->deadline = m->now;
	m->nvic.line[16 + irq] = (uint8_t)(level != 0);
}

/* ---- exception entry and return ---- */

static int cpu_error(struct mcu *m, const char *what)
{
	char b[96];

	fprintf(m->report, "swell-mcu: CPU stopped at %.6f s: %s at pc %s\n", mcu_seconds(m->now), what,
		mcu_symbolize(m, reg(m, UC_ARM_REG_PC), b, sizeof(b)));
	return MCU_EXIT_CPU;
}

static void trace(struct mcu *m, const char *what, unsigned exc)
{
	if (m->trace_irq)
		fprintf(m->trace_irq, "%.9f %s %u depth %u\n", mcu_seconds(m->now), what, exc, m->nvic.depth);
}

static int vector_pc(struct mcu *m, unsigned exc, uint32_t *pc)
{
	int ok = 1;

	*pc = rd32(m, m->vtor + 4u * exc, &ok);
	return ok && (*pc & 1u) ? 0 : -1;
}

/* B1.5.6: push the frame, EXC_RETURN in LR, the handler's address in PC. */
static int exc_enter(struct mcu *m, unsigned exc)
{
	uint32_t control = reg(m, UC_ARM_REG_CONTROL), sp = reg(m, UC_ARM_REG_SP), xpsr = reg(m, UC_ARM_REG_XPSR);
	uint32_t pc = reg(m, UC_ARM_REG_PC), handler, frame, align, excret, cur;
	int fp = (control & 4u) != 0, ok = 1;
	uint32_t size = fp ? 0x68u : 0x20u;

	if ((control & 2u) && m->nvic.depth == 0)
		return cpu_error(m, "exception from thread mode on the process stack (not modelled)");
	if (vector_pc(m, exc, &handler) != 0)
		return cpu_error(m, "exception vector without the Thumb bit or outside memory");
	cur = m->nvic.depth ? m->nvic.stack[m->nvic.depth - 1] : 0u;
	align = (sp >> 2) & 1u;
	frame = (sp - size) & ~7u;
	wr32(m, frame + 0x00, reg(m, UC_ARM_REG_R0), &ok);
	wr32(m, frame + 0x04, reg(m, UC_ARM_REG_R1), &ok);
	wr32(m, frame + 0x08, reg(m, UC_ARM_REG_R2), &ok);
	wr32(m, frame + 0x0C, reg(m, UC_ARM_REG_R3), &ok);
	wr32(m, frame + 0x10, reg(m, UC_ARM_REG_R12), &ok);
	wr32(m, frame + 0x14, reg(m, UC_ARM_REG_LR), &ok);
	wr32(m, frame + 0x18, pc & ~1u, &ok);
	wr32(m, frame + 0x1C, (xpsr & 0xFFFFFC00u) | 1u << 24 | align << 9 | cur, &ok);
	if (fp) {
		for (int i = 0; i < 16; i++)
			wr32(m, frame + 0x20 + 4u * (uint32_t)i, reg(m, UC_ARM_REG_S0 + i), &ok);
		wr32(m, frame + 0x60, reg(m, UC_ARM_REG_FPSCR), &ok);
	}
	if (!ok)
		return cpu_error(m, "exception frame outside RAM (stack overflow)");
	if (m->nvic.depth)
		excret = fp ? 0xFFFFFFE1u : 0xFFFFFFF1u;
	else
		excret = fp ? 0xFFFFFFE9u : 0xFFFFFFF9u;
	set_reg(m, UC_ARM_REG_SP, frame);
	set_reg(m, UC_ARM_REG_LR, excret);
	set_reg(m, UC_ARM_REG_XPSR, (xpsr & ~0x0600FC00u) | 1u << 24); /* IT state cleared */
	set_reg(m, UC_ARM_REG_CONTROL, control & ~4u); /* FPCA = 0 in the handler */
	set_reg(m, UC_ARM_REG_PC, handler | 1u);
	set_reg(m, UC_ARM_REG_IPSR, exc);
	m->nvic.pending[exc] = 0;
	m->nvic.active[exc] = 1;
	m->nvic.stack[m->nvic.depth++] = exc;
	m->irq_taken[exc]++;
	trace(m, "enter", exc);
	return 0;
}

/* Take the first pending exception if it preempts the execution priority; 1 when one was taken. */
static int take_pending(struct mcu *m, int *rc)
{
	unsigned e = first_pending(m);

	m->pend_check = 0;
	if (!e)
		return 0;
	if (group_of(m, prio_of(m, e)) >= exec_prio(m, 1, 0)) {
		/* masked by PRIMASK or BASEPRI only: look again at every block until it is not */
		m->pend_check = group_of(m, prio_of(m, e)) < exec_prio(m, 0, 0);
		return 0;
	}
	*rc = exc_enter(m, e);
	return *rc == 0;
}

/* B1.5.8: the handler returned through EXC_RETURN; tail-chain into a pending exception that may
 * preempt the context returned to, else unstack. */
static int exc_return(struct mcu *m, uint32_t excret)
{
	unsigned top, next;
	uint32_t sp, frame, xpsr, pc, size, control;
	int ok = 1;

	if (!m->nvic.depth)
		return cpu_error(m, "EXC_RETURN with no exception active");
	if ((excret & 0xFFFFFFE0u) != 0xFFFFFFE0u || (excret & 0xFu) == 0x5u || (excret & 0xFu) == 0xDu)
		return cpu_error(m, "EXC_RETURN value not handled (process stack or reserved)");
	top = m->nvic.stack[m->nvic.depth - 1];
	if (((excret & 8u) != 0) != (m->nvic.depth == 1))
		return cpu_error(m, "EXC_RETURN mode does not match the active exceptions");
	m->nvic.active[top] = 0;
	m->nvic.depth--;
	trace(m, "return", top);
	next = first_pending(m);
	if (next && group_of(m, prio_of(m, next)) < exec_prio(m, 1, 0)) {
		uint32_t handler;

		if (vector_pc(m, next, &handler) != 0)
			return cpu_error(m, "exception vector without the Thumb bit or outside memory");
		control = reg(m, UC_ARM_REG_CONTROL);
		set_reg(m, UC_ARM_REG_CONTROL, control & ~4u);
		set_reg(m, UC_ARM_REG_LR, excret);
		set_reg(m, UC_ARM_REG_PC, handler | 1u);
		set_reg(m, UC_ARM_REG_IPSR, next);
		m->nvic.pending[next] = 0;
		m->nvic.active[next] = 1;
		m->nvic.stack[m->nvic.depth++] = next;
		m->irq_taken[next]++;
		trace(m, "tail-chain", next);
		return 0;
	}
	sp = reg(m, UC_ARM_REG_SP);
	frame = sp;
	size = (excret & 0x10u) ? 0x20u : 0x68u;
	xpsr = rd32(m, frame + 0x1C, &ok);
	pc = rd32(m, frame + 0x18, &ok);
	set_reg(m, UC_ARM_REG_R0, rd32(m, frame + 0x00, &ok));
	set_reg(m, UC_ARM_REG_R1, rd32(m, frame + 0x04, &ok));
	set_reg(m, UC_ARM_REG_R2, rd32(m, frame + 0x08, &ok));
	set_reg(m, UC_ARM_REG_R3, rd32(m, frame + 0x0C, &ok));
	set_reg(m, UC_ARM_REG_R12, rd32(m, frame + 0x10, &ok));
	set_reg(m, UC_ARM_REG_LR, rd32(m, frame + 0x14, &ok));
	if (!(excret & 0x10u)) {
		for (int i = 0; i < 16; i++)
			set_reg(m, UC_ARM_REG_S0 + i, rd32(m, frame + 0x20 + 4u * (uint32_t)i, &ok));
		set_reg(m, UC_ARM_REG_FPSCR, rd32(m, frame + 0x60, &ok));
	}
	if (!ok)
		return cpu_error(m, "exception frame outside RAM on return");
	control = reg(m, UC_ARM_REG_CONTROL);
	set_reg(m, UC_ARM_REG_CONTROL, (excret & 0x10u) ? control & ~4u : control | 4u);
	set_reg(m, UC_ARM_REG_SP, (frame + size) | ((xpsr >> 9) & 1u) << 2);
	set_reg(m, UC_ARM_REG_XPSR, (xpsr & ~0x3FFu) | 1u << 24);
	set_reg(m, UC_ARM_REG_IPSR, m->nvic.depth ? m->nvic.stack[m->nvic.depth - 1] : 0u);
	set_reg(m, UC_ARM_REG_PC, pc | 1u);
	return 0;
}

/* ---- unicorn hooks ---- */

/* At the start of each translated block: stop there when an event is due (interrupts are taken
 * between blocks; unicorn keeps the IT state whole there). The stop itself is made in the code hook of
 * the block's first instruction, before it runs: unicorn 2.0.1 stopped from a block hook runs that
 * instruction and then reports the block's start as the PC, so the restart ran it again (an LDMIA
 * with writeback loaded the next four words: the force identity found it). */
static void on_block(uc_engine *uc, uint64_t addr, uint32_t size, void *user)
{
	struct mcu *m = user;

	(void)size;
	if (m->now >= m->deadline ||
	    (m->pend_check && first_pending(m) && group_of(m, prio_of(m, first_pending(m))) < exec_prio(m, 1, 0))) {
		if (addr < EXC_RETURN_PAGE) {
			state_of(m)->stop_at = addr;
			return;
		}
		m->stop_req = 1;
		uc_emu_stop(uc);
	}
}

/* Before each instruction: its cost. A code hook also keeps unicorn's PC exact for the peripheral
 * models, so that a register read in the middle of a block sees the time of its own instruction
 * (DWT CYCCNT read twice around four NOPs differs by the four). */
static void on_code(uc_engine *uc, uint64_t addr, uint32_t size, void *user)
{
	struct mcu *m = user;

	(void)size;
	if (addr == state_of(m)->stop_at) {
		state_of(m)->stop_at = UINT64_MAX;
		m->stop_req = 1;
		uc_emu_stop(uc);
		return;
	}
	if (addr < EXC_RETURN_PAGE)
		charge(m, 1);
}

static void on_intr(uc_engine *uc, uint32_t intno, void *user)
{
	struct mcu *m = user;

	if (intno == QEMU_EXCP_EXCEPTION_EXIT)
		m->exc_return = 1;
	else
		m->cpu_intno = (int)intno;
	m->stop_req = 1;
	uc_emu_stop(uc);
}

struct unmodelled_ctx {
	struct mcu *m;
	uint32_t base;
};

static uint64_t unmodelled_read(uc_engine *uc, uint64_t off, unsigned size, void *user)
{
	struct unmodelled_ctx *u = user;

	(void)uc;
	(void)size;
	mcu_unmodelled(u->m, "unmodelled", u->base + (uint32_t)off, 0, 0);
	return 0;
}

static void unmodelled_write(uc_engine *uc, uint64_t off, unsigned size, uint64_t v, void *user)
{
	struct unmodelled_ctx *u = user;

	(void)uc;
	(void)size;
	mcu_unmodelled(u->m, "unmodelled", u->base + (uint32_t)off, 1, (uint32_t)v);
}

/* A peripheral address nothing models: a page that reads 0 and reports each address once. */
static bool on_unmapped(uc_engine *uc, uc_mem_type type, uint64_t addr, int size, int64_t value, void *user)
{
	struct mcu *m = user;
	struct unmodelled_ctx *u;
	uint32_t page = (uint32_t)addr & ~0x3FFu;

	(void)type;
	(void)size;
	(void)value;
	m->fault_addr = (uint32_t)addr;
	if (!((addr >= 0x40000000u && addr < 0x60000000u) || (addr >= 0xE0000000u && addr < 0xE0100000u)))
		return false; /* a bus fault (mcu_run) */
	if (state_of(m)->n_unmodelled_pages >= 64 || !(u = malloc(sizeof(*u))))
		return false;
	*u = (struct unmodelled_ctx){ m, page };
	if (uc_mmio_map(uc, page, 0x400, unmodelled_read, u, unmodelled_write, u) != UC_ERR_OK) {
		free(u);
		return false;
	}
	state_of(m)->unmodelled_pages[state_of(m)->n_unmodelled_pages++] = u;
	return true;
}

void mcu_unmodelled(struct mcu *m, const char *what, uint32_t addr, int is_write, uint32_t v)
{
	char b[96];

	for (unsigned i = 0; i < m->n_unmodelled; i++)
		if (m->unmodelled[i] == addr)
			return;
	if (m->n_unmodelled < sizeof(m->unmodelled) / sizeof(m->unmodelled[0]))
		m->unmodelled[m->n_unmodelled++] = addr;
	if (is_write)
		fprintf(m->report, "swell-mcu: %s register 0x%08x written (0x%08x) at pc %s; reported once\n", what,
			addr, v, mcu_symbolize(m, reg(m, UC_ARM_REG_PC), b, sizeof(b)));
	else
		fprintf(m->report, "swell-mcu: %s register 0x%08x read (as 0) at pc %s; reported once\n", what, addr,
			mcu_symbolize(m, reg(m, UC_ARM_REG_PC), b, sizeof(b)));
}

/* ---- peripherals ---- */

static uint64_t periph_read(uc_engine *uc, uint64_t off, unsigned size, void *user)
{
	struct mcu_periph *p = user;

	(void)uc;
	if (p->advance)
		p->advance(p->owner, p->ctx, p->owner->now);
	return p->read(p->owner, p->ctx, (uint32_t)off, size);
}

static void periph_write(uc_engine *uc, uint64_t off, unsigned size, uint64_t v, void *user)
{
	struct mcu_periph *p = user;

	(void)uc;
	if (p->advance)
		p->advance(p->owner, p->ctx, p->owner->now);
	p->write(p->owner, p->ctx, (uint32_t)off, size, (uint32_t)v);
	p->owner->deadline = p->owner->now; /* an interrupt may be pending now: look from the next block */
}

int mcu_add_periph(struct mcu *m, const struct mcu_periph *p)
{
	struct mcu_periph *q;

	if (m->n_periph >= MCU_PERIPHS_MAX)
		return -1;
	q = &m->periph[m->n_periph];
	*q = *p;
	q->owner = m;
	if (uc_mmio_map(m->uc, q->base, q->size, periph_read, q, periph_write, q) != UC_ERR_OK)
		return -1;
	m->n_periph++;
	return 0;
}

int mcu_rcc_on_reset(struct mcu *m, uint32_t off, uint32_t bit, void (*fn)(struct mcu *m, void *ctx), void *ctx)
{
	if (m->n_rcc_reset >= sizeof(m->rcc_reset) / sizeof(m->rcc_reset[0]))
		return -1;
	m->rcc_reset[m->n_rcc_reset].off = off;
	m->rcc_reset[m->n_rcc_reset].bit = bit;
	m->rcc_reset[m->n_rcc_reset].fn = fn;
	m->rcc_reset[m->n_rcc_reset].ctx = ctx;
	m->n_rcc_reset++;
	return 0;
}

int mcu_rcc_on_enable(struct mcu *m, uint32_t off, uint32_t bit, void (*fn)(struct mcu *m, void *ctx, int on),
		      void *ctx)
{
	if (m->n_rcc_enable >= sizeof(m->rcc_enable) / sizeof(m->rcc_enable[0]))
		return -1;
	m->rcc_enable[m->n_rcc_enable].off = off;
	m->rcc_enable[m->n_rcc_enable].bit = bit;
	m->rcc_enable[m->n_rcc_enable].fn = fn;
	m->rcc_enable[m->n_rcc_enable].ctx = ctx;
	m->n_rcc_enable++;
	return 0;
}

int mcu_on_system_reset(struct mcu *m, void (*fn)(struct mcu *m, void *ctx), void *ctx)
{
	if (m->n_sys_reset >= sizeof(m->sys_reset) / sizeof(m->sys_reset[0]))
		return -1;
	m->sys_reset[m->n_sys_reset].fn = fn;
	m->sys_reset[m->n_sys_reset].ctx = ctx;
	m->n_sys_reset++;
	return 0;
}

static void advance_all(struct mcu *m)
{
	for (unsigned i = 0; i < m->n_periph; i++)
		if (m->periph[i].advance)
			m->periph[i].advance(m, m->periph[i].ctx, m->now);
}

uint64_t mcu_next_event(struct mcu *m)
{
	uint64_t t = MCU_NEVER;

	for (unsigned i = 0; i < m->n_periph; i++)
		if (m->periph[i].next_event) {
			uint64_t e = m->periph[i].next_event(m, m->periph[i].ctx);

			if (e < t)
				t = e;
		}
	return t;
}

/* ---- set-up and the run loop ---- */

int mcu_init(struct mcu *m, uint32_t cpi_milli, char *why, size_t why_len)
{
	struct cpu_state *s = calloc(1, sizeof(*s));
	uc_err e;

	m->cpu = s;
	m->cpi_milli = cpi_milli;
	m->report = stderr;
	m->clk = (struct mcu_clocks){ 16000000u, 16000000u, 16000000u, 16000000u, (uint32_t)(MCU_TIME_HZ / 16000000u) };
	if (!s || !(s->flash = calloc(1, FLASH_SIZE))) {
		snprintf(why, why_len, "out of memory");
		return -1;
	}
	e = uc_open(UC_ARCH_ARM, UC_MODE_THUMB | UC_MODE_MCLASS, &m->uc);
	if (e == UC_ERR_OK)
		e = uc_ctl_set_cpu_model(m->uc, UC_CPU_ARM_CORTEX_M4);
	if (e == UC_ERR_OK)
		e = uc_mem_map_ptr(m->uc, FLASH_BASE, FLASH_SIZE, UC_PROT_READ | UC_PROT_EXEC, s->flash);
	if (e == UC_ERR_OK)
		e = uc_mem_map_ptr(m->uc, 0, FLASH_SIZE, UC_PROT_READ | UC_PROT_EXEC, s->flash);
	if (e == UC_ERR_OK)
		e = uc_mem_map(m->uc, SRAM_BASE, SRAM_SIZE, UC_PROT_ALL);
	if (e == UC_ERR_OK)
		e = uc_mem_map(m->uc, CCM_BASE, CCM_SIZE, UC_PROT_READ | UC_PROT_WRITE);
	if (e == UC_ERR_OK)
		e = uc_mem_map(m->uc, SYSMEM_BASE, SYSMEM_SIZE, UC_PROT_READ);
	if (e == UC_ERR_OK)
		e = uc_mem_map(m->uc, EXC_RETURN_PAGE, 0x1000, UC_PROT_READ | UC_PROT_EXEC);
	if (e == UC_ERR_OK)
		e = uc_hook_add(m->uc, &s->h_block, UC_HOOK_BLOCK, (void *)on_block, m, 1, 0);
	if (e == UC_ERR_OK)
		e = uc_hook_add(m->uc, &s->h_code, UC_HOOK_CODE, (void *)on_code, m, 1, 0);
	if (e == UC_ERR_OK)
		e = uc_hook_add(m->uc, &s->h_intr, UC_HOOK_INTR, (void *)on_intr, m, 1, 0);
	if (e == UC_ERR_OK)
		e = uc_hook_add(m->uc, &s->h_unmapped, UC_HOOK_MEM_UNMAPPED, (void *)on_unmapped, m, 1, 0);
	if (e != UC_ERR_OK) {
		snprintf(why, why_len, "unicorn: %s", uc_strerror(e));
		return -1;
	}
	return 0;
}

void mcu_free(struct mcu *m)
{
	struct cpu_state *s = state_of(m);

	if (m->uc)
		uc_close(m->uc);
	if (s) {
		for (unsigned i = 0; i < s->n_unmodelled_pages; i++)
			free(s->unmodelled_pages[i]);
		free(s->flash);
		free(s);
	}
	free(m->sym);
	free(m->strtab);
}

int mcu_reset(struct mcu *m, char *why, size_t why_len)
{
	int ok = 1;
	uint32_t sp = rd32(m, FLASH_BASE, &ok), pc = rd32(m, FLASH_BASE + 4u, &ok);

	if (!ok || !(pc & 1u) || sp < SRAM_BASE || sp > SRAM_BASE + SRAM_SIZE) {
		snprintf(why, why_len,
			 "the vector table at 0x%08x has no stack in SRAM and Thumb reset vector "
			 "(sp 0x%08x, pc 0x%08x)",
			 FLASH_BASE, sp, pc);
		return -1;
	}
	memset(&m->nvic, 0, sizeof(m->nvic));
	m->vtor = 0;
	set_reg(m, UC_ARM_REG_CONTROL, 0);
	set_reg(m, UC_ARM_REG_PRIMASK, 0);
	set_reg(m, UC_ARM_REG_BASEPRI, 0);
	set_reg(m, UC_ARM_REG_SP, sp);
	set_reg(m, UC_ARM_REG_LR, 0xFFFFFFFFu);
	set_reg(m, UC_ARM_REG_PC, pc);
	set_reg(m, UC_ARM_REG_XPSR, 1u << 24);
	set_reg(m, UC_ARM_REG_IPSR, 0);
	return 0;
}

/* A system reset (RM0090 7.1.2) carried out: the models back to their reset state, the clocks back
 * to HSI, the CPU from the vector table; memory keeps its contents. */
static int system_reset(struct mcu *m, uint32_t flags)
{
	char why[160];

	m->reset_flags = flags;
	m->watchdog_bit = m->reset_req = 0;
	m->resets++;
	m->clk = (struct mcu_clocks){ 16000000u, 16000000u, 16000000u, 16000000u, (uint32_t)(MCU_TIME_HZ / 16000000u) };
	m->ccr = 0x200u;
	m->shcsr = m->cfsr = m->hfsr = m->cpacr = m->dwt_ctrl = 0;
	for (unsigned i = 0; i < m->n_sys_reset; i++)
		m->sys_reset[i].fn(m, m->sys_reset[i].ctx);
	if (mcu_reset(m, why, sizeof(why)) != 0) {
		fprintf(m->report, "swell-mcu: reset at %.6f s: %s\n", mcu_seconds(m->now), why);
		return MCU_EXIT_CPU;
	}
	fprintf(m->report, "swell-mcu: system reset at %.6f s (%s)\n", mcu_seconds(m->now),
		flags & MCU_CSR_IWDGRSTF ? "watchdog" : "requested by the image");
	return 0;
}

/* ARMv7-M ARM B3.2.15 (CFSR), B3.2.16 (HFSR), B1.5.14 (fault behavior). */
#define CFSR_IBUSERR (1u << 8)
#define CFSR_PRECISERR (1u << 9)
#define CFSR_BFARVALID (1u << 15)
#define CFSR_UNDEFINSTR (1u << 16)
#define CFSR_INVSTATE (1u << 17)
#define CFSR_NOCP (1u << 19)
#define CFSR_UNALIGNED (1u << 24)
#define HFSR_FORCED (1u << 30)
#define QEMU_EXCP_UDEF 1
#define QEMU_EXCP_NOCP 17
#define QEMU_EXCP_INVSTATE 18
#define QEMU_EXCP_UNALIGNED 22

/* A synchronous fault of the instruction at PC (B1.5.14): its own exception (4 MemManage, 5 BusFault,
 * 6 UsageFault) when SHCSR enables it and it may preempt, else HardFault with HFSR.FORCED; a fault
 * while HardFault is active is a lockup, which ends the run. */
static int take_fault(struct mcu *m, unsigned exc, uint32_t cfsr_bits, const char *what)
{
	const uint32_t ena = exc == 4 ? 1u << 16 : exc == 5 ? 1u << 17 : 1u << 18;
	char b[160];

	if (!(m->shcsr & ena) || group_of(m, prio_of(m, exc)) >= exec_prio(m, 1, 0)) {
		if (m->nvic.active[3] || m->nvic.active[2]) {
			snprintf(b, sizeof(b), "lockup: %s in the HardFault or NMI handler", what);
			return cpu_error(m, b);
		}
		m->hfsr |= HFSR_FORCED;
		exc = 3;
	}
	m->cfsr |= cfsr_bits;
	if (cfsr_bits & CFSR_BFARVALID)
		m->bfar = m->fault_addr;
	m->faults++;
	if (m->trace_irq)
		fprintf(m->trace_irq, "%.9f fault %s\n", mcu_seconds(m->now), what);
	return exc_enter(m, exc);
}

/* unicorn leaves a run by itself after WFI (and nothing else): the instruction before PC. */
static int after_wfi(struct mcu *m)
{
	uint32_t pc = reg(m, UC_ARM_REG_PC);
	uint8_t b[4];

	if (uc_mem_read(m->uc, pc - 2u, b, 2) == UC_ERR_OK && b[0] == 0x30 && b[1] == 0xBF)
		return 1; /* WFI, T1 */
	return uc_mem_read(m->uc, pc - 4u, b, 4) == UC_ERR_OK && b[0] == 0xAF && b[1] == 0xF3 && b[2] == 0x03 &&
		b[3] == 0x80; /* WFI.W, T2 */
}

/* Sleep after WFI: until an exception is pending that would preempt were PRIMASK clear, or `until`. */
/* The run loop's I/O hook and when it is due next. */
struct io {
	mcu_io_hook hook;
	void *ctx;
	uint64_t next, slice;
};

/* The hook when it is due: 0 on, else the run's end (a negative return ends it with OK). */
static int io_due(struct mcu *m, struct io *io)
{
	int rc;

	if (!io->hook || m->now < io->next)
		return 0;
	rc = io->hook(m, io->ctx);
	io->next = m->now + io->slice;
	advance_all(m);
	return rc < 0 ? -1 : rc;
}

/* Sleep after WFI: until an exception is pending that would preempt were PRIMASK clear, or `until`;
 * the hook runs at its times meanwhile (frames from a tunnel may wake the CPU). 0, or the hook's
 * end of the run. */
static int sleep_wfi(struct mcu *m, uint64_t until, struct io *io)
{
	uint64_t t0 = m->now;
	int rc = 0;

	m->wfi_count++;
	for (;;) {
		unsigned e;
		uint64_t t;

		advance_all(m);
		if (m->watchdog_bit || m->reset_req)
			break;
		e = first_pending(m);
		if (e && group_of(m, prio_of(m, e)) < exec_prio(m, 0, 0))
			break;
		t = mcu_next_event(m);
		if (io->hook && io->next < t)
			t = io->next;
		if (t >= until) {
			m->now = until;
			break;
		}
		if (t > m->now)
			m->now = t;
		rc = io_due(m, io);
		if (rc)
			break;
	}
	m->wfi_units += m->now - t0;
	return rc;
}

int mcu_run(struct mcu *m, uint64_t until, uint64_t slice, mcu_io_hook hook, void *hook_ctx)
{
	struct io io = { hook, hook_ctx, hook ? m->now : MCU_NEVER, slice };
	int rc = 0;

	while (m->now < until) {
		uint64_t deadline;
		uc_err e;
		uint32_t pc;

		advance_all(m);
		rc = io_due(m, &io);
		if (rc)
			return rc < 0 ? MCU_EXIT_OK : rc;
		if (m->watchdog_bit || m->reset_req) {
			if (!m->restart_on_reset)
				return m->watchdog_bit ? MCU_EXIT_WATCHDOG : MCU_EXIT_RESET;
			rc = system_reset(m, MCU_CSR_PINRSTF | (m->watchdog_bit ? MCU_CSR_IWDGRSTF : MCU_CSR_SFTRSTF));
			if (rc)
				return rc;
		}
		(void)take_pending(m, &rc);
		if (rc)
			return rc;
		deadline = mcu_next_event(m);
		if (io.next < deadline)
			deadline = io.next;
		if (until < deadline)
			deadline = until;
		if (deadline <= m->now)
			deadline = m->now + 1; /* at least one block */
		m->deadline = deadline;
		m->stop_req = 0;
		state_of(m)->stop_at = UINT64_MAX;
		m->exc_return = 0;
		m->cpu_intno = 0;
		pc = reg(m, UC_ARM_REG_PC);
		e = uc_emu_start(m->uc, pc | 1u, 0xFFFFFFFFu, 0, 0);
		if (e == UC_ERR_READ_UNMAPPED || e == UC_ERR_WRITE_UNMAPPED) {
			rc = take_fault(m, 5, CFSR_PRECISERR | CFSR_BFARVALID, "bus error (access outside memory)");
			if (rc)
				return rc;
		} else if (e == UC_ERR_FETCH_UNMAPPED) {
			rc = take_fault(m, 5, CFSR_IBUSERR, "bus error (instruction fetch outside memory)");
			if (rc)
				return rc;
		} else if (e == UC_ERR_INSN_INVALID) { /* unicorn's report of an undefined instruction */
			rc = take_fault(m, 6, CFSR_UNDEFINSTR, "usage fault (undefined instruction)");
			if (rc)
				return rc;
		} else if (e != UC_ERR_OK) {
			char what[96];

			snprintf(what, sizeof(what), "unicorn: %s", uc_strerror(e));
			return cpu_error(m, what);
		} else if (m->exc_return) {
			rc = exc_return(m, reg(m, UC_ARM_REG_PC) | 1u);
			if (rc)
				return rc;
		} else if (m->cpu_intno == QEMU_EXCP_UDEF || m->cpu_intno == QEMU_EXCP_NOCP ||
			   m->cpu_intno == QEMU_EXCP_INVSTATE || m->cpu_intno == QEMU_EXCP_UNALIGNED) {
			rc = take_fault(m, 6,
					m->cpu_intno == QEMU_EXCP_UDEF               ? CFSR_UNDEFINSTR
						: m->cpu_intno == QEMU_EXCP_NOCP     ? CFSR_NOCP
						: m->cpu_intno == QEMU_EXCP_INVSTATE ? CFSR_INVSTATE
										     : CFSR_UNALIGNED,
					"usage fault");
			if (rc)
				return rc;
		} else if (m->cpu_intno) {
			char what[64];

			snprintf(what, sizeof(what), "CPU exception %d (SVC or BKPT: not modelled)", m->cpu_intno);
			return cpu_error(m, what);
		} else if (!m->stop_req) {
			if (!after_wfi(m))
				return cpu_error(m, "unicorn stopped without a reason");
			rc = sleep_wfi(m, until, &io);
			if (rc)
				return rc < 0 ? MCU_EXIT_OK : rc;
		}
	}
	if (m->watchdog_bit || m->reset_req)
		return m->restart_on_reset ? MCU_EXIT_OK : m->watchdog_bit ? MCU_EXIT_WATCHDOG : MCU_EXIT_RESET;
	return MCU_EXIT_OK;
}
