/* CAN1 of the emulated STM32F405: the bxCAN model (bxcan.h) at 0x40006400 with its four interrupt
 * lines (RM0090 table 61: 19 CAN1_TX, 20 CAN1_RX0, 21 CAN1_RX1, 22 CAN1_SCE), the APB1 clock from
 * the RCC model and the RCC reset line (APB1RSTR bit 25). The model counts time in ns; the emulator's
 * units are converted with ns rounded down and units rounded up, so an event is never reached early. */
#ifndef SWELL_MCU_CAN1_H
#define SWELL_MCU_CAN1_H

#include "bxcan.h"
#include "mcu.h"

struct mcu_can1_dev {
	struct bxcan b;
};

static inline uint64_t mcu_can1_ns(uint64_t units)
{
	return units / (MCU_TIME_HZ / 1000000u) * 1000u +
		units % (MCU_TIME_HZ / 1000000u) * 1000u / (MCU_TIME_HZ / 1000000u);
}

static inline uint64_t mcu_can1_units(uint64_t ns)
{
	return ns == UINT64_MAX ? MCU_NEVER : (ns * (MCU_TIME_HZ / 1000000u) + 999u) / 1000u;
}

/* Map CAN1 (before mcu_run). 0, or -1 when the map or the reset line could not be set up. */
int mcu_can1_add(struct mcu *m, struct mcu_can1_dev *c);
/* A frame from another node, its EOF at the emulator's time (NULL: only bring the model and its lines
 * up to now). ctx: the mcu_can1_dev. */
void mcu_can1_bus_rx(struct mcu *m, void *ctx, const struct bxcan_frame *f);

#endif
