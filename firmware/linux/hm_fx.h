/* Effect mode on a HapticMaster (docs/hapticmaster.md, "Effect mode"): the controller's effect sets
 * (EFFECT_SPRING, EFFECT_DAMPER, EFFECT_LIMIT, swell/effect.h) become the device's own effects, which
 * it renders every servo tick. Shared by swell-ctl's hm: link and swell-hmbridge, on top of hm_client.
 *
 * The device's effects, all named swell_*:
 *   swell_pull   spring, stiffness k, origin [0,0,w + D], vel [0,0,u_w], direction [0,0,1], deadband D,
 *                dampfactor 0, maxforce F_max
 *   swell_push   spring, stiffness -k, origin [0,0,w - H + D], the rest as swell_pull
 *   swell_damp   damper, dampcoef [0,0,b], vel [0,0,u_w]
 *   swell_weight biasforce, force [0,0,bias]
 * with D = HM_FX_DEADBAND_10UM (1 m, more than the workspace: the far sides of the deadbands are never
 * reached), so that their sum is the set's k clamp(w - z, 0, H) - b (v - u_w) + bias. Units on the
 * wire: 0.01 mm -> m (5 decimals), 0.1 mm/s -> m/s (4), 0.01 N/m -> N/m (2), 0.01 N s/m -> N s/m (2),
 * mN -> N (3), 0.01 N -> N (2): every value written exactly, in integers.
 *
 * Requests (none waits; they ride hm_client's pipeline):
 *   first set of a session: one request creates, configures and enables the four with the set's
 *     values (every answer must be a success, or the next sample reports a fault);
 *   every later set: its values, appended to the next tick's request (hm_client_set_extra);
 *   stop (the command disabled: fault, e-stop, mode change, exit; the set older than the freshness
 *     limit; the client not running): one request removing the four, sent on the tick the stop is
 *     seen (a set not yet sent is dropped);
 *   every (re)connection's start-up first removes them (answers ignored: they may not exist), so a
 *     device never keeps a dead session's effects. */
#ifndef SWELL_HM_FX_H
#define SWELL_HM_FX_H

#include <stdint.h>
#include <stdio.h>

#include "hm_client.h"
#include "swell/effect.h"
#include "swell/proto.h"

#define HM_FX_DEADBAND_10UM 100000 /* 1 m */
#define HM_FX_FRESH_TICKS 25 /* 10 ms at 2500 Hz, as swell-hm's --effect-fresh */

struct hm_fx_stats {
	uint32_t sets; /* complete sets taken */
	uint32_t updates, creations; /* sets sent: as an update, as the first of a session */
	uint32_t replaced; /* sets replaced by a newer one before they went out */
	uint32_t stops, stale; /* removals sent; sets that went stale */
	uint32_t unsent; /* requests that found no room (tried again next tick) */
};

struct hm_fx {
	struct swell_effect_rx rx;
	struct swell_effect set; /* the newest complete set */
	uint32_t set_tick; /* hm_client tick it came on */
	uint32_t fresh_ticks;
	int have; /* a set to render (cleared by a stop) */
	int unsent; /* ... that has not gone out yet */
	int live; /* our effects exist on the device: created in this session and not removed since */
	uint32_t session; /* the client's start-ups when they were created */
	struct hm_fx_stats st;
};

/* Ready, no set; every start-up of c removes the four effects first. fresh_ticks: a set older than
 * this many ticks (hm_client_force calls) is stale. */
void hm_fx_init(struct hm_fx *x, struct hm_client *c, uint32_t fresh_ticks);

/* One message from the controller: 1 when it was an effect message (taken), 0 otherwise. */
int hm_fx_msg(struct hm_fx *x, const struct hm_client *c, const struct swell_msg *m);

/* Every tick, just before hm_client_force: enable is whether this tick's force command is enabled (0
 * drops the set: a new one is needed); trusted 0 (swell-hmbridge's watchdog: the controller or the
 * device silent) removes the effects but keeps a fresh set for when the trust is back. Sends what the
 * tick needs: the creation, the update, or the removal. */
void hm_fx_tick(struct hm_fx *x, struct hm_client *c, int enable, int trusted);

/* The set's values as device commands ("set swell_pull pos [0,0,1.00625];..."); the length, or 0
 * when it does not fit in cap. */
size_t hm_fx_values(const struct swell_effect *e, char *buf, size_t cap);

/* "  hm effects ..." for a program's report. */
void hm_fx_report(const struct hm_fx *x, FILE *f);

#endif
