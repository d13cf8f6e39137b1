/* Choice of a bxCAN transmit mailbox. The hardware (MCR.TXFP = 0) sends the pending frame with the
 * lowest identifier first, and between equal identifiers the lower mailbox number first; so a frame
 * never goes into a mailbox below a pending frame of the same id (streams stay in order), and when
 * all three are busy the least urgent pending frame is aborted for a more urgent one. */
#ifndef SWELL_FW_CAN_TX_H
#define SWELL_FW_CAN_TX_H

#include <stdint.h>

#include "swell/err.h"

/* tme: bit m set when mailbox m is empty; pend_id[m]: id of the frame pending in mailbox m (only
 * read when not empty). On SWELL_OK, *mb is the mailbox to fill and *abort is 1 when its pending
 * frame must be aborted first. SWELL_ESIZE: refuse (every pending frame is at least as urgent, or
 * order would break); outputs untouched. */
enum swell_err can_tx_pick(uint32_t tme, const uint32_t pend_id[3], uint32_t new_id, unsigned *mb, int *abort);

#endif
