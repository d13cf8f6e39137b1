/* The controller tick: TIM2 update interrupt at a fixed rate, highest priority (the force path).
 * Each tick's cost is measured (DWT cycles on silicon, SysTick ticks under QEMU); a tick whose work
 * is still running when the next update arrives counts as an overrun. */
#ifndef SWELL_FW_TICK_H
#define SWELL_FW_TICK_H

#include <stdint.h>

#include "swell/err.h"

struct tick_stats {
	uint32_t count; /* ticks run */
	uint32_t overruns; /* update flag set again before the tick's work finished */
	uint32_t last_cost; /* cycles (or SysTick ticks) of the last tick's work */
	uint32_t max_cost;
};

/* Start TIM2 at rate_hz from the timer clock; fn runs in the interrupt. SWELL_ERANGE when the rate
 * does not divide the clock (nothing started). */
enum swell_err tick_start(uint32_t tim_clk_hz, uint32_t rate_hz, uint8_t prio, void (*fn)(void));
void tick_stop(void);
void tick_read(struct tick_stats *out);

#endif
