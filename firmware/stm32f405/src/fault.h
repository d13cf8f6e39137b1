/* Fault handlers: zero the force output first, then report over the console, then wait for the
 * independent watchdog to reset the chip (the watchdog is never refreshed from here). */
#ifndef SWELL_FW_FAULT_H
#define SWELL_FW_FAULT_H

#include <stdint.h>

void isr_hardfault(void);
void isr_memmanage(void);
void isr_busfault(void);
void isr_usagefault(void);
void irq_unexpected(void);

/* 1 when a word read at addr completes, 0 when it bus-faults (the fault handler then skips the read
 * and returns here): a probe of memory that may not be there. Needs the bus fault enabled. */
int fault_probe_read(uint32_t addr);

/* Zero the force, print the reason, stop. Never returns. */
__attribute__((noreturn)) void fault_stop(const char *why);

#endif
