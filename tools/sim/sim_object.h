/* swell-sim's floating object: --object A,B,H,MASS_KG with a scripted motion, the common/ force law
 * and coupling every device tick, the safety stage, and a CSV trace. Host program code. */
#ifndef SWELL_SIM_OBJECT_H
#define SWELL_SIM_OBJECT_H

#include <stdio.h>

#include "swell/wave.h"

/* The object options, for --help. */
void sim_object_usage(FILE *f);

/* Take option a with value v if it is one of the object options: 1 taken, 0 not ours. A bad value
 * exits with status 2 and a one-line reason. */
int sim_object_option(const char *a, const char *v);

/* 1 when --object was given. */
int sim_object_active(void);

/* The first object option given without --object (it would be ignored), or NULL. */
const char *sim_object_orphan(void);

/* Run the scene with the object for `steps` solver steps of dt_s (cells dx_m; 0: the defaults
 * 0.004 s and 0.00625 m) and print the summary. Returns the exit status. */
int sim_object_run(struct swell_wave *w, double dt_s, double dx_m, long steps, int float64);

#endif
