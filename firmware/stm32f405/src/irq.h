/* Interrupt masking on the Cortex-M4, written once: PRIMASK saved and set around a short critical
 * section, restored after it (so nesting keeps the outer state). */
#ifndef SWELL_FW_IRQ_H
#define SWELL_FW_IRQ_H

#include <stdint.h>

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

/* Mask every configurable interrupt for good (fault and reset paths). */
static inline void irq_disable(void)
{
	__asm__ volatile("cpsid i" ::: "memory");
}

#endif
