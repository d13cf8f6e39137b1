#include "tick.h"

#include "../logic/timer_div.h"
#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"
#include "irq.h"
#include "isr.h"
#include "timebase.h"

static void (*tick_fn)(void);
static volatile struct tick_stats stats;

void isr_tim2(void)
{
	uint64_t t0 = timebase_cycles(), cost;

	TIM2->SR = ~TIM_SR_UIF; /* rc_w0: write 0 to clear */
	if (tick_fn)
		tick_fn();
	if (TIM2->SR & TIM_SR_UIF)
		stats.overruns++;
	cost = timebase_cycles() - t0;
	stats.last_cost = cost > UINT32_MAX ? UINT32_MAX : (uint32_t)cost;
	if (stats.last_cost > stats.max_cost)
		stats.max_cost = stats.last_cost;
	stats.count++;
}

enum swell_err tick_start(uint32_t tim_clk_hz, uint32_t rate_hz, uint8_t prio, void (*fn)(void))
{
	uint32_t psc, arr;
	enum swell_err err = fw_timer_div(tim_clk_hz, rate_hz, &psc, &arr);

	if (err != SWELL_OK)
		return err;
	tick_fn = fn;
	RCC->APB1ENR |= RCC_APB1ENR_TIM2;
	(void)RCC->APB1ENR;
	TIM2->CR1 = TIM_CR1_URS; /* only overflow raises the update interrupt */
	TIM2->PSC = psc;
	TIM2->ARR = arr;
	TIM2->EGR = TIM_EGR_UG; /* load PSC now */
	TIM2->SR = 0;
	TIM2->CNT = 0;
	TIM2->DIER = TIM_DIER_UIE;
	irq_enable_at(IRQ_TIM2, prio);
	TIM2->CR1 |= TIM_CR1_CEN;
	/* Writing ARR again is a no-op on silicon (ARPE = 0, same value); QEMU's timer model arms its
	 * next update only on an ARR write while counting, so without it the tick never starts there. */
	TIM2->ARR = arr;
	return SWELL_OK;
}

void tick_stop(void)
{
	TIM2->CR1 &= ~TIM_CR1_CEN;
	NVIC->ICER[IRQ_TIM2 / 32] = 1u << (IRQ_TIM2 % 32);
	TIM2->DIER = 0;
}

void tick_read(struct tick_stats *out)
{
	*out = (struct tick_stats){ stats.count, stats.overruns, stats.last_cost, stats.max_cost };
}
