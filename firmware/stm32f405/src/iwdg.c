#include "iwdg.h"

#include "../regs/stm32f405_periph.h"

#define IWDG_WAIT_LOOPS 200000u /* the update takes up to 5 LSI periods (~160 us) */

int iwdg_start(uint32_t timeout_ms)
{
	uint32_t n;

	if (timeout_ms < 1)
		timeout_ms = 1;
	if (timeout_ms > 4095)
		timeout_ms = 4095;
	IWDG->KR = IWDG_KEY_START; /* also starts the LSI */
	IWDG->KR = IWDG_KEY_UNLOCK;
	IWDG->PR = 3; /* /32: 1 kHz at the nominal 32 kHz LSI, so 1 count = 1 ms */
	IWDG->RLR = timeout_ms - 1; /* LSI is 17..47 kHz: the real timeout is 0.68..1.9 x this */
	for (n = 0; n < IWDG_WAIT_LOOPS && (IWDG->SR & (IWDG_SR_PVU | IWDG_SR_RVU)); n++)
		;
	IWDG->KR = IWDG_KEY_REFRESH;
	return n < IWDG_WAIT_LOOPS; /* 0: the prescaler and reload updates never finished */
}

void iwdg_kick(void)
{
	IWDG->KR = IWDG_KEY_REFRESH;
}
