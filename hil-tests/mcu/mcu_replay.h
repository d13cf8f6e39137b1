/* The emulated STM32F405's deterministic replay (docs/stm32f405-emulator.md, "Scenarios and the force
 * identity"): a recording of the bus (SWELLREC, carrier CAN: docs/links.md) fed into CAN1 tick by tick,
 * every frame the image sends logged with its virtual time, bus faults at virtual times, and the
 * image's own record of the force it commands sampled at every tick. Host-side code of the emulator
 * (malloc at load time is fine here). */
#ifndef SWELL_MCU_REPLAY_H
#define SWELL_MCU_REPLAY_H

#include <stdint.h>
#include <stdio.h>

#include "mcu_can1.h"

#define MCU_FAULTS_MAX 16

enum mcu_fault_kind {
	MCU_FAULT_BUS_OFF, /* the node goes bus-off (bxcan_inject_bus_off) */
	MCU_FAULT_TX_ERRORS, /* the next N attempts fail with a bit error */
	MCU_FAULT_NO_ACK, /* nobody acknowledges for S seconds */
	MCU_FAULT_DOMINANT, /* the bus stuck dominant for S seconds */
	MCU_FAULT_ARB_LOST, /* the next N attempts lose arbitration: the mailboxes fill */
	MCU_FAULT_RX_BURST, /* N frames for the node in one instant: the RX FIFO (3 deep) overruns */
};

struct mcu_fault {
	uint64_t at, until; /* virtual time; until: the end of a fault with a duration */
	enum mcu_fault_kind kind;
	uint32_t n;
	int state; /* 0 waiting, 1 on, 2 done */
};

struct mcu_replay {
	/* the recording: frames in order, tick k's frames from tick_first[k] to tick_first[k + 1] */
	struct bxcan_frame *frame;
	uint32_t n_frames, *tick_first, n_ticks;
	/* feeding: the TIM2 update the current tick's frames go before, and when each is due */
	const struct mcu_periph *tim2;
	uint64_t target;
	uint32_t tick, first, next, end; /* ticks begun; the current tick's frames: first, next, end */
	uint64_t due[64];
	uint32_t late; /* frames a tick could not deliver before its update (more than fit in a period) */
	/* the log: frames sent, and the image's force record (safe.c's force_cN) at every tick */
	FILE *log;
	uint32_t force_addr;
	struct mcu_fault fault[MCU_FAULTS_MAX];
	unsigned n_faults;
	uint64_t tx_frames, ticks_seen;
};

/* Load a recording (carrier CAN; frame times say the tick: tick k = [k, k + 1) x tick_ns). 0, or -1 with
 * a one-line reason in why. Without a path the replay feeds nothing (log and faults only). */
int mcu_replay_load(struct mcu_replay *r, const char *path, uint64_t tick_ns, char *why, size_t why_len);
/* Parse "AT KIND [ARG]" (AT in virtual seconds; busoff | tx-errors N | no-ack S | dominant S |
 * arb-lost N | rx-burst N) into the fault list; 0, or -1 with the reason. */
int mcu_replay_fault(struct mcu_replay *r, const char *spec, char *why, size_t why_len);
/* Before the run: find TIM2 and the image's force record, and hook the log into CAN1's transmit
 * callback (the log may be NULL). 0, or -1 with the reason. */
int mcu_replay_start(struct mcu_replay *r, struct mcu *m, struct mcu_can1_dev *c, FILE *log, char *why, size_t why_len);
/* From the run's I/O hook (called every slice): faults due, the frames due before the next tick. */
void mcu_replay_step(struct mcu_replay *r, struct mcu *m, struct mcu_can1_dev *c);
/* The transmit callback's log line (bxcan_tx_fn); user: the replay. */
void mcu_replay_tx(void *user, const struct bxcan_frame *f, uint64_t t_ns);
void mcu_replay_free(struct mcu_replay *r);

#endif
