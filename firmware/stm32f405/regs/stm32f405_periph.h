/* STM32F405 GPIO, USART, general-purpose timer (TIM2..5) and independent watchdog
 * (RM0090 sections 8, 30, 18, 21), and the interrupt numbers the port uses (RM0090 table 61). */
#ifndef SWELL_REGS_STM32F405_PERIPH_H
#define SWELL_REGS_STM32F405_PERIPH_H

#include "cortex_m4.h"

struct gpio_regs {
	volatile uint32_t MODER, OTYPER, OSPEEDR, PUPDR, IDR, ODR, BSRR, LCKR, AFR[2];
};
REG_CHECK(struct gpio_regs, AFR, 0x20);
#define GPIOA ((struct gpio_regs *)0x40020000u)
#define GPIO_MODE_AF 2u
#define GPIO_SPEED_HIGH 2u

struct usart_regs {
	volatile uint32_t SR, DR, BRR, CR1, CR2, CR3, GTPR;
};
#define USART1 ((struct usart_regs *)0x40011000u)
#define USART_SR_TXE (1u << 7)
#define USART_SR_TC (1u << 6)
#define USART_CR1_UE (1u << 13)
#define USART_CR1_TE (1u << 3)

struct tim_regs {
	volatile uint32_t CR1, CR2, SMCR, DIER, SR, EGR, CCMR1, CCMR2, CCER, CNT, PSC, ARR;
};
REG_CHECK(struct tim_regs, CNT, 0x24);
REG_CHECK(struct tim_regs, ARR, 0x2C);
#define TIM2 ((struct tim_regs *)0x40000000u)
#define TIM_CR1_CEN (1u << 0)
#define TIM_CR1_URS (1u << 2)
#define TIM_DIER_UIE (1u << 0)
#define TIM_SR_UIF (1u << 0)
#define TIM_EGR_UG (1u << 0)

struct iwdg_regs {
	volatile uint32_t KR, PR, RLR, SR;
};
#define IWDG ((struct iwdg_regs *)0x40003000u)
#define IWDG_KEY_UNLOCK 0x5555u
#define IWDG_KEY_START 0xCCCCu
#define IWDG_KEY_REFRESH 0xAAAAu
#define IWDG_SR_PVU (1u << 0)
#define IWDG_SR_RVU (1u << 1)

/* Interrupt numbers (position in the vector table minus 16). */
enum stm32f405_irq {
	IRQ_CAN1_RX0 = 20,
	IRQ_CAN1_SCE = 22,
	IRQ_TIM2 = 28,
	IRQ_OTG_FS = 67,
	IRQ_COUNT = 82,
};

#endif
