/* ef32: eq. (1) in its edge-flux form, a bench scheme (swell-bench compares it with the solver,
 * swell/wave.h, in the run-time-against-error table). Host code; never on the controller path.
 *
 * L9 is a graph Laplacian, L9_a = sum over neighbours b of w_ab (h_b - h_a), so eq. (1) can be
 * solved in its edge-flux form: every edge (a, b) keeps a flow f, the volume that moves from b into a
 * in one step,
 *     f(n) = (1-t) [ f(n-1) + e w_ab (h_b - h_a)(n-1) ],   h_a += f,   h_b -= f.
 * Summing the flows of a cell gives back eq. (1) exactly (the cell's velocity is the sum of its
 * flows, zero at rest). In fixed point every rounded flow is added to one cell and subtracted from
 * another, so the volume sum(h) is conserved exactly, whatever the rounding.
 * Mirrored ghosts turn into edge weights: diagonals 1/2, inner orthogonal edges 1, and orthogonal
 * edges that run along a wall 3/2 (the two diagonals through the ghost fold onto them).
 *
 * Fixed point. Heights and flows are int32 with 1 LSB = 2^-16 mm (SWELL_H_FRAC), saturated to the
 * int28 range [SWELL_H_MIN, SWELL_H_MAX] (+-2048 mm), so no intermediate can overflow. Coefficients
 * are Q1.30 (the solver's e_eff and 1-t, swell_wave_check's limits). Rounding: e w dh is rounded to
 * nearest (ties up); the damping product (1-t) s is rounded toward zero, so damping never leaves a
 * flow stuck in a limit cycle (any non-zero flow loses at least one LSB per step when t > 0). 1-t is
 * made odd (t moves by at most 2^-30): then rounding toward zero is floor + (s < 0).
 *
 * Kernels (ef32_set_kernel, the solver's enum): the scalar reference (SWELL_KERNEL_REF, the
 * definition), a fused scalar kernel (one pass per row: flows, the cell's own sum and the row
 * above's) and, on x86-64 with AVX2, an 8-lane kernel over whole tile rows. All are bit-identical.
 *
 * Sleeping tiles (lossless): the grid is cut into 8 x 8 tiles. A tile whose edges all gave zero flow
 * in the last step, and none of whose cells nor its neighbour tiles' cells changed since, would give
 * zero flows again: its edges are skipped, bit-identically. Anything that writes h from outside must
 * say so with ef32_touched() (or ef32_rest()).
 *
 * Storage is the caller's: EF32_WORDS(nx, ny) int32 words. */
#ifndef SWELL_EF32_H
#define SWELL_EF32_H

#include <stddef.h>
#include <stdint.h>

#include "swell/wave.h"

/* h, v and the step accumulator (nx ny words each); the four flows of every tile row, E N NE NW,
 * 8 words each (rows padded to whole tiles); then one flag byte a tile */
#define EF32_WORDS(nx, ny)                                                                               \
	(3 * (size_t)(nx) * (size_t)(ny) + 4 * SWELL_WAVE_TILE * SWELL_WAVE_TILES_X(nx) * (size_t)(ny) + \
	 (SWELL_WAVE_TILES(nx, ny) + 3) / 4)

struct ef32 {
	uint16_t nx, ny;
	int32_t *h; /* h(n), row-major, LSB 2^-16 mm */
	int32_t *v; /* h(n) - h(n-1), the last step's change */
	int32_t *acc; /* the step in progress: sum of the new flows of every cell */
	/* Flows, by tile row: the 8 cells (i, j) with i / 8 = tx have their flows at
	 * f + 32 (j tiles_x + tx) + 8 k + i % 8, k = 0 E (into (i,j) from (i+1,j)), 1 N (from (i,j+1)),
	 * 2 NE (from (i+1,j+1)), 3 NW (from (i-1,j+1)). */
	int32_t *f;
	struct swell_wave_params p;
	q30_t e_eff; /* e (paper) or e/2 (calibrated), made even */
	q30_t c_1; /* e_eff * 1   inner orthogonal edges */
	q30_t c_half; /* e_eff * 1/2 diagonal edges */
	q30_t c_wall; /* e_eff * 3/2 orthogonal edges along a wall */
	q30_t q; /* 1 - t, made odd when t > 0 */
	uint32_t steps;
	uint32_t saturations; /* row segments (up to a tile row) in which a height or flow was clamped */
	uint16_t tiles_x, tiles_y;
	uint8_t *tile; /* flag byte a tile (ef32.c) */
	uint8_t sleep; /* 1: skip sleeping tiles (default); 0: every edge every step */
	uint8_t band_asleep; /* every tile of the band of rows in progress sleeps */
	uint32_t tiles_skipped; /* tile-rows skipped, cumulative */
	uint8_t kernel; /* enum swell_wave_kernel in use (never AUTO) */
};

/* Bind caller storage (EF32_WORDS(nx, ny) words) and set the water flat and at rest; the
 * parameters' checks are swell_wave_check's. On error *w is untouched. */
enum swell_err ef32_init(struct ef32 *w, uint16_t nx, uint16_t ny, int32_t *storage, size_t words,
			 const struct swell_wave_params *p);

/* The coefficients e_eff (made even) and q as given, outside the validated region too (the bench's
 * stress runs; ef32_init makes q odd when damped): every tile awake. */
void ef32_force(struct ef32 *w, q30_t e_eff, q30_t q);

/* The present heights become the rest state: all flows and v zero. */
void ef32_rest(struct ef32 *w);

/* One step: every edge, then h += acc, v = acc. */
void ef32_step(struct ef32 *w);

/* Cell (i, j) was written from outside: wake its tile and the neighbours (outside the grid: ignored). */
void ef32_touched(struct ef32 *w, int i, int j);

/* Tile sleeping on (default) or off; results are bit-identical either way. */
void ef32_set_sleep(struct ef32 *w, int on);

/* SWELL_EINVAL if this build or CPU lacks the kernel, and nothing changes; AUTO the fastest. */
enum swell_err ef32_set_kernel(struct ef32 *w, enum swell_wave_kernel k);

/* sum(h) in LSB, exact */
int64_t ef32_volume(const struct ef32 *w);

/* The exact integer energy of swell/wave.h's struct swell_energy, with v as h(n) - h(n-1). */
struct swell_energy ef32_energy(const struct ef32 *w);

/* CRC-32 of the state: heights, then every E flow in cell order, then N, NE, NW; int32 little-endian. */
uint32_t ef32_checksum(const struct ef32 *w);

#endif
