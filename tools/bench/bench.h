/* swell-bench's modes, one file each, and what they share. main.c: the arguments, the --f405 input
 * and the order of the modes; bench_matrix.c: run time against error; bench_error.c: the error runs
 * and error against steps; scenes.c: the image's cost scenes; bench_stability.c: the stability map;
 * bench_stress.c: the stress runs; bench_plots.c: the plots. */
#ifndef SWELL_BENCH_H
#define SWELL_BENCH_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "kernels.h"
#include "measure.h"
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
const char *stencil_name(enum swell_stencil st);

struct sample {
	long step;
	double linf_ref, l2_ref, linf_eig, l2_eig, linf_sei, l2_sei, e_drift, vol_lsb;
};

/* The (1,1) mode at AMP_MM from rest, its errors at the steps at[0..nat) (ascending) into out. */
void error_run(enum bench_impl impl, enum swell_stencil st, int nx, double e, double t, const long *at, int nat,
	       struct sample *out, uint32_t *sat);

/* The STM32F405 image's instruction counts (--f405): per cell-step of each kernel; its cost scenes
 * per cell-step and per awake cell-step, in the edge-flux and the velocity form; the naive int32 loop. */
extern double f405_instr[BENCH_IMPL_COUNT];
extern double f405_cost[FW_COST_SCENES], f405_cost_awake[FW_COST_SCENES]; /* the solver's */
extern double f405_naive;

/* The modes, in the order of a run; each writes its CSV file and prints its figures. */
void run_matrix(const struct opts *o);
void run_error_steps(const struct opts *o);
void run_scenes(const struct opts *o);
void run_stability(const struct opts *o);
void run_stress(const struct opts *o);
/* plots.gp and the PNGs from the CSV files in o->out: 0 when gnuplot drew them. */
int write_plots(const struct opts *o);
/* --replot: the first CSV file the plots read that is missing or empty in o->out, else NULL. */
const char *missing_results(const struct opts *o);

#endif
