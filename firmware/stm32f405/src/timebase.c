#include "timebase.h"

#include "../regs/cortex_m4.h"
#include "irq.h"
#include "isr.h"

static volatile uint32_t wraps;
static int has_dwt;

void isr_systick(void)
{
	wraps++;
}

void timebase_init(uint8_t systick_prio)
{
	uint32_t a, b;

	SYSTICK->CTRL = 0;
	SYSTICK->LOAD = SYSTICK_MAX;
	SYSTICK->VAL = 0;
	SCB->SHPR[SCB_SHPR_IDX(EXC_SYSTICK)] = (uint8_t)(systick_prio << (8 - NVIC_PRIO_BITS));
	SYSTICK->CTRL = SYSTICK_CTRL_CLKSOURCE | SYSTICK_CTRL_TICKINT | SYSTICK_CTRL_ENABLE;

	DEMCR |= DEMCR_TRCENA;
	if (!(DWT->CTRL & DWT_CTRL_NOCYCCNT)) {
		DWT->CYCCNT = 0;
		DWT->CTRL |= DWT_CTRL_CYCCNTENA;
		a = DWT->CYCCNT;
		__asm__ volatile("nop\n\tnop\n\tnop\n\tnop");
		b = DWT->CYCCNT;
		has_dwt = a != b;
	}
}

/* wraps:VAL read consistently from thread mode or any interrupt: if the counter wrapped while we
 * read it and the SysTick interrupt has not run yet, its pending bit says so. QEMU sets that bit
 * only when its timer event runs, which can come after VAL has already reloaded: a reading below the
 * last one is such a wrap, not yet counted (readings come far more often than one a wrap). */
uint64_t timebase_systick(void)
{
	static uint64_t last;
	uint32_t primask, w, v;
	uint64_t t;

	primask = irq_save();
	w = wraps;
	v = SYSTICK->VAL;
	if (SCB->ICSR & SCB_ICSR_PENDSTSET) {
		v = SYSTICK->VAL;
		w++;
	}
	t = ((uint64_t)w << 24) + (SYSTICK_MAX - v);
	if (t < last)
		t += (uint64_t)1 << 24;
	last = t;
	irq_restore(primask);
	return t;
}

int timebase_has_dwt(void)
{
	return has_dwt;
}

uint64_t timebase_cycles(void)
{
	return has_dwt ? timebase_dwt() : timebase_systick();
}
