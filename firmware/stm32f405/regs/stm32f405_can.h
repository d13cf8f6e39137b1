/* STM32F405 bxCAN (RM0090 section 32.9): CAN1 master with the 28 shared filter banks. */
#ifndef SWELL_REGS_STM32F405_CAN_H
#define SWELL_REGS_STM32F405_CAN_H

#include "cortex_m4.h"

struct can_txmb {
	volatile uint32_t TIR, TDTR, TDLR, TDHR;
};
struct can_rxfifo {
	volatile uint32_t RIR, RDTR, RDLR, RDHR;
};
struct can_filter_reg {
	volatile uint32_t FR1, FR2;
};
struct can_regs {
	volatile uint32_t MCR, MSR, TSR, RF0R, RF1R, IER, ESR, BTR;
	uint32_t reserved0[88];
	struct can_txmb TX[3];
	struct can_rxfifo RX[2];
	uint32_t reserved1[12];
	volatile uint32_t FMR, FM1R;
	uint32_t reserved2;
	volatile uint32_t FS1R;
	uint32_t reserved3;
	volatile uint32_t FFA1R;
	uint32_t reserved4;
	volatile uint32_t FA1R;
	uint32_t reserved5[8];
	struct can_filter_reg FB[28];
};
REG_CHECK(struct can_regs, BTR, 0x1C);
REG_CHECK(struct can_regs, TX, 0x180);
REG_CHECK(struct can_regs, RX, 0x1B0);
REG_CHECK(struct can_regs, FMR, 0x200);
REG_CHECK(struct can_regs, FS1R, 0x20C);
REG_CHECK(struct can_regs, FFA1R, 0x214);
REG_CHECK(struct can_regs, FA1R, 0x21C);
REG_CHECK(struct can_regs, FB, 0x240);
#define CAN1 ((struct can_regs *)0x40006400u)

#define CAN_MCR_INRQ (1u << 0)

#define CAN_MSR_INAK (1u << 0)
#define CAN_MSR_SLAK (1u << 1)
#define CAN_MSR_ERRI (1u << 2)

#define CAN_TSR_ABRQ(m) (1u << (8 * (m) + 7))
#define CAN_TSR_TME_SHIFT 26
#define CAN_TSR_TME(m) (1u << (CAN_TSR_TME_SHIFT + (m)))

#define CAN_RFR_FMP_MASK 3u
#define CAN_RFR_FOVR (1u << 4)
#define CAN_RFR_RFOM (1u << 5)

#define CAN_IER_FMPIE0 (1u << 1)
#define CAN_IER_FOVIE0 (1u << 3)
#define CAN_IER_EPVIE (1u << 9)
#define CAN_IER_BOFIE (1u << 10)
#define CAN_IER_ERRIE (1u << 15)

#define CAN_ESR_BOFF (1u << 2)

#define CAN_BTR_LBKM (1u << 30)
#define CAN_BTR_SILM (1u << 31)

#define CAN_TIR_TXRQ (1u << 0)
#define CAN_TIR_RTR (1u << 1)
#define CAN_TIR_IDE (1u << 2)
#define CAN_TIR_STID_SHIFT 21

#define CAN_FMR_FINIT (1u << 0)

#endif
