#include "boot.h"

#include "../regs/cortex_m4.h"
#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"
#include "console.h"
#include "irq.h"
#include "safe.h"

#define SYSCFG_MEMRMP (*(volatile uint32_t *)0x40013800u)
#define SYSCFG_MEMRMP_SYSTEM_FLASH 1u /* MEM_MODE = 01: system flash at 0x00000000 */
#define RCC_APB2ENR_SYSCFG (1u << 14)
#define SRAM_BASE 0x20000000u
#define SRAM_END 0x20020000u

void boot_request_reset(void)
{
	safe_force_zero();
	con_puts_hex32("boot: ENTER_BOOTLOADER accepted, force zeroed: resetting into the ROM bootloader at 0x",
		       BOOT_SYSMEM);
	con_putc('\n');
	con_drain();
	irq_disable();
	BOOT_WORD(1) = BOOT_MAGIC_REQUEST;
	__asm__ volatile("dsb" ::: "memory");
	/* keep PRIGROUP, ask for a system reset (RM0090: every register but RCC_CSR and the backup
	 * domain goes back to its reset value; SRAM keeps its contents) */
	SCB->AIRCR = SCB_AIRCR_VECTKEY | (SCB->AIRCR & (7u << SCB_AIRCR_PRIGROUP_SHIFT)) | SCB_AIRCR_SYSRESETREQ;
	__asm__ volatile("dsb" ::: "memory");
	for (;;)
		__asm__ volatile("wfi");
}

static int looks_like_rom(uint32_t msp, uint32_t pc)
{
	return msp > SRAM_BASE && msp <= SRAM_END && (msp & 3u) == 0 && (pc & 1u) && pc > BOOT_SYSMEM &&
		pc < BOOT_SYSMEM + BOOT_SYSMEM_SIZE;
}

void boot_early(void)
{
	uint32_t msp, pc, k;

	if (BOOT_WORD(1) != BOOT_MAGIC_REQUEST)
		return;
	BOOT_WORD(1) = 0; /* once only: the bootloader's own reset must start this image */
	irq_disable();
	SYSTICK->CTRL = 0;
	SYSTICK->LOAD = 0;
	SYSTICK->VAL = 0;
	for (k = 0; k < 8; k++) {
		NVIC->ICER[k] = 0xFFFFFFFFu;
		NVIC->ICPR[k] = 0xFFFFFFFFu;
	}
	/* System memory answers at 0x1FFF0000 whatever the remap; it is read before anything is remapped,
	 * so that a fault here still finds this image's vector table. Where nothing answers (QEMU) the
	 * read bus-faults: boot_probe_fault() in the fault handler sees PROBING, records the fault and
	 * resets into this image. */
	BOOT_WORD(1) = BOOT_PROBING;
	__asm__ volatile("dsb" ::: "memory");
	msp = *(volatile const uint32_t *)BOOT_SYSMEM;
	pc = *(volatile const uint32_t *)(BOOT_SYSMEM + 4u);
	BOOT_WORD(1) = 0;
	BOOT_WORD(2) = msp;
	BOOT_WORD(3) = pc;
	if (looks_like_rom(msp, pc)) {
		/* System flash at 0x00000000 (VTOR is 0 after reset: the ROM's own vector table), as when
		 * BOOT0 selects it. The ROM sets up its own clocks and interrupts; it is entered as from a
		 * reset: MSP from its table, PRIMASK clear with every interrupt disabled and none pending. */
		RCC->APB2ENR |= RCC_APB2ENR_SYSCFG;
		(void)RCC->APB2ENR;
		SYSCFG_MEMRMP = SYSCFG_MEMRMP_SYSTEM_FLASH;
		__asm__ volatile("dsb\n\tisb" ::: "memory");
		__asm__ volatile("msr msp, %0\n\t"
				 "cpsie i\n\t"
				 "bx %1" ::"r"(msp),
				 "r"(pc)
				 : "memory");
		__builtin_unreachable();
	}
	/* No bootloader there: nothing was remapped; boot this image as after any reset. */
	__asm__ volatile("cpsie i" ::: "memory");
	BOOT_WORD(1) = BOOT_OUTCOME_NOROM;
}

void boot_probe_fault(void)
{
	if (BOOT_WORD(1) != BOOT_PROBING)
		return;
	BOOT_WORD(1) = BOOT_OUTCOME_FAULTED;
	BOOT_WORD(2) = SCB->BFAR;
	BOOT_WORD(3) = SCB->CFSR;
	__asm__ volatile("dsb" ::: "memory");
	SCB->AIRCR = SCB_AIRCR_VECTKEY | SCB_AIRCR_SYSRESETREQ;
	__asm__ volatile("dsb" ::: "memory");
	for (;;)
		;
}

int boot_report(void)
{
	uint32_t outcome = BOOT_WORD(1);

	if (outcome != BOOT_OUTCOME_NOROM && outcome != BOOT_OUTCOME_FAULTED)
		return 0;
	BOOT_WORD(1) = 0;
	con_puts_hex32("boot: bootloader requested before this reset; the ROM table at 0x", BOOT_SYSMEM);
	if (outcome == BOOT_OUTCOME_FAULTED) {
		con_puts_hex32(" bus-faulted when read (bfar 0x", BOOT_WORD(2));
		con_puts_hex32(", cfsr 0x", BOOT_WORD(3));
		con_puts(")");
	} else {
		con_puts_hex32(" read as MSP 0x", BOOT_WORD(2));
		con_puts_hex32(" PC 0x", BOOT_WORD(3));
	}
	con_puts(": no bootloader there, not jumped; this image started instead\n");
	return 1;
}
