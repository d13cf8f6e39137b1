/* Effect mode on a HapticMaster (docs/hapticmaster.md, "Effect mode": the four swell_* effects, their
 * units and the requests): the controller's effect sets (EFFECT_SPRING, EFFECT_DAMPER, EFFECT_LIMIT,
 * swell/effect.h) become the device's own effects, which it renders every servo tick. Shared by
 * swell-ctl's hm: link and swell-hmbridge, on top of hm_client; no request waits. */
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
