/* swell-sim's floating object: --object A,B,H,MASS_KG with a scripted motion, the common/ force law
 * and coupling every device tick, the safety stage, and a CSV trace. Host program code. */
#ifndef SWELL_SIM_OBJECT_H
#define SWELL_SIM_OBJECT_H

#include <stdio.h>

#include "swell/cli.h"
#include "swell/wave.h"

/* The object options, for --help. */
void sim_object_usage(FILE *f);

/* One of the object options (--object, --motion, --at, --tick-hz, --damper, --safety, --trace) with its
 * value, a swell_cli hook: 0, or -1 with the reason in c->why. */
int sim_object_option(struct swell_cli *c, const char *a, const char *v);

/* 1 when --object was given. */
int sim_object_active(void);

/* The first object option given without --object (it would be ignored), or NULL. */
const char *sim_object_orphan(void);

/* Run the scene with the object for `steps` solver steps of dt_s (cells dx_m; 0: the defaults
 * 0.004 s and 0.00625 m) and print the summary. Returns the exit status. */
int sim_object_run(struct swell_wave *w, double dt_s, double dx_m, long steps, int float64);

#endif
