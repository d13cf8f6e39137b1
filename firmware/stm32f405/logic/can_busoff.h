/* Bus-off recovery policy of the bxCAN driver, without registers. Recovery (a pass through
 * initialisation mode; the controller then waits for 128 x 11 recessive bits) is requested after a
 * hold-off; a node that goes bus-off again within CAN_BUSOFF_QUIET_MS of recovering doubles its
 * hold-off, up to CAN_BUSOFF_MAX_MS, so a broken bus is not flooded with error frames. All times are
 * in ms of a free-running 32-bit counter (wrap-safe). */
#ifndef SWELL_FW_CAN_BUSOFF_H
#define SWELL_FW_CAN_BUSOFF_H

#include <stdint.h>

#define CAN_BUSOFF_BASE_MS 100u
#define CAN_BUSOFF_MAX_MS 1600u
#define CAN_BUSOFF_QUIET_MS 1000u

struct can_busoff {
	uint8_t pending; /* bus-off seen, recovery not yet done */
	uint8_t recovered_once;
	uint32_t since_ms; /* bus-off (or last failed attempt) time */
	uint32_t recovered_ms; /* time of the last recovery */
	uint32_t holdoff_ms;
	uint32_t count; /* bus-off events */
};

void can_busoff_init(struct can_busoff *b);
/* A bus-off was seen at now (repeated reports while pending are ignored). */
void can_busoff_event(struct can_busoff *b, uint32_t now_ms);
/* Is a recovery attempt due? */
int can_busoff_due(const struct can_busoff *b, uint32_t now_ms);
/* The attempt at now succeeded (ok = 1) or must be retried after another hold-off (ok = 0). */
void can_busoff_attempted(struct can_busoff *b, uint32_t now_ms, int ok);

#endif
