/* Fault handlers: zero the force output first, then report over the console, then wait for the
 * independent watchdog to reset the chip (the watchdog is never refreshed from here). */
#ifndef SWELL_FW_FAULT_H
#define SWELL_FW_FAULT_H

void isr_hardfault(void);
void isr_memmanage(void);
void isr_busfault(void);
void isr_usagefault(void);
void irq_unexpected(void);

/* Zero the force, print the reason, stop. Never returns. */
__attribute__((noreturn)) void fault_stop(const char *why);

#endif
