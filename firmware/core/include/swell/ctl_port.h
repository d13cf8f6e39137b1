/* The contract between the controller core and a port (Linux process, STM32F405): a port acts on
 * the core only through these calls. In: decoded messages, the clock, link events, reports. Out: the
 * two message queues (FORCE_CMD on the device queue is the force output) and the states it acts on. */
#ifndef SWELL_CTL_PORT_H
#define SWELL_CTL_PORT_H

#include <stddef.h>
#include <stdint.h>

struct swell_ctl;
struct swell_msg;

enum swell_ctl_link {
	SWELL_LINK_DEVICE = 0,
	SWELL_LINK_HOST = 1,
	SWELL_LINKS = 2
};

/* A decoded message from one link. Messages from the wrong side are counted and ignored. */
void swell_ctl_rx(struct swell_ctl *c, enum swell_ctl_link from, const struct swell_msg *m);

/* One device tick (docs/design.md): swell_ctl_tick_force then swell_ctl_tick_background. */
void swell_ctl_tick(struct swell_ctl *c);

/* The same tick in two parts for ports with interrupt priorities: the force part (steps 1-3, up to
 * FORCE_CMD) from the tick interrupt, the background part (steps 4-5, solver slice and telemetry) at
 * a lower priority right after it. Done before the next force part, the results are bit-identical to
 * swell_ctl_tick's; not done, the force part counts an overrun and runs anyway (safety first). */
void swell_ctl_tick_force(struct swell_ctl *c);
void swell_ctl_tick_background(struct swell_ctl *c);
/* 1 while the background part of the last force part has not run. */
int swell_ctl_background_due(const struct swell_ctl *c);

/* Up to cap queued messages for a link, oldest first, removed from the queue. */
size_t swell_ctl_tx(struct swell_ctl *c, enum swell_ctl_link link, struct swell_msg *out, size_t cap);

/* The carrier of a link is gone (CAN bus-off, USB unplug, TCP reset, nothing reaches the device).
 * Device link: the next tick faults exactly as after silent_ticks of silence (RUNNING -> FAULT with
 * SWELL_ETIMEOUT, ARMED -> IDLE, zero force); recovery counts from when the device is heard again.
 * The host link: nothing changes, the force loop does not depend on the host. */
void swell_ctl_link_down(struct swell_ctl *c, enum swell_ctl_link link);
/* 1 while the device counts as lost (silent for swell_ctl_silent_limit ticks, or its link down). */
int swell_ctl_device_lost(const struct swell_ctl *c);
/* The device silence limit in ticks: silent_ticks, in effect mode at least two update periods (the
 * device reports once an update there; not with cmd_every_tick). */
uint32_t swell_ctl_silent_limit(const struct swell_ctl *c);

/* Port reports. */
void swell_ctl_overrun(struct swell_ctl *c);
void swell_ctl_bad_frames(struct swell_ctl *c, uint32_t n);

/* Force the outputs to zero right now and queue a zero FORCE_CMD (shutdown, signals, faults). */
void swell_ctl_zero_force(struct swell_ctl *c);

/* 1 once an ENTER_BOOTLOADER was accepted: the force is zero and the last heartbeat queued; the port
 * drains its queues and reboots into its bootloader (or, without one, exits). */
int swell_ctl_bootloader_requested(const struct swell_ctl *c);

/* The port's relative costs of a solver step's parts, in instructions of its processor: the core
 * spreads a step over the ticks of its period by them (ctl_solver.c). */
struct swell_ctl_costs {
	uint32_t cell; /* a cell of a kernel row with its row driver and the height update one row behind */
	uint32_t scan_cell; /* the body's ceiling scan of a cell while the object is out of the water */
	uint32_t end; /* the step's end: the last row's heights, the fixers, the tile flags, the coupling */
};
/* Defined by the port, one table a program (the Cortex-M4's: firmware/stm32f405/logic/m4_costs.c). */
extern const struct swell_ctl_costs swell_ctl_port_costs;

#endif
