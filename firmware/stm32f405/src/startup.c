/* Reset entry and vector table. The core loads the stack pointer from entry 0 and jumps to entry 1:
 * nothing before main() needs assembly. Unused interrupts land in irq_unexpected(), which zeroes the
 * force like a fault does. */
#include <stdint.h>
#include <string.h>

#include "../regs/cortex_m4.h"
#include "../regs/stm32f405_periph.h"
#include "boot.h"
#include "fault.h"
#include "isr.h"

extern uint32_t _sidata[], _sdata[], _edata[], _sbss[], _ebss[];
extern uint32_t _sstack[], _estack[];

#define STACK_PAINT 0x5AFE57ACu

int main(void);
void isr_default(void);

/* Target of the weak aliases below (an alias must be defined in this file): straight on to the
 * fault report with the stacked frame intact. */
__attribute__((naked)) void isr_default(void)
{
	__asm__ volatile("b irq_unexpected");
}

void isr_systick(void) __attribute__((weak, alias("isr_default")));
void isr_tim2(void) __attribute__((weak, alias("isr_default")));
void isr_can1_rx0(void) __attribute__((weak, alias("isr_default")));
void isr_can1_sce(void) __attribute__((weak, alias("isr_default")));
void isr_otg_fs(void) __attribute__((weak, alias("isr_default")));

typedef void (*vector_fn)(void);
union vector {
	vector_fn fn;
	uint32_t *sp;
};

#define IRQ(n) (16 + (n))

/* Defaults first, then the handlers we have: the later initializers are meant to override. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Woverride-init"

__attribute__((section(".isr_vector"), used)) static const union vector vectors[16 + IRQ_COUNT] = {
	[0] = { .sp = _estack },
	[1] = { isr_reset },
	[2] = { isr_nmi },
	[3] = { isr_hardfault },
	[4] = { isr_memmanage },
	[5] = { isr_busfault },
	[6] = { isr_usagefault },
	[7 ... 14] = { irq_unexpected }, /* reserved, SVCall, DebugMon, PendSV: none used */
	[15] = { isr_systick },
	[IRQ(0)... IRQ(IRQ_COUNT - 1)] = { irq_unexpected },
	[IRQ(IRQ_TIM2)] = { isr_tim2 },
	[IRQ(IRQ_CAN1_RX0)] = { isr_can1_rx0 },
	[IRQ(IRQ_CAN1_SCE)] = { isr_can1_sce },
	[IRQ(IRQ_OTG_FS)] = { isr_otg_fs },
};
#pragma GCC diagnostic pop

void isr_nmi(void)
{
	/* NMI on the F405 is the clock security system: HSE failed. Treat like a fault. */
	fault_stop("NMI (clock security: HSE lost)");
}

/* Fill the unused stack with a pattern so that the deepest use can be measured later. */
static void stack_paint(void)
{
	uint32_t *p, *sp;

	__asm__ volatile("mov %0, sp" : "=r"(sp));
	for (p = _sstack; p < sp - 16; p++)
		*p = STACK_PAINT;
}

uint32_t stack_used_bytes(void)
{
	const uint32_t *p = _sstack;

	while ((uintptr_t)p < (uintptr_t)_estack && *p == STACK_PAINT)
		p++;
	return (uint32_t)((uintptr_t)_estack - (uintptr_t)p);
}

uint32_t stack_size_bytes(void)
{
	return (uint32_t)((uintptr_t)_estack - (uintptr_t)_sstack);
}

void isr_reset(void)
{
	/* A requested jump to the ROM bootloader goes first, from the state the reset left. */
	boot_early();
	/* The FPU first: the compiler may use FP registers anywhere after this (hard-float ABI). */
	SCB->CPACR |= SCB_CPACR_CP10_CP11_FULL;
	__asm__ volatile("dsb\n\tisb" ::: "memory");
	stack_paint();
	/* linker symbols: addresses, not one C object, so their distance is taken as integers */
	memcpy(_sdata, _sidata, (size_t)((uintptr_t)_edata - (uintptr_t)_sdata));
	memset(_sbss, 0, (size_t)((uintptr_t)_ebss - (uintptr_t)_sbss));
	SCB->VTOR = (uint32_t)(uintptr_t)vectors;
	main();
	fault_stop("main returned");
}
