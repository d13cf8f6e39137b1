/* Clock tree: 168 MHz SYSCLK from the HSE crystal through the PLL, with bounded waits and a
 * fallback chain HSE+PLL -> HSI+PLL -> HSI (16 MHz). AHB 168 MHz, APB1 42 MHz (timers 84 MHz),
 * APB2 84 MHz, PLL48CLK 48 MHz (USB needs the HSE path for its +-0.25 % accuracy). */
#ifndef SWELL_FW_CLOCK_H
#define SWELL_FW_CLOCK_H

#include <stdint.h>

#include "swell_board.h" /* SWELL_HSE_HZ and the PLL's M and N, checked at configure time */

enum clock_src {
	CLOCK_HSI = 0, /* 16 MHz internal RC, no PLL */
	CLOCK_HSI_PLL = 1, /* 168 MHz from HSI: no USB (HSI is 1 % accurate) */
	CLOCK_HSE_PLL = 2, /* 168 MHz from the crystal: everything works */
};

struct clock_info {
	enum clock_src src; /* what the switch status (RCC_CFGR.SWS) confirms */
	uint32_t sysclk_hz, hclk_hz, pclk1_hz, pclk2_hz;
	uint32_t tim_apb1_hz; /* TIM2..7, 12..14: 2 x PCLK1 when APB1 is divided */
	uint8_t hse_timeout, pll_timeout, switch_timeout;
};

void clock_init(struct clock_info *ci);
const char *clock_src_name(enum clock_src s);

#endif
