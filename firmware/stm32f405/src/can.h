/* bxCAN1 driver (RX and TX on the board's pins, AF9: PB8/PB9 on src/board.h's boards so far) from RM0090 section 32: bit timing from logic/can_timing,
 * acceptance filters from logic/can_filter, three TX mailboxes sent by identifier priority (lowest
 * id first, safety frames have the lowest ids), error counters, bus-off handled by the driver:
 * force zeroed at once, recovery after a hold-off that doubles while the bus keeps failing
 * (logic/can_busoff, not the hardware's own: a node that keeps going bus-off is rate-limited). */
#ifndef SWELL_FW_CAN_H
#define SWELL_FW_CAN_H

#include <stdint.h>

#include "../logic/can_filter.h"
#include "../logic/can_timing.h"
#include "loopback.h"
#include "swell/err.h"

/* Does a bxCAN answer (enters initialisation mode within a bounded wait)? Leaves it in reset. */
int can_probe(void);

/* Configure and start: bit timing for pclk1_hz / bitrate (SWELL_ERANGE if not exact), filters
 * (SWELL_ESIZE if they need more than 14 banks), interrupts at the given priorities.
 * loopback: internal loopback + silent (self-test on silicon without a bus). */
enum swell_err can_start(uint32_t pclk1_hz, uint32_t bitrate, const struct can_filter_spec *flt, unsigned nflt,
			 int loopback, uint8_t prio_rx, uint8_t prio_sce);

/* Queue a frame. A free mailbox is used; when all three are busy and the new frame has a lower id
 * (higher priority) than a pending one, that pending frame is aborted and replaced. SWELL_ESIZE
 * when every pending frame is more urgent; SWELL_ESTATE when stopped or bus-off. */
enum swell_err can_send(const struct fw_frame *f);

/* Take a received frame from the driver's ring (filled by the FIFO 0 interrupt); SWELL_ETRUNC
 * when empty. */
enum swell_err can_recv(struct fw_frame *f);

/* Abort every pending transmission (a safe-state hook, safe_force_zero; safe when CAN is not running). */
void can_abort_all(void);

/* Call from the main loop: runs the bus-off recovery once the hold-off has passed. */
void can_poll(uint32_t now_ms);

/* Bus-off events since start (the port compares it each tick: a new one takes the device link down). */
uint32_t can_bus_offs(void);

#endif
