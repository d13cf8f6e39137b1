/* What the controller core's files share (ctl.c: the tick and the states; ctl_param.c: the parameters;
 * ctl_telemetry.c: what goes to the host; ctl_solver.c: the solver step spread over its ticks). Not
 * part of the core's interface (swell/ctl.h, swell/ctl_port.h). */
#ifndef SWELL_CTL_PRIV_H
#define SWELL_CTL_PRIV_H

#include <string.h>

#include "swell/ctl.h"

/* Stale quads read a tick at most: QUAD_READS_PER_S / tick_hz (ctl_telemetry.c). */
#define QUAD_READS_PER_S 90000u
#define NEVER_SENT INT16_MIN

/* Ticks between two sends of something sent hz times a second (at least every tick). */
static inline uint32_t ctl_period(const struct swell_ctl *c, uint32_t hz)
{
	uint32_t p = c->cfg.tick_hz / hz;

	return p ? p : 1;
}

static inline int16_t ctl_sent_get(const struct swell_ctl *c, uint32_t a)
{
	return (int16_t)(uint16_t)(c->sent[a >> 1] >> ((a & 1u) * 16));
}

static inline void ctl_sent_set(struct swell_ctl *c, uint32_t a, int16_t v)
{
	uint32_t shift = (a & 1u) * 16;

	c->sent[a >> 1] = (c->sent[a >> 1] & ~(0xffffu << shift)) | ((uint32_t)(uint16_t)v << shift);
}

static inline struct swell_msg ctl_msg(const struct swell_ctl *c, enum swell_msg_type type)
{
	struct swell_msg m;

	memset(&m, 0, sizeof(m));
	m.type = (uint8_t)type;
	m.node = c->cfg.node;
	return m;
}

static inline struct swell_fsafety_params ctl_safety_params(const struct swell_ctl_config *cfg)
{
	struct swell_fsafety_params p = cfg->safety;

	p.tick_hz = cfg->tick_hz;
	return p;
}

static inline int16_t ctl_to_cN(int32_t uN)
{
	int32_t cN = (uN >= 0 ? uN + 5000 : uN - 5000) / 10000;

	return (int16_t)swell_clamp(cN, -25000, 25000);
}

static inline int16_t ctl_to_10um(int32_t um)
{
	int32_t t = (um >= 0 ? um + 5 : um - 5) / 10;

	return (int16_t)swell_clamp(t, -30000, 30000);
}

/* A limited force on the wire: to the nearest cN, but no more than the whole cN within f_max (a limit
 * that is not a whole number of cN would otherwise be passed by up to 0.5 cN). */
static inline int16_t ctl_force_cN(const struct swell_ctl *c, int32_t uN)
{
	const int32_t lim = (int32_t)(c->cfg.safety.f_max_uN / 10000u);

	return (int16_t)swell_clamp(ctl_to_cN(uN), -lim, lim);
}

/* ctl.c: a message onto a link's queue (the oldest goes when it is full). */
void ctl_push(struct swell_ctl *c, enum swell_ctl_link l, const struct swell_msg *m);

/* ctl_param.c: a PARAM_SET or PARAM_GET from the host, answered with PARAM_ACK or PARAM_NACK. */
void ctl_param_msg(struct swell_ctl *c, const struct swell_msg *m);

/* ctl_telemetry.c */
void ctl_send_heartbeat(struct swell_ctl *c);
/* The background part's sends of tick t within `budget` messages: heartbeat, scene, info, pose and the
 * changed height quads; returns the cells read. */
uint32_t ctl_telemetry(struct swell_ctl *c, uint32_t t, uint32_t budget);
/* The solver step just finished: the quads of every tile that moved are stale. */
void ctl_mark_moved_tiles(struct swell_ctl *c);
/* The object's water was `before` and is now c->body.placed: the tiles where it changed are stale. */
void ctl_mark_water_moved(struct swell_ctl *c, const struct swell_body_fp *before);

/* ctl_solver.c: this tick's share of the solver step (the step's end on the period's last tick);
 * returns the cells done. */
uint32_t ctl_solver_slice(struct swell_ctl *c);

/* ctl_energy.c, the force part, after the force law and before the safety stage: keeps the tick's
 * device position; with force.passivity on and the account's D below zero, adds the controller's
 * force to f_dev_uN (device axes). Outside RUNNING it ends the run. */
void ctl_energy_force(struct swell_ctl *c, int running, int32_t f_dev_uN[3]);
/* The background part: W to the force part's position, S(n), D and its least value; the force now
 * held, as the wire carries it. */
void ctl_energy_account(struct swell_ctl *c);
/* The background part at a solver step's end: the water's energy, when the port keeps it. */
void ctl_energy_water(struct swell_ctl *c);

#endif
