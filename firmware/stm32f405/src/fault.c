#include "fault.h"

#include <stdint.h>

#include "../regs/cortex_m4.h"
#include "board.h"
#include "boot.h"
#include "console.h"
#include "irq.h"
#include "safe.h"

/* Registers the core stacked on exception entry. */
struct fault_frame {
	uint32_t r0, r1, r2, r3, r12, lr, pc, xpsr;
};

void fault_report(const struct fault_frame *f, uint32_t exc_return);

__attribute__((noreturn)) static void halt(void)
{
	irq_disable();
	for (;;)
		__asm__ volatile("wfi");
}

void fault_stop(const char *why)
{
	safe_force_zero();
	board_led(0);
	con_puts("FAULT: ");
	con_puts(why);
	con_puts(" (force zeroed, waiting for the watchdog)\n");
	halt();
}

/* Called from the naked entries below with the stacked frame of whichever stack was in use. */
__attribute__((used, noreturn)) void fault_report(const struct fault_frame *f, uint32_t exc_return)
{
	uint32_t ipsr;
	int k;

	boot_probe_fault(); /* the ROM probe of a bootloader request: no return */
	safe_force_zero();
	__asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
	con_puts_u32("FAULT: exception ", ipsr & 0x1FFu);
	con_puts_hex32(" pc 0x", f->pc);
	con_puts_hex32(" lr 0x", f->lr);
	con_puts_hex32(" xpsr 0x", f->xpsr);
	con_puts_hex32(" exc_return 0x", exc_return);
	con_puts_hex32("\nFAULT: cfsr 0x", SCB->CFSR);
	con_puts_hex32(" hfsr 0x", SCB->HFSR);
	con_puts_hex32(" mmfar 0x", SCB->MMFAR);
	con_puts_hex32(" bfar 0x", SCB->BFAR);
	con_puts("\nFAULT: force now");
	for (k = 0; k < 3; k++) {
		con_putc(' ');
		con_put_i64(safe_force_cN(k));
	}
	con_puts(" cN (zeroed), waiting for the watchdog\n");
	halt();
}

/* fault_probe_read: r1 = 1, the one load that may fault (a 16-bit LDR at fault_probe_insn), r0 = r1. A
 * bus fault there is answered by fault_probe_fixup: r1 = 0 in the stacked frame, the load skipped. */
__asm__(".syntax unified\n\t"
	".thumb\n\t"
	".section .text.fault_probe_read,\"ax\",%progbits\n\t"
	".global fault_probe_read\n\t"
	".type fault_probe_read, %function\n\t"
	".thumb_func\n"
	"fault_probe_read:\n\t"
	"movs r1, #1\n"
	"fault_probe_insn:\n\t"
	"ldr r2, [r0]\n\t"
	"mov r0, r1\n\t"
	"bx lr\n\t"
	".size fault_probe_read, .-fault_probe_read\n\t"
	".text");

/* 1 when the fault is the probe's load: the frame then resumes after it with r1 = 0. */
__attribute__((used)) int fault_probe_fixup(struct fault_frame *f);
__attribute__((used)) int fault_probe_fixup(struct fault_frame *f)
{
	extern const char fault_probe_insn[];

	if ((f->pc & ~1u) != ((uint32_t)(uintptr_t)fault_probe_insn & ~1u))
		return 0;
	f->r1 = 0;
	f->pc += 2; /* LDR r2, [r0]: a 16-bit encoding */
	SCB->CFSR = SCB->CFSR & 0xFF00u; /* the bus fault's status bits, written back to clear them */
	SCB->HFSR = SCB->HFSR; /* FORCED, had it escalated */
	return 1;
}

/* The only assembly of the handlers: pick MSP or PSP by EXC_RETURN bit 2; a probe's fault returns to
 * the probe, any other goes to fault_report with the frame. */
#define FAULT_ENTRY(name)                                   \
	__attribute__((naked)) void name(void)              \
	{                                                   \
		__asm__ volatile("tst lr, #4\n\t"           \
				 "ite eq\n\t"               \
				 "mrseq r0, msp\n\t"        \
				 "mrsne r0, psp\n\t"        \
				 "push {r0, lr}\n\t"        \
				 "bl fault_probe_fixup\n\t" \
				 "mov r2, r0\n\t"           \
				 "pop {r0, r1}\n\t"         \
				 "cmp r2, #0\n\t"           \
				 "it ne\n\t"                \
				 "bxne r1\n\t"              \
				 "b fault_report\n\t");     \
	}

FAULT_ENTRY(isr_hardfault)
FAULT_ENTRY(isr_memmanage)
FAULT_ENTRY(isr_busfault)
FAULT_ENTRY(isr_usagefault)
FAULT_ENTRY(irq_unexpected)
