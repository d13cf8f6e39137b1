/* The memory of the pool, found at boot: the SRAM arena (app_arena, .bss) and a fast block of 64 KB
 * only the CPU reaches. On silicon that is the core-coupled RAM at 0x10000000 (RM0090: CCM data
 * RAM, on the D-bus only: no DMA, no peripheral reaches it); QEMU 7.2's netduinoplus2 maps no CCM
 * but 192 KB of SRAM at 0x20000000 where the F405 has 128 KB (hw/arm/stm32f405_soc.c, SRAM_SIZE),
 * so under emulation the block is the 64 KB above 0x20020000 (a bus fault on silicon). A read probe
 * that survives the bus fault (fault_probe_read) decides, each block checked as RAM (written and
 * read back at both ends); neither: no fast block, pools must fit the SRAM arena. */
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
