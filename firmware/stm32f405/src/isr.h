/* Interrupt and exception handlers of the vector table (startup.c). Each is defined by the module
 * that owns the peripheral; the ones not linked fall back to irq_unexpected (weak aliases), as do
 * the vectors no module handles. */
#ifndef SWELL_FW_ISR_H
#define SWELL_FW_ISR_H

void isr_reset(void);
void isr_nmi(void);
void isr_systick(void);
void isr_tim2(void);
void isr_can1_rx0(void);
void isr_can1_sce(void);
void isr_otg_fs(void);

#include <stdint.h>

/* Deepest stack use since reset (the stack is painted at reset), and the stack size, in bytes. */
uint32_t stack_used_bytes(void);
uint32_t stack_size_bytes(void);

#endif
