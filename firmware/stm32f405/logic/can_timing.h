/* bxCAN bit timing (RM0090 32.7.7): one bit = 1 + TS1 + TS2 time quanta, tq = BRP / f_APB1,
 * sample point after 1 + TS1 quanta. Limits: BRP 1..1024, TS1 1..16, TS2 1..8, SJW 1..4. */
#ifndef SWELL_FW_CAN_TIMING_H
#define SWELL_FW_CAN_TIMING_H

#include <stdint.h>

#include "swell/err.h"

struct can_timing {
	uint16_t brp; /* prescaler, 1..1024 */
	uint8_t ts1, ts2, sjw; /* in time quanta */
	uint8_t tq_per_bit; /* 1 + ts1 + ts2, 8..25 */
	uint16_t sample_permille; /* (1 + ts1) / tq_per_bit, in 0.1 % */
};

/* Exact bit rate only (f_clk = bitrate * brp * tq_per_bit); among those, the sample point nearest
 * to want_sp_permille (CiA: 875), then the most quanta per bit. SWELL_ERANGE when no exact setting
 * exists or an argument is 0; *t untouched on error. */
enum swell_err can_timing_compute(uint32_t clk_hz, uint32_t bitrate, uint16_t want_sp_permille, struct can_timing *t);

/* The CAN_BTR value (without the loopback/silent bits). */
uint32_t can_timing_btr(const struct can_timing *t);

#endif
