/* Cortex-M4 core peripherals used by the port (ARMv7-M ARM, B3): SCB, NVIC, SysTick, DWT.
 * Our own small map; offsets are checked at compile time. */
#ifndef SWELL_REGS_CORTEX_M4_H
#define SWELL_REGS_CORTEX_M4_H

#include <stddef.h>
#include <stdint.h>

#define REG_CHECK(type, field, off) _Static_assert(offsetof(type, field) == (off), #type "." #field)

struct scb_regs {
	volatile uint32_t CPUID, ICSR, VTOR, AIRCR, SCR, CCR;
	volatile uint8_t SHPR[12]; /* priority bytes of system handlers 4..15 */
	volatile uint32_t SHCSR, CFSR, HFSR, DFSR, MMFAR, BFAR, AFSR;
	uint32_t reserved0[18];
	volatile uint32_t CPACR;
};
REG_CHECK(struct scb_regs, SHPR, 0x18);
REG_CHECK(struct scb_regs, SHCSR, 0x24);
REG_CHECK(struct scb_regs, BFAR, 0x38);
REG_CHECK(struct scb_regs, CPACR, 0x88);
#define SCB ((struct scb_regs *)0xE000ED00u)

#define SCB_ICSR_PENDSTSET (1u << 26)
#define SCB_AIRCR_VECTKEY (0x05FAu << 16)
#define SCB_AIRCR_PRIGROUP_SHIFT 8
#define SCB_AIRCR_SYSRESETREQ (1u << 2)
#define SCB_CCR_DIV_0_TRP (1u << 4)
#define SCB_SHCSR_MEMFAULTENA (1u << 16)
#define SCB_SHCSR_BUSFAULTENA (1u << 17)
#define SCB_SHCSR_USGFAULTENA (1u << 18)
#define SCB_CPACR_CP10_CP11_FULL (0xFu << 20)
/* Index into SHPR for a system exception number 4..15. */
#define SCB_SHPR_IDX(exc) ((exc)-4)
#define EXC_SYSTICK 15

struct nvic_regs {
	volatile uint32_t ISER[8];
	uint32_t reserved0[24];
	volatile uint32_t ICER[8];
	uint32_t reserved1[24];
	volatile uint32_t ISPR[8];
	uint32_t reserved2[24];
	volatile uint32_t ICPR[8];
	uint32_t reserved3[24];
	volatile uint32_t IABR[8];
	uint32_t reserved4[56];
	volatile uint8_t IPR[240];
};
REG_CHECK(struct nvic_regs, ICER, 0x80);
REG_CHECK(struct nvic_regs, ICPR, 0x180);
REG_CHECK(struct nvic_regs, IPR, 0x300);
#define NVIC ((struct nvic_regs *)0xE000E100u)

struct systick_regs {
	volatile uint32_t CTRL, LOAD, VAL, CALIB;
};
#define SYSTICK ((struct systick_regs *)0xE000E010u)
#define SYSTICK_CTRL_ENABLE (1u << 0)
#define SYSTICK_CTRL_TICKINT (1u << 1)
#define SYSTICK_CTRL_CLKSOURCE (1u << 2) /* 1: processor clock */
#define SYSTICK_MAX 0x00FFFFFFu /* 24-bit counter */

#define DEMCR (*(volatile uint32_t *)0xE000EDFCu)
#define DEMCR_TRCENA (1u << 24)
struct dwt_regs {
	volatile uint32_t CTRL, CYCCNT;
};
#define DWT ((struct dwt_regs *)0xE0001000u)
#define DWT_CTRL_CYCCNTENA (1u << 0)
#define DWT_CTRL_NOCYCCNT (1u << 25)

/* Number of implemented priority bits on the STM32F4 (priorities 0..15 in the top nibble). */
#define NVIC_PRIO_BITS 4

#endif
