/* STM32F405 port: boot, checks, then the controller (a CAN or USB peripheral answered). With no link
 * the product stops with the force at zero; the self-test image (SWELL_FW_SELFTEST, QEMU netduinoplus2
 * has neither) runs the self-test there instead. */
#include <stdint.h>

#include "../regs/cortex_m4.h"
#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"
#include "app.h"
#include "board.h"
#include "boot.h"
#include "can.h"
#include "clock.h"
#include "console.h"
#include "fault.h"
#include "image.h"
#include "mem.h"
#include "safe.h"
#ifdef SWELL_FW_SELFTEST
#include "selftest.h"
#endif
#include "timebase.h"
#include "usb.h"

/* Interrupt priorities (0 = most urgent, preemption only): the force path first. */
#define PRIO_TICK 0 /* TIM2: the haptic tick, force out */
#define PRIO_SYSTICK 1 /* wrap counter, a few instructions every 0.1 s: never lose a wrap */
#define PRIO_CAN_SCE 2 /* bus-off: zero force promptly */
#define PRIO_CAN_RX 3 /* device frames (position in) */
#define PRIO_USB 4 /* host link */

#define WATCHDOG_MS 100u

/* Boot-mode word in the last 16 bytes of SRAM (outside every section, not cleared at start-up), read
 * by the self-test image only: a test harness writes it before reset (QEMU: -device loader,addr=0x2001fff0,data=...,data-len=4).
 * BOOT_MODE_FAULT: after the self-test, command a force and execute an undefined instruction, to
 * check that the fault handler zeroes the force and reports. Cleared once read. */
#define BOOT_MODE (*(volatile uint32_t *)0x2001FFF0u)
#define BOOT_MODE_FAULT 0x544C4146u /* "FALT" */
/* BOOT_MODE_BOOTLOADER: instead of the self-test, the enter-bootloader path (selftest_boot_request);
 * after its reset, the boot report and a stop. */
#define BOOT_MODE_BOOTLOADER 0x544F4F42u /* "BOOT" */

static void put_reset_cause(uint32_t csr)
{
	con_puts("reset:");
	if (csr & RCC_CSR_IWDGRSTF)
		con_puts(" watchdog");
	if (csr & RCC_CSR_SFTRSTF)
		con_puts(" software");
	if (csr & RCC_CSR_PORRSTF)
		con_puts(" power-on");
	if (csr & RCC_CSR_PINRSTF)
		con_puts(" pin");
	if (csr & RCC_CSR_BORRSTF)
		con_puts(" brown-out");
	if (!(csr & 0xFE000000u))
		con_puts(" (no flag)");
	con_putc('\n');
}

static void setup_faults(void)
{
	SCB->AIRCR = SCB_AIRCR_VECTKEY | (3u << SCB_AIRCR_PRIGROUP_SHIFT); /* 4 bits preemption */
	SCB->SHCSR |= SCB_SHCSR_MEMFAULTENA | SCB_SHCSR_BUSFAULTENA | SCB_SHCSR_USGFAULTENA;
	SCB->CCR |= SCB_CCR_DIV_0_TRP;
}

int main(void)
{
	struct clock_info ci;
	struct image_info img;
	uint32_t csr = RCC->CSR, boot_mode = BOOT_MODE;
	enum swell_err err;
	int can_ok, usb_ok, came_back;

	BOOT_MODE = 0;
	RCC->CSR |= RCC_CSR_RMVF;
	safe_force_zero();
	clock_init(&ci);
	board_init(); /* the CAN transceiver out of standby, the LED off */
	con_init(ci.pclk1_hz, ci.pclk2_hz, 115200);
	setup_faults();
	con_puts("\nswell-fw stm32f405 ");
	con_puts(SWELL_FW_VERSION_STR);
	con_puts(" board " SWELL_BOARD_NAME "\n");
	put_reset_cause(csr);
	came_back = boot_report();
	con_puts("clock: ");
	con_puts(clock_src_name(ci.src));
	con_puts_u32(" sysclk ", ci.sysclk_hz);
	con_puts_u32(" Hz, apb1 ", ci.pclk1_hz);
	con_puts_u32(" Hz, apb2 ", ci.pclk2_hz);
	con_puts(" Hz");
	if (ci.hse_timeout)
		con_puts(" (HSE did not start: timeout)");
	if (ci.pll_timeout)
		con_puts(" (PLL did not lock: timeout)");
	if (ci.switch_timeout)
		con_puts(" (switch to PLL not confirmed: timeout)");
	con_putc('\n');

	err = image_check(&img);
	con_puts("image: ");
	if (err != SWELL_OK) {
		con_puts("REFUSED: ");
		con_puts(swell_err_str(err));
		con_putc('\n');
		fault_stop("image check failed");
	}
	con_puts_u32("version ", img.version >> 16);
	con_puts_u32(".", (img.version >> 8) & 0xFFu);
	con_puts_u32(".", img.version & 0xFFu);
	con_puts_u32(", ", img.length);
	con_puts_hex32(" bytes, crc32 0x", img.crc);
	con_puts(" ok\n");
	board_led(1); /* lit: the image is whole; a stop on a fault (fault_stop) puts it out */

	mem_probe(&app_mem, app_arena,
		  APP_ARENA_WORDS); /* the bus fault is enabled: a missing block is a recoverable fault */

	timebase_init(PRIO_SYSTICK);
	con_puts("cycles: ");
	con_puts(timebase_has_dwt() ? "DWT CYCCNT\n" : "SysTick (no DWT CYCCNT on this core)\n");

	can_ok = can_probe();
	usb_ok = usb_probe();
	con_puts("link: CAN1 ");
	con_puts(can_ok ? "answers" : "absent");
	con_puts(", USB OTG FS ");
	con_puts(usb_ok ? "answers" : "absent");
	con_putc('\n');

	if (!can_ok && !usb_ok) {
#ifdef SWELL_FW_SELFTEST
		if (boot_mode == BOOT_MODE_BOOTLOADER) {
			if (!came_back)
				selftest_boot_request(); /* returns only on a failed check */
			con_puts(came_back ? "boot test: end, back in this image\n" : "boot test: end, FAILED\n");
			for (;;)
				__asm__ volatile("wfi");
		}
		selftest_run(ci.tim_apb1_hz);
		if (boot_mode == BOOT_MODE_FAULT) {
			con_puts("boot mode: fault injection (force 1234 cN on z, then an undefined instruction)\n");
			safe_force_record(0, 0, 1234);
			__asm__ volatile("udf #0");
		}
#else
		(void)boot_mode;
		(void)came_back;
		con_puts("link: none answered: stopped, force zero\n");
#endif
		for (;;)
			__asm__ volatile("wfi");
	}

	{
		const struct app_prio prio = { PRIO_TICK, PRIO_CAN_RX, PRIO_CAN_SCE, PRIO_USB };

		app_run(&ci, can_ok, usb_ok, &prio, WATCHDOG_MS);
	}
}
