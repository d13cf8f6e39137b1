/* Entering the STM32F405's ROM bootloader (system memory, 0x1FFF0000: USART, CAN and USB DfuSe,
 * ST AN2606) from a running image, without BOOT0: boot_request_reset() leaves a magic word in SRAM
 * and resets, boot_early() at the very start of the next reset checks the ROM's vector table and
 * jumps, a table that does not look like ST's (or a read that bus-faults: boot_probe_fault()) starts
 * this image instead, and main() says so (boot_report()). The steps: docs/stm32f405.md, "Entering the
 * ROM bootloader". */
#ifndef SWELL_FW_BOOT_H
#define SWELL_FW_BOOT_H

#include <stdint.h>

#define BOOT_SYSMEM 0x1FFF0000u /* STM32F405/407 system memory (RM0090 2.4, AN2606) */
#define BOOT_SYSMEM_SIZE 0x7800u /* 30 KB */

/* The four boot-mode words in the last 16 bytes of SRAM, outside every section (stm32f405.ld):
 * [0] test mode set by a harness (main.c), [1] bootloader request / outcome, [2] and [3] the MSP and
 * PC read from the ROM's table by the last attempt. */
#define BOOT_WORD(i) (((volatile uint32_t *)0x2001FFF0u)[i])
#define BOOT_MAGIC_REQUEST 0x55464442u /* "BDFU": jump to the ROM bootloader at the next reset */
#define BOOT_PROBING 0x424F5250u /* "PROB": reading the ROM's table right now */
#define BOOT_OUTCOME_NOROM 0x4D4F524Eu /* "NROM": read, not a bootloader's table, this image started */
#define BOOT_OUTCOME_FAULTED 0x544C4146u /* "FALT": the read bus-faulted, this image started */

/* Zero the force, print one line, leave the magic and reset. Never returns. */
__attribute__((noreturn)) void boot_request_reset(void);

/* From isr_reset before anything else: jumps to the ROM when requested and present; returns
 * otherwise. Uses no .data/.bss and no FPU. */
void boot_early(void);

/* From the fault handler, first: a bus fault while boot_early() reads the ROM's table is recorded
 * and answered with a reset into this image. Returns for any other fault. */
void boot_probe_fault(void);

/* From main() once the console is up: if the last reset was a bootloader request that found no
 * bootloader, say so (and clear the outcome). Returns 1 if it did. */
int boot_report(void);

#endif
