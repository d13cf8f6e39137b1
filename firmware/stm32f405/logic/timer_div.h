/* Prescaler and auto-reload of an STM32 timer for an exact update rate. */
#ifndef SWELL_FW_TIMER_DIV_H
#define SWELL_FW_TIMER_DIV_H

#include <stdint.h>

#include "swell/err.h"

/* Find psc, arr with (psc + 1) (arr + 1) = clk_hz / rate_hz exactly, arr + 1 <= 65536 (so a 16-bit
 * timer works too), psc + 1 <= 65536, and the smallest psc (finest resolution). SWELL_ERANGE when
 * rate_hz is 0, above clk_hz / 2, or does not divide clk_hz; outputs untouched on error. */
enum swell_err fw_timer_div(uint32_t clk_hz, uint32_t rate_hz, uint32_t *psc, uint32_t *arr);

#endif
