/* Interrupt masking on the Cortex-M4, written once: PRIMASK saved and set around a short critical
 * section, restored after it (so nesting keeps the outer state). */
#ifndef SWELL_FW_IRQ_H
#define SWELL_FW_IRQ_H

#include <stdint.h>

#include "../regs/cortex_m4.h"

static inline uint32_t irq_save(void)
{
	uint32_t primask;

	__asm__ volatile("mrs %0, primask\n\tcpsid i" : "=r"(primask)::"memory");
	return primask;
}

static inline void irq_restore(uint32_t primask)
{
	__asm__ volatile("msr primask, %0" ::"r"(primask) : "memory");
}

/* One peripheral interrupt on at a priority, any old pending request cleared first. */
static inline void irq_enable_at(unsigned irq, uint8_t prio)
{
	NVIC->IPR[irq] = (uint8_t)(prio << (8 - NVIC_PRIO_BITS));
	NVIC->ICPR[irq / 32] = 1u << (irq % 32);
	NVIC->ISER[irq / 32] = 1u << (irq % 32);
}

/* Mask every configurable interrupt for good (fault and reset paths). */
static inline void irq_disable(void)
{
	__asm__ volatile("cpsid i" ::: "memory");
}

#endif
