/* The velocity form's row kernels (wave.h, "Velocity form"): private to the solver, one kernel a
 * file (wave_vel_ref.c, wave_vel_fused.c, wave_vel_avx2.c), called by wave.c for a run of awake tiles of a row.
 *
 * A kernel computes, for every cell (i, j) of the tiles tx0 <= tx < tx1 (at most SWELL_WAVE_VEL_RUN;
 * the last tile of the row may be narrower) of row j, from the heights h(n) of
 * rows j-1 .. j+1 (mirrored at the walls) and the cell's momentum u(n):
 *     x = 2 L9 = ([1 2 1] x [1 2 1]) h - 16 h          exact in int32 for |h| <= 2^26
 *     C = e_eff 2^(F+1)  (F = vel_frac; C < 2^31)      the coefficient, u in 2^-F height LSB
 *     s = u + floor((x C + 2^31) / 2^32)               undamped: e L9 to nearest, ties up
 *     s = u + floor(x C / 2^32), s += (s < 0)          damped (then F = 0): the sum toward zero (a
 *                                                      negative exact integer one LSB further):
 *                                                      dissipative, so damped water comes to rest
 *     s = clamp(s, SWELL_H_MIN, SWELL_H_MAX)           counted in saturations
 *     s = floor(q s / 2^30) + (s < 0)   (damp only)    toward zero: q = 1 - t is odd
 *     dh = (s + 2^(F-1) - (s < 0)) >> F  (dh = s at 0)  the height change, nearest, ties away
 *                                                      from zero (no bias in the volume residual)
 * and stores u = s, acc += dh; it adds the sums of the new s and dh to sum[0] and sum[1] and sets
 * any[tx - tx0] non-zero exactly when some new s of that tile is non-zero. Every kernel gives the
 * same bits as swell_wave_vel_ref. */
#ifndef SWELL_WAVE_PRIV_H
#define SWELL_WAVE_PRIV_H

#include <stdint.h>

#include "swell/wave.h"

#define SWELL_WAVE_VEL_RUN 8 /* tiles a call at most */

/* Tile flags. Z1: every flow of the tile's edges was zero after the last finished step. ZERO: after
 * the last two (then the increments e w dh are zero after damping too, not just cancelling an old
 * flow). NONZERO: some edge gave a non-zero flow in the step in progress. CHANGED: a cell of the tile
 * changed in the last finished step. TOUCHED: a cell changed (from outside, or at the finish) in the
 * step in progress. */
#define T_ZERO 1u
#define T_NONZERO 2u
#define T_CHANGED 4u
#define T_TOUCHED 8u
#define T_Z1 16u
/* DIRTY: the step in progress may have written acc in this tile (an edge of it or of a neighbour tile
 * was computed, or water was added). PREV: the same for the last finished step, whose acc is now v. */
#define T_DIRTY 32u
#define T_DIRTY_PREV 64u
/* SLEEPING: decided at the first row of the tile's row in this step (asleep() is a 3 x 3 scan; one
 * decision serves the tile's eight rows); swell_wave_touched() clears it around the touched cell. */
#define T_SLEEPING 128u

void swell_wave_vel_ref(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any);
void swell_wave_vel_fused(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any);

/* x86-64 with AVX2 (wave.c checks the CPU before it chooses it) */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(SWELL_NO_AVX2)
#define SWELL_WAVE_VEL_AVX2 1
void swell_wave_vel_avx2(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any);
/* The finishing pass of row j (wave.c's finish_row), the same bits: where a tile has the flags of
 * need, h += acc (T_DIRTY; clamped to int27, a row that clamped counted once, T_TOUCHED where acc
 * is non-zero) and v = 0 (T_DIRTY_PREV); every tile when tiles do not sleep. */
void swell_wave_vel_finish_avx2(struct swell_wave *w, int j, uint8_t need);
#else
#define SWELL_WAVE_VEL_AVX2 0
#endif

#endif
