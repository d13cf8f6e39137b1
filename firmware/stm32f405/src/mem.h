/* The memory of the pool, found at boot: the SRAM arena (app_arena, .bss) and a fast block of 64 KB
 * only the CPU reaches: the core-coupled RAM on silicon, the SRAM QEMU maps above 0x20020000 under
 * emulation, or none; each probed through fault_probe_read and checked as RAM (docs/stm32f405.md). */
#ifndef SWELL_FW_MEM_H
#define SWELL_FW_MEM_H

#include "swell/ctl_pool.h"

#define MEM_CCM_BASE 0x10000000u
#define MEM_SRAM_ABOVE_BASE 0x20020000u /* QEMU only: the F405's SRAM ends here */
#define MEM_FAST_BYTES 0x10000u

/* Probe once at boot (after the bus fault is enabled) and fill m with the SRAM arena given and the
 * fast block found; prints one line. */
void mem_probe(struct fw_mem *m, int32_t *sram, size_t sram_words);

/* One boot line: the pool's grid and each buffer's bytes and memory. */
void mem_report(const struct swell_ctl *c, const struct fw_mem *m, const struct fw_pool_at *p);

#endif
