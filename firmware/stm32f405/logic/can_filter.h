/* bxCAN acceptance filters for 11-bit data frames (RM0090 32.7.4), planned as register values.
 * Exact identifiers go in 16-bit list mode (4 per bank), id/mask pairs in 16-bit mask mode (2 per
 * bank); RTR and IDE are always compared, so remote and extended frames never pass. A bank
 * delivers to one FIFO, so specs are grouped by FIFO. When an identifier matches specs with
 * different FIFOs, an exact identifier wins over a mask (the hardware's rule); avoid overlaps
 * between masks of different FIFOs. */
#ifndef SWELL_FW_CAN_FILTER_H
#define SWELL_FW_CAN_FILTER_H

#include <stdint.h>

#include "swell/err.h"

#define CAN_FILTER_BANKS_CAN1 14 /* CAN2 start bank left at the reset value 14 */

enum can_filter_kind {
	CAN_FILTER_EXACT = 0, /* accept id only */
	CAN_FILTER_MASK = 1, /* accept every x with (x ^ id) & mask == 0 */
};

struct can_filter_spec {
	uint16_t id; /* 0..0x7FF */
	uint16_t mask; /* 0..0x7FF, MASK kind only: 1 bits must match */
	uint8_t kind; /* enum can_filter_kind */
	uint8_t fifo; /* 0 or 1 */
};

struct can_filter_bank {
	uint32_t fr1, fr2;
	uint8_t list_mode; /* FM1R bit: 1 list, 0 mask */
	uint8_t fifo; /* FFA1R bit */
};

/* Plan banks for specs[0..n). SWELL_ERANGE for a bad id, mask, kind or FIFO; SWELL_ESIZE when more
 * than max_banks are needed. Outputs untouched on error. */
enum swell_err can_filter_plan(const struct can_filter_spec *specs, unsigned n, struct can_filter_bank *banks,
			       unsigned max_banks, unsigned *nbanks);

/* A model of the hardware's filter match (16-bit scale, all banks active), for tests and the
 * driver's self-check: is a frame with this id, rtr and ide accepted, and into which FIFO? */
int can_filter_match(const struct can_filter_bank *banks, unsigned nbanks, uint16_t id, int rtr, int ide,
		     unsigned *fifo);

#endif
