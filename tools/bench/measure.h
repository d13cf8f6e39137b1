/* swell-bench measures: reference solutions, error norms, forcing and the stability classifier.
 * Host-only benchmark code. */
#ifndef SWELL_BENCH_MEASURE_H
#define SWELL_BENCH_MEASURE_H

#include <stdint.h>

#include "kernels.h"

/* The (m, n) standing mode with mirrored walls: phi = cos(a (i + 1/2)) cos(b (j + 1/2)),
 * a = m pi / nx, b = n pi / ny, an exact eigenvector of L9 with eigenvalue S (the symbol). */
struct bench_mode {
	int nx, ny, m, n;
	double a, b;
	double S; /* -8 + 2 (1 + cos a)(1 + cos b) */
};

void bench_mode_init(struct bench_mode *md, int nx, int ny, int m, int n);
double bench_mode_phi(const struct bench_mode *md, int i, int j);
/* amp * phi over the grid, mm. */
void bench_mode_field(const struct bench_mode *md, double amp, double *h_mm);

/* Exact discrete amplitude of the mode under eq. (1) with coefficients e_eff, q, starting at rest
 * (s(-1) = s(0) = amp): the scalar recurrence s(k+1) = s(k) + q (s(k) - s(k-1) + e_eff S s(k)),
 * advanced in long double. */
struct bench_amp {
	long double s, sp, e_eff, q, S;
	long steps;
};
void bench_amp_init(struct bench_amp *am, double amp, double e_eff, double q, double S);
void bench_amp_step(struct bench_amp *am);

/* Closed form for t = 0: s(k) = amp cos(w (k + 1/2)) / cos(w / 2), cos w = 1 + e_eff S / 2.
 * Also the continuous seiche started at rest half a step before t = 0, with w the continuous
 * omega dt = pi sqrt(e) sqrt((m/nx)^2 + (n/ny)^2) (e the physical eq. (2) value). */
double bench_amp_closed(double amp, double omega_dt, long k);
double bench_omega_discrete(double e_eff, double S); /* acos(1 + e_eff S / 2), NaN if unstable */
double bench_omega_seiche(double e, const struct bench_mode *md);

/* L-inf and L2 (root mean square over the cells) of x - y, n values. */
void bench_err(const double *x, const double *y, int n, double *linf, double *l2);

/* xorshift64*: deterministic, seeded, the same sequence on every host. */
struct bench_rng {
	uint64_t s;
};
void bench_rng_seed(struct bench_rng *r, uint64_t seed);
uint64_t bench_rng_next(struct bench_rng *r);
double bench_rng_uniform(struct bench_rng *r); /* [0, 1) */

/* A volume-conserving push, as an object entering or leaving the water makes: the k x k footprint
 * at (i0, j0) moves by `depth` LSB per cell and the ring of cells around it takes the opposite
 * volume, spread evenly with the remainder on its first cells, so the sum over the grid is exactly
 * zero. Cells outside the grid are skipped on both sides. */
void bench_push(struct bench_field *f, int i0, int j0, int k, int32_t depth);

/* Run a field from seeded noise (uniform in +-amp_mm) for `steps` steps and classify it: bounded
 * when max |h| over the last quarter of the run is at most `growth` times max |h| over the first
 * quarter, nothing saturated and nothing became non-finite. Comparing two windows, not the start,
 * keeps the large but bounded transient of modes near omega = pi (amplitude 1/cos(omega/2) when
 * started at rest) from counting as growth. Returns 1 bounded, 0 not; *gain gets the ratio. */
int bench_bounded(struct bench_field *f, double amp_mm, long steps, double growth, uint64_t seed, double *gain);

/* Analytic stability limit on e_eff: (1 + q) / (4 q). */
double bench_e_limit(double q);

#endif
