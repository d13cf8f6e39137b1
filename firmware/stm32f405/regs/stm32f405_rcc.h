/* STM32F405 reset and clock control, flash interface and power control (RM0090 sections 3, 5, 7). */
#ifndef SWELL_REGS_STM32F405_RCC_H
#define SWELL_REGS_STM32F405_RCC_H

#include "cortex_m4.h"

struct rcc_regs {
	volatile uint32_t CR, PLLCFGR, CFGR, CIR;
	volatile uint32_t AHB1RSTR, AHB2RSTR, AHB3RSTR;
	uint32_t reserved0;
	volatile uint32_t APB1RSTR, APB2RSTR;
	uint32_t reserved1[2];
	volatile uint32_t AHB1ENR, AHB2ENR, AHB3ENR;
	uint32_t reserved2;
	volatile uint32_t APB1ENR, APB2ENR;
	uint32_t reserved3[2];
	volatile uint32_t AHB1LPENR, AHB2LPENR, AHB3LPENR;
	uint32_t reserved4;
	volatile uint32_t APB1LPENR, APB2LPENR;
	uint32_t reserved5[2];
	volatile uint32_t BDCR, CSR;
};
REG_CHECK(struct rcc_regs, APB1RSTR, 0x20);
REG_CHECK(struct rcc_regs, AHB1ENR, 0x30);
REG_CHECK(struct rcc_regs, APB1ENR, 0x40);
REG_CHECK(struct rcc_regs, APB2ENR, 0x44);
REG_CHECK(struct rcc_regs, CSR, 0x74);
#define RCC ((struct rcc_regs *)0x40023800u)

#define RCC_CR_HSION (1u << 0)
#define RCC_CR_HSIRDY (1u << 1)
#define RCC_CR_HSEON (1u << 16)
#define RCC_CR_HSERDY (1u << 17)
#define RCC_CR_CSSON (1u << 19)
#define RCC_CR_PLLON (1u << 24)
#define RCC_CR_PLLRDY (1u << 25)

#define RCC_PLLCFGR_M_SHIFT 0 /* 2..63 */
#define RCC_PLLCFGR_N_SHIFT 6 /* 50..432 */
#define RCC_PLLCFGR_P_SHIFT 16 /* 0: /2, 1: /4, 2: /6, 3: /8 */
#define RCC_PLLCFGR_SRC_HSE (1u << 22)
#define RCC_PLLCFGR_Q_SHIFT 24 /* 2..15 */

#define RCC_CFGR_SW_MASK 3u
#define RCC_CFGR_SW_HSI 0u
#define RCC_CFGR_SW_PLL 2u
#define RCC_CFGR_SWS_SHIFT 2
#define RCC_CFGR_HPRE_SHIFT 4
#define RCC_CFGR_PPRE1_SHIFT 10
#define RCC_CFGR_PPRE2_SHIFT 13
#define RCC_CFGR_PPRE_DIV2 4u
#define RCC_CFGR_PPRE_DIV4 5u

#define RCC_AHB1ENR_GPIOA (1u << 0)
#define RCC_AHB1ENR_CCMDATARAM (1u << 20)
#define RCC_AHB2ENR_OTGFS (1u << 7)
#define RCC_APB1ENR_TIM2 (1u << 0)
#define RCC_APB1ENR_CAN1 (1u << 25)
#define RCC_APB1ENR_PWR (1u << 28)
#define RCC_APB1RSTR_CAN1 (1u << 25)

#define RCC_CSR_RMVF (1u << 24)
#define RCC_CSR_BORRSTF (1u << 25)
#define RCC_CSR_PINRSTF (1u << 26)
#define RCC_CSR_PORRSTF (1u << 27)
#define RCC_CSR_SFTRSTF (1u << 28)
#define RCC_CSR_IWDGRSTF (1u << 29)

struct flash_regs {
	volatile uint32_t ACR, KEYR, OPTKEYR, SR, CR, OPTCR;
};
#define FLASH_IF ((struct flash_regs *)0x40023C00u)
#define FLASH_ACR_PRFTEN (1u << 8)
#define FLASH_ACR_ICEN (1u << 9)
#define FLASH_ACR_DCEN (1u << 10)

struct pwr_regs {
	volatile uint32_t CR, CSR;
};
#define PWR ((struct pwr_regs *)0x40007000u)
#define PWR_CR_VOS (1u << 14) /* scale 1: needed for 168 MHz */

#endif
