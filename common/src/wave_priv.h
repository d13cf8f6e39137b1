/* The solver's row kernels (wave.h, "Form"): private to the solver, one kernel a
 * file (wave_vel_ref.c, wave_vel_fused.c, wave_vel_avx2.c), called by wave.c for a run of awake tiles of a row.
 *
 * A kernel computes, for every cell (i, j) of the tiles tx0 <= tx < tx1 (at most SWELL_WAVE_VEL_RUN;
 * the last tile of the row may be narrower) of row j, from the heights h(n) of
 * rows j-1 .. j+1 (mirrored at the walls) and the cell's momentum u(n):
 *     x = 2 L9 = ([1 2 1] x [1 2 1]) h - 16 h          exact in int32 for |h| <= 2^26
 *     C = e_eff 2^(F+1)  (F = vel_frac; C < 2^31)      the coefficient, u in 2^-F height LSB
 *     s = u + floor((x C + 2^31) / 2^32)               undamped: e L9 to nearest, ties up
 *     s = u + floor(x C / 2^32), s += (s + u < 0)      damped (then F = 0): the sum toward half the
 *                                                      kick, e L9 / 2 (up when 2 u + e L9 < 0; an
 *                                                      exact integer there one LSB up): it does
 *                                                      not add to the step's energy, so damped
 *                                                      water comes to rest (docs/fixed-point.md)
 *     s = clamp(s, SWELL_H_MIN, SWELL_H_MAX)           counted in saturations
 *     s = floor(q s / 2^30) + (s < 0)   (damp only)    toward zero: q = 1 - t is odd
 *     dh = (s + 2^(F-1) - (s < 0)) >> F  (dh = s at 0)  the height change, nearest, ties away
 *                                                      from zero (no bias in the volume residual)
 * and stores u = s (the heights follow one row behind, in the driver: h += dh); it adds the sums of the new s and dh to sum[0] and sum[1] and sets
 * any[tx - tx0] non-zero exactly when some new s of that tile is non-zero. Every kernel gives the
 * same bits as swell_wave_vel_ref. */
#ifndef SWELL_WAVE_PRIV_H
#define SWELL_WAVE_PRIV_H

#include <stdint.h>
#include <string.h>

#include "swell/wave.h"

#define SWELL_WAVE_VEL_RUN 8 /* tiles a call at most */

/* ARMv7E-M's DSP instructions (SMMLAR, SMMUL, SSAT) */
#if defined(__ARM_FEATURE_DSP) && defined(__thumb2__)
#include <arm_acle.h>
#define SWELL_WAVE_DSP 1
#else
#define SWELL_WAVE_DSP 0
#endif

#if SWELL_WAVE_DSP
/* The Q flag (sticky saturation) around a call of assembly: GCC does not take a call or an asm to set
 * Q, so its ACLE __saturation_occurred() after one may give the value read before it (seen: the
 * clamps of the heights' update went uncounted). Volatile asm with a memory clobber stays in place. */
static inline void swell_q_clear(void)
{
	__asm__ volatile("msr APSR_nzcvq, %0" : : "r"(0) : "cc", "memory");
}

static inline uint32_t swell_q_take(void)
{
	uint32_t r;

	__asm__ volatile("mrs %0, APSR" : "=r"(r) : : "memory");
	return (r >> 27) & 1u;
}
#endif

/* x86-64 kernels with AVX2 (functions compiled for it, chosen after a CPU check) */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(SWELL_NO_AVX2)
#define SWELL_WAVE_AVX2 1
#else
#define SWELL_WAVE_AVX2 0
#endif

/* Tile flags, the solver's and the bench's ef32's (tools/bench/ef32, which adds its own bits 32 and
 * 64): the tile's state is its momentum u (ef32: the flows of its edges). Z1: all of it was zero after
 * the last finished step. ZERO: after the last two (then the kicks e L9 are zero too, not just
 * cancelling an old momentum). NONZERO: some of it is non-zero in the step in progress. CHANGED: a
 * cell of the tile changed in the last finished step. TOUCHED: a cell changed (from outside, or by
 * the fixer) in the step in progress. */
#define T_ZERO 1u
#define T_NONZERO 2u
#define T_CHANGED 4u
#define T_TOUCHED 8u
#define T_Z1 16u
/* SLEEPING: decided at the first row of the tile's row in this step (swell_tiles_asleep() is a 3 x 3
 * scan; one decision serves the tile's eight rows); swell_tiles_touch() clears it around the touched
 * cell. */
#define T_SLEEPING 128u

/* 1 if any of the n flag bytes from trow (a row of tiles, or every tile) has the flag (lacks: lacks
 * it): four flag bytes a word. */
static inline int swell_tiles_row_any(const uint8_t *trow, int n, uint8_t flag, int lacks)
{
	const uint32_t mask = 0x01010101u * flag, flip = lacks ? mask : 0u;
	int x;

	for (x = 0; x + 4 <= n; x += 4) {
		uint32_t f;

		memcpy(&f, trow + x, sizeof(f));
		if ((f ^ flip) & mask)
			return 1;
	}
	for (; x < n; x++)
		if ((trow[x] ^ flip) & flag)
			return 1;
	return 0;
}

/* A tile (tx, ty) of the tiles_x x tiles_y flags t may be skipped: its state was zero for two steps
 * and nothing around it has changed since. */
static inline int swell_tiles_asleep(const uint8_t *t, int tiles_x, int tiles_y, int tx, int ty)
{
	const int x0 = tx > 0 ? tx - 1 : 0, x1 = tx + 1 < tiles_x ? tx + 1 : tx;
	const int y0 = ty > 0 ? ty - 1 : 0, y1 = ty + 1 < tiles_y ? ty + 1 : ty;
	int x, y;

	if (!(t[ty * tiles_x + tx] & T_ZERO))
		return 0;
	for (y = y0; y <= y1; y++)
		for (x = x0; x <= x1; x++)
			if (t[y * tiles_x + x] & (T_CHANGED | T_TOUCHED))
				return 0;
	return 1;
}

/* At the first row of the band of tiles ty: which of its tiles sleep in this step (T_SLEEPING);
 * 1 if all do. */
static inline __attribute__((always_inline)) int swell_tiles_band(uint8_t *t, int tiles_x, int tiles_y, int ty)
{
	uint8_t *trow = t + ty * tiles_x;
	int tx, all = 1;

	if (!swell_tiles_row_any(trow, tiles_x, T_ZERO, 0)) {
		/* no tile of the band was still for two steps (moving water): none sleeps */
		for (tx = 0; tx < tiles_x; tx++)
			trow[tx] &= (uint8_t)~T_SLEEPING;
		return 0;
	}
	for (tx = 0; tx < tiles_x; tx++) {
		if (swell_tiles_asleep(t, tiles_x, tiles_y, tx, ty)) {
			trow[tx] |= T_SLEEPING;
		} else {
			trow[tx] &= (uint8_t)~T_SLEEPING;
			all = 0;
		}
	}
	return all;
}

/* The tiles within r of the tile (tx, ty), clipped to the grid: t = (t & keep) | set. */
static inline void swell_tiles_block(uint8_t *t, int tiles_x, int tiles_y, int tx, int ty, int r, uint8_t keep,
				     uint8_t set)
{
	const int x0 = tx > r ? tx - r : 0, x1 = tx + r < tiles_x ? tx + r : tiles_x - 1;
	const int y0 = ty > r ? ty - r : 0, y1 = ty + r < tiles_y ? ty + r : tiles_y - 1;
	int x, y;

	for (y = y0; y <= y1; y++)
		for (x = x0; x <= x1; x++)
			t[y * tiles_x + x] = (uint8_t)((t[y * tiles_x + x] & keep) | set);
}

/* A cell of the tile (tx, ty) changed from outside: the tile TOUCHED, and it and its neighbours not
 * sleeping for the rest of this step. */
static inline void swell_tiles_touch(uint8_t *t, int tiles_x, int tiles_y, int tx, int ty)
{
	t[ty * tiles_x + tx] |= T_TOUCHED;
	swell_tiles_block(t, tiles_x, tiles_y, tx, ty, 1, (uint8_t)~T_SLEEPING, 0);
}

/* The first checks of an init (swell_wave_init's, ef32_init's): the state and the storage given, the
 * sides within [SWELL_WAVE_MIN_SIDE, SWELL_WAVE_MAX_SIDE], the parameters (swell_wave_check). */
static inline enum swell_err swell_wave_init_check(const void *w, const int32_t *storage, int nx, int ny,
						   const struct swell_wave_params *p)
{
	if (!w || !storage)
		return SWELL_EINVAL;
	if (nx < SWELL_WAVE_MIN_SIDE || ny < SWELL_WAVE_MIN_SIDE || nx > SWELL_WAVE_MAX_SIDE ||
	    ny > SWELL_WAVE_MAX_SIDE)
		return SWELL_ESIZE;
	return swell_wave_check(p);
}

/* The kernel k names, for this build and CPU, into *kernel (AUTO: the fastest there is); SWELL_EINVAL
 * and *kernel unchanged where the build or the CPU lacks it. */
static inline enum swell_err swell_kernel_choose(enum swell_wave_kernel k, uint8_t *kernel)
{
#if SWELL_WAVE_AVX2
	const int avx2 = __builtin_cpu_supports("avx2");
#else
	const int avx2 = 0;
#endif

	if (k == SWELL_KERNEL_AUTO)
		k = avx2 ? SWELL_KERNEL_AVX2 : SWELL_KERNEL_FUSED;
	if (k != SWELL_KERNEL_REF && k != SWELL_KERNEL_FUSED && !(k == SWELL_KERNEL_AVX2 && avx2))
		return SWELL_EINVAL;
	*kernel = (uint8_t)k;
	return SWELL_OK;
}

/* The exact integer energy (struct swell_energy) of the heights h (nx x ny, row-major) whose last step
 * changed cell a by change(ctx, a): swell_wave_energy's, and the bench's ef32's. */
struct swell_energy swell_energy_of(const int32_t *h, int nx, int ny, q30_t e_eff,
				    int32_t (*change)(const void *ctx, int a), const void *ctx);

/* The coefficients e_eff and q as given (apply_params' with the checked ones; the bench's stress runs
 * outside the validated region too), u's fraction bits for them, every tile awake. */
void swell_wave_force_coeffs(struct swell_wave *w, q30_t e_eff, q30_t q);

void swell_wave_vel_ref(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any);
void swell_wave_vel_fused(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any);

#if SWELL_WAVE_DSP
/* Row j, the first or the last, whole (no tile of it asleep), damped with F = 0, in a grid 64 cells
 * wide, in assembly: the same bits, flags, sums and saturations as swell_wave_vel_fused's run of the
 * row. 0 (nothing done) where it does not apply. */
int swell_wave_vel_row_m4(struct swell_wave *w, int j, uint8_t *trow);
/* Rows [j0, j1) of one band (its flags trow), damped with F = 0, in a grid 64 or 128 cells wide,
 * none of them a wall's row, and done_row = j0 - 1: every tile computed (a sleeping tile's new u are
 * 0: it has not moved for two steps and nothing around it changed, so its stencil reads what gave 0
 * before; it is not counted as skipped), the same bits, flags, sums and saturations as
 * swell_wave_vel_fused's runs, and the heights one row behind (update_rows' bits and counts): rows
 * [j0 - 1, j1 - 1) become h(n+1), done_row j1 - 1. 0 (nothing done) where it does not apply. */
int swell_wave_vel_band_m4(struct swell_wave *w, int j0, int j1, uint8_t *trow);
#endif

/* x86-64 with AVX2 (wave.c checks the CPU before it chooses it) */
#if SWELL_WAVE_AVX2
/* Whether the AVX2 kernel takes the field: C = e_eff 2^(F+1) must fit int32 (not at e_eff = 1, F = 0;
 * the fused kernel does those), and damped water has F = 0 (wave.c). */
static inline int swell_wave_vel_avx2_fits(const struct swell_wave *w, int damp)
{
	return ((int64_t)w->e_eff << (w->vel_frac + 1)) <= INT32_MAX && !(damp && w->vel_frac);
}
/* Rows [j0, j1) of one band of tiles (its flags trow, its sleeping tiles decided), whole, the
 * driver's bookkeeping included: the same bits, flags and counts as step_row_vel (wave.c) calling
 * swell_wave_vel_ref for each run of awake tiles, the sums added to w->vel_sum and w->vel_sum_h. The
 * heights one row behind too (update_rows, the same bits and counts): rows [done_row, j1 - 1) become
 * h(n+1) in the same pass, done_row (j0 - 1, or 0 at j0 = 0, on entry) becomes j1 - 1. */
void swell_wave_vel_rows_avx2(struct swell_wave *w, int j0, int j1, uint8_t *trow, int damp);
/* The heights' update of rows [j0, j1) on its own (wave.c's update_rows: where the kernel above does
 * not run), the same bits and counts: h += dh(u),
 * clamped to int27 (a row that clamped counted once), in the tiles with T_NONZERO. */
void swell_wave_vel_update_avx2(struct swell_wave *w, int j0, int j1);
#endif

#endif
