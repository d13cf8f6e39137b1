#include "mem.h"

#include "../regs/stm32f405_rcc.h"
#include "console.h"
#include "fault.h"

/* A 64 KB block at base that reads without a fault and keeps what is written at both ends. */
static int block_is_ram(uint32_t base)
{
	volatile uint32_t *first = (volatile uint32_t *)base;
	volatile uint32_t *last = (volatile uint32_t *)(base + MEM_FAST_BYTES - 4u);

	if (!fault_probe_read(base) || !fault_probe_read(base + MEM_FAST_BYTES - 4u))
		return 0;
	*first = 0x5A5A0F0Fu;
	*last = 0xA5A5F0F0u;
	if (*first != 0x5A5A0F0Fu || *last != 0xA5A5F0F0u)
		return 0;
	*first = 0;
	*last = 0;
	return 1;
}

void mem_probe(struct fw_mem *m, int32_t *sram, size_t sram_words)
{
	*m = (struct fw_mem){ sram, sram_words, NULL, 0, "none" };
	RCC->AHB1ENR |= RCC_AHB1ENR_CCMDATARAM; /* on at reset (RM0090), made sure of */
	if (block_is_ram(MEM_CCM_BASE)) {
		m->fast = (int32_t *)MEM_CCM_BASE;
		m->fast_name = "CCM 0x10000000";
	} else if (block_is_ram(MEM_SRAM_ABOVE_BASE)) {
		m->fast = (int32_t *)MEM_SRAM_ABOVE_BASE;
		m->fast_name = "SRAM 0x20020000 (emulator: no CCM)";
	}
	if (m->fast)
		m->fast_words = MEM_FAST_BYTES / 4u;
	con_puts_u32("memory: SRAM arena ", (uint32_t)m->sram_words * 4u);
	con_puts_hex32(" bytes at 0x", (uint32_t)(uintptr_t)m->sram);
	con_puts_u32(", fast block ", (uint32_t)m->fast_words * 4u);
	con_puts(" bytes in ");
	con_puts(m->fast_name);
	con_putc('\n');
}

static void put_buf(const char *name, uint32_t bytes, const char *where)
{
	con_puts(name);
	con_putc(' ');
	con_put_u64(bytes);
	con_puts(" in ");
	con_puts(where);
}

void mem_report(const struct swell_ctl *c, const struct fw_mem *m, const struct fw_pool_at *p)
{
	const uint32_t n = (uint32_t)c->cfg.nx * c->cfg.ny;
	const char *fast = p->apart ? m->fast_name : "SRAM";

	con_puts_u32("pool: ", c->cfg.nx);
	con_putc('x');
	con_put_u64(c->cfg.ny);
	con_puts_u32(" cells of ", c->cfg.dx_um);
	con_puts_u32(" um, depth ", c->cfg.depth_um);
	con_puts(" um; bytes: ");
	put_buf("h", n * 4u, "SRAM");
	put_buf(", tile flags", (uint32_t)c->wave.tiles_x * c->wave.tiles_y, "SRAM");
	put_buf(", u", n * 4u, fast);
	put_buf(", sent", (n + 1u) / 2u * 4u, "SRAM");
	con_puts_u32("; SRAM ", (uint32_t)p->sram_words * 4u);
	con_puts_u32(" of ", (uint32_t)m->sram_words * 4u);
	con_puts_u32(", fast ", (uint32_t)p->fast_words * 4u);
	con_puts_u32(" of ", (uint32_t)m->fast_words * 4u);
	con_putc('\n');
}
