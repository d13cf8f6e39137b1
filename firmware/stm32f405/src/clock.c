#include "clock.h"

#include "../regs/stm32f405_rcc.h"

/* Bounded waits, in polling loops (about 4 cycles each): HSE start-up is typically 2 ms; we allow
 * about 20 ms at 16 MHz before giving up. PLL lock takes about 100 us. */
#define HSE_WAIT_LOOPS 80000u
#define PLL_WAIT_LOOPS 20000u
#define SWITCH_WAIT_LOOPS 2000u

static int wait_bits(volatile uint32_t *reg, uint32_t mask, uint32_t want, uint32_t loops)
{
	while (loops--)
		if ((*reg & mask) == want)
			return 1;
	return 0;
}

static void run_on_hsi(struct clock_info *ci)
{
	RCC->CFGR = RCC_CFGR_SW_HSI; /* all prescalers /1 */
	(void)wait_bits(&RCC->CFGR, RCC_CFGR_SW_MASK << RCC_CFGR_SWS_SHIFT, 0, SWITCH_WAIT_LOOPS);
	RCC->CR &= ~RCC_CR_PLLON;
	ci->src = CLOCK_HSI;
	ci->sysclk_hz = ci->hclk_hz = ci->pclk1_hz = ci->pclk2_hz = ci->tim_apb1_hz = 16000000u;
}

void clock_init(struct clock_info *ci)
{
	uint32_t m, n, src_bit;
	enum clock_src want;

	*ci = (struct clock_info){ 0 };
	RCC->CR |= RCC_CR_HSION;
	(void)wait_bits(&RCC->CR, RCC_CR_HSIRDY, RCC_CR_HSIRDY, PLL_WAIT_LOOPS);
	/* Voltage scale 1 and 5 wait states (168 MHz at 2.7-3.6 V) before any speed-up; both are safe
	 * at every lower clock, so a fallback needs no undo. */
	RCC->APB1ENR |= RCC_APB1ENR_PWR;
	(void)RCC->APB1ENR;
	PWR->CR |= PWR_CR_VOS;
	FLASH_IF->ACR = 5u | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;

	RCC->CR |= RCC_CR_HSEON;
	if (wait_bits(&RCC->CR, RCC_CR_HSERDY, RCC_CR_HSERDY, HSE_WAIT_LOOPS)) {
		want = CLOCK_HSE_PLL;
		m = SWELL_PLL_M; /* the board's crystal / M x N = 336 MHz (boards/board.cmake) */
		n = SWELL_PLL_N;
		src_bit = RCC_PLLCFGR_SRC_HSE;
	} else {
		ci->hse_timeout = 1;
		RCC->CR &= ~RCC_CR_HSEON;
		want = CLOCK_HSI_PLL;
		m = 8; /* 16 MHz / 8 = 2 MHz, x 168 */
		n = 168;
		src_bit = 0;
	}
	/* VCO 336 MHz; P /2 = 168 MHz; Q /7 = 48 MHz. */
	RCC->CR &= ~RCC_CR_PLLON;
	RCC->PLLCFGR = (m << RCC_PLLCFGR_M_SHIFT) | (n << RCC_PLLCFGR_N_SHIFT) | (0u << RCC_PLLCFGR_P_SHIFT) | src_bit |
		(7u << RCC_PLLCFGR_Q_SHIFT);
	RCC->CR |= RCC_CR_PLLON;
	if (!wait_bits(&RCC->CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY, PLL_WAIT_LOOPS)) {
		ci->pll_timeout = 1;
		run_on_hsi(ci);
		return;
	}
	RCC->CFGR = (0u << RCC_CFGR_HPRE_SHIFT) | (RCC_CFGR_PPRE_DIV4 << RCC_CFGR_PPRE1_SHIFT) |
		(RCC_CFGR_PPRE_DIV2 << RCC_CFGR_PPRE2_SHIFT) | RCC_CFGR_SW_PLL;
	if (!wait_bits(&RCC->CFGR, RCC_CFGR_SW_MASK << RCC_CFGR_SWS_SHIFT, RCC_CFGR_SW_PLL << RCC_CFGR_SWS_SHIFT,
		       SWITCH_WAIT_LOOPS)) {
		ci->switch_timeout = 1;
		run_on_hsi(ci);
		return;
	}
	if (want == CLOCK_HSE_PLL)
		RCC->CR |= RCC_CR_CSSON; /* HSE failure later: NMI, force zeroed, switch back to HSI */
	ci->src = want;
	ci->sysclk_hz = ci->hclk_hz = 168000000u;
	ci->pclk1_hz = 42000000u;
	ci->pclk2_hz = ci->tim_apb1_hz = 84000000u;
}

const char *clock_src_name(enum clock_src s)
{
	switch (s) {
	case CLOCK_HSE_PLL:
		return "HSE+PLL";
	case CLOCK_HSI_PLL:
		return "HSI+PLL";
	default:
		return "HSI";
	}
}
