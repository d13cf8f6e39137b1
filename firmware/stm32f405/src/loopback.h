/* Software loopback link used by the self-test when no CAN or USB peripheral answers: frames sent
 * come back in order, as a bus with one silent listener would return them in bxCAN loopback mode. */
#ifndef SWELL_FW_LOOPBACK_H
#define SWELL_FW_LOOPBACK_H

#include <stdint.h>

#include "swell/err.h"

struct fw_frame {
	uint32_t id; /* 11-bit standard identifier */
	uint8_t len; /* 0..8 */
	uint8_t data[8];
};

#define LOOPBACK_DEPTH 8

int loopback_selftest(void);

#endif
