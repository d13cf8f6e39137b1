/* Cycle counting. SysTick runs from the core clock with a 2^24 reload and counts its wraps, giving
 * a 64-bit count (exact under QEMU -icount shift=0, where 1 tick = 1e9/168e6 = 5.95 instructions).
 * DWT CYCCNT is used where it exists (real silicon); QEMU has none, and we detect that. */
#ifndef SWELL_FW_TIMEBASE_H
#define SWELL_FW_TIMEBASE_H

#include <stdint.h>

void timebase_init(uint8_t systick_prio);
uint64_t timebase_systick(void); /* SysTick ticks since timebase_init, 64 bits */
int timebase_has_dwt(void);
/* Cycle counter: DWT CYCCNT where the core has one, else SysTick extended to 64 bits. */
uint64_t timebase_cycles(void);
static inline uint32_t timebase_dwt(void)
{
	return *(volatile uint32_t *)0xE0001004u;
}

#endif
