/* swell-bench's modes, one file each (main.c: the matrix, error against steps, stability, stress, plots
 * and the arguments; scenes.c: what a scene does not need is skipped), and what they share. */
#ifndef SWELL_BENCH_H
#define SWELL_BENCH_H

#include <stdio.h>

#include "kernels.h"
#include "scene.h"

#define MAX_LIST 16
#define AMP_MM 1.0 /* amplitude of the measured mode */
#define MODE_M 1
#define MODE_N 1

struct opts {
	const char *preset;
	const char *out;
	const char *f405;
	int grids[MAX_LIST], ngrids;
	double es[MAX_LIST];
	int nes;
	long steps; /* error runs of the matrix */
	long long_steps; /* error against steps */
	int reps; /* timing repetitions (best of) */
	int map_ne, map_nt;
	long map_steps;
	int bnd_nt;
	double stress_cells; /* cell-steps of the edge-of-stability runs */
	int plots;
};

/* Correctness checks count failures (the exit status); progress goes to stderr. */
void check(int ok, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void progress(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void *xmalloc(size_t n);
double now_s(void);
FILE *open_out(const struct opts *o, const char *name);
void init_or_die(struct bench_field *f, enum bench_impl impl, int nx, double e, double t, enum swell_stencil st);

/* The STM32F405 image's instruction counts (--f405): its cost scenes per cell-step and per awake
 * cell-step, in the edge-flux and the velocity form, and the naive int32 loop. */
extern double f405_cost[FW_COST_SCENES], f405_cost_awake[FW_COST_SCENES];
extern double f405_vcost[FW_COST_SCENES], f405_vcost_awake[FW_COST_SCENES];
extern double f405_naive;

void run_scenes(const struct opts *o);

#endif
