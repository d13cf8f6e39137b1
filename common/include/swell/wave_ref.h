/* Float64 implementation of eq. (1) in its printed three-level form, with ghost cells, for tests
 * and benchmarks only: host code, never on the controller path. It shares no code with wave.c, so
 * agreement between the two checks the edge-flux derivation as well as the rounding. */
#ifndef SWELL_WAVE_REF_H
#define SWELL_WAVE_REF_H

#include <stddef.h>
#include <stdint.h>

#include "swell/wave.h"

#define SWELL_WAVE_REF_DOUBLES(nx, ny) ((size_t)3 * (size_t)(nx) * (size_t)(ny))

struct swell_wave_ref {
	int nx, ny;
	double *h; /* h(n), in mm */
	double *hp; /* h(n-1) */
	double *next; /* scratch */
	double e_eff; /* e, or e/2 for the calibrated stencil */
	double q; /* 1 - t */
	uint32_t steps;
};

/* Same coefficients as the fixed-point field (its e_eff and q, which are exact in double), heights
 * converted from LSB to mm, at rest. storage: SWELL_WAVE_REF_DOUBLES(nx, ny) doubles. */
void swell_wave_ref_from_fixed(struct swell_wave_ref *r, const struct swell_wave *w, double *storage);

void swell_wave_ref_step(struct swell_wave_ref *r);

double swell_wave_ref_volume(const struct swell_wave_ref *r);

#endif
