/* The shallow-water height field of the paper's eq. (1) and (2), in fixed point: swell's solver.
 *
 *   h(n) = h(n-1) + (1-t) [ h(n-1) - h(n-2) + e L9(n-1) ]
 *   L9   = -6 h[i,j] + h[i±1,j] + h[i,j±1] + 1/2 (four diagonal neighbours)
 *   e    = g dt^2 d / dx^2
 *
 * Walls reflect: ghost cells mirror the edge cells. The water starts at rest (h(-1) = h(0)).
 *
 * Form. Eq. (1) as a momentum per cell, u(n+1) = (1-t) [u(n) + e L9(n)], h(n+1) = h(n) + u(n+1) +
 * water added from outside, with the separable stencil 2 L9 = ([1 2 1] x [1 2 1]) h - 16 h. Each cell
 * is rounded on its own: undamped, u + e L9 to nearest (ties up); damped, u + e L9 toward e L9 / 2
 * (half the cell's kick) and then the damping toward zero (common/src/wave_priv.h has the exact
 * rule). Nearest rounding with damping leaves small limit cycles of single cells (measured: 2-4
 * LSB/step forever at e 0.35-0.45), and so does rounding toward zero at e 0.45 (a cell at rest kicked
 * past its balance point lands as far on the other side); rounding toward half the kick does not add
 * to the energy the undamped scheme keeps (by less than an LSB^2 a cell where the sum is within half
 * an LSB of that point), and damped water comes to rest (measured: 288 of 288 cases,
 * common/tests/test_wave_rest.cpp). At the step's finish the integer residual r = sum u(n+1) is given
 * back in whole LSBs of u (to cells of tiles that moved, one LSB a cell, from a cursor that rotates
 * over the grid; whole shares first when |r| exceeds their count), so sum u = 0. Undamped, u carries
 * vel_frac fraction bits beyond a height LSB (as many as keep 2^(vel_frac+1) e_eff < 2 in Q1.30 for
 * the M4's SMMLAR, at most 4: 4 for e_eff < 1/16, 2 for the pool's 0.2), which brings the rounding
 * error under an edge-flux form's (tools/bench, ef32); damped, none (with them, single cells keep
 * cycling by 2-3 LSB at e 0.35 and t 0.02). A cell's height change dh(u) is u(n+1) rounded to a
 * height LSB (nearest, ties away from zero; u itself when vel_frac is 0), and the residual of those
 * roundings is given back the same way in whole height LSBs (into h), so the volume sum(h) stays
 * exact. Water added from outside never enters u (it is mass, not momentum).
 *
 * Fixed point. Heights are int32 with 1 LSB = 2^-16 mm (SWELL_H_FRAC), saturated to int27
 * (SWELL_HV_MIN..MAX, +-1024 mm) so that 2 L9 fits int32; u to int28 (SWELL_H_MIN..MAX).
 * Coefficients are Q1.30; 1-t is made odd (t moves by at most 2^-30), so that rounding toward zero
 * is floor + (s < 0), which the Cortex-M4 kernel computes with one SMMUL.
 *
 * Stability (von Neumann, q = 1-t): modes are stable iff e_eff < (1+q) / (4q), where e_eff is e for
 * the paper stencil and e/2 for the calibrated one (L9/2, waves at sqrt(g d)). Parameters outside
 * that limit are refused, never run.
 *
 * Storage is the caller's: SWELL_WAVE_WORDS(nx, ny) int32 words, 8 bytes a cell (h, u and the tile
 * flags). No allocation, no float.
 *
 * Bounded work per call: a step can be split into row slices (swell_wave_step_rows) and a finishing
 * pass (swell_wave_step_finish), so that a controller tick never carries a whole grid step. There is
 * no step accumulator: row j's heights become h(n+1) = h(n) + dh(u(n+1)) (saturated) as soon as row
 * j+1's momentum is done (the last row that reads row j's h(n)), one row behind the kernel, and the
 * last row at the step's finish. So after swell_wave_step_rows has done rows [0, next_row), rows
 * [0, done_row) hold h(n+1), done_row = next_row - 1 (every row after the finish), and h(n) there is
 * h - dh(u). A reader takes h(n) only through the read functions below (swell_wave_h, _row, _quad,
 * _sum), which apply that rule; the fields are the solver's own (wave*.c). The last step's change
 * h(n) - h(n-1) is not kept: swell_wave_dh gives the solver's own change dh(u) instead, which differs
 * from it by the water added from outside and the volume fixer's LSBs (at most one LSB a cell in a
 * step, and only where water moved). Water added from outside (swell_wave_add) goes into h at once:
 * in rows below done_row it is part of h(n+1) and also shows in h - dh(u); elsewhere the rest of the
 * step reads it. Results are bit-identical to the unsplit step.
 *
 * Kernels (swell_wave_set_kernel): SWELL_KERNEL_REF (the definition, one cell at a time in int64),
 * SWELL_KERNEL_FUSED (column sums carried in registers; SMMLAR/SMMUL/SSAT on ARMv7E-M) and
 * SWELL_KERNEL_AVX2 (x86-64 with AVX2: a tile row a vector, and the height update too),
 * bit-identical: same heights, momenta and sleeping tiles.
 *
 * Sleeping tiles (lossless): the grid is cut into 8 x 8 tiles. A tile whose momentum was zero for
 * the last two steps, and none of whose cells nor its neighbour tiles' cells changed since, would
 * give zero momentum again (same heights, same rounding): it is skipped, bit-identically. Anything
 * that writes h from outside must say so with swell_wave_touched() (or swell_wave_rest()), or use
 * swell_wave_add(). */
#ifndef SWELL_WAVE_H
#define SWELL_WAVE_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"
#include "swell/fixed.h"

#define SWELL_H_FRAC 16 /* fractional bits of a height, in mm */
#define SWELL_H_ONE_MM ((int32_t)1 << SWELL_H_FRAC) /* 1 mm in height LSB */
#define SWELL_H_MAX (((int32_t)1 << 27) - 1) /* saturation bounds of the momentum u: int28 */
#define SWELL_H_MIN (-((int32_t)1 << 27))

#define SWELL_HV_MAX (((int32_t)1 << 26) - 1) /* height bounds: int27 */
#define SWELL_HV_MIN (-((int32_t)1 << 26))

#define SWELL_WAVE_MIN_SIDE 2
#define SWELL_WAVE_MAX_SIDE 1024
#define SWELL_WAVE_TILE 8 /* side of a sleeping tile, in cells */
#define SWELL_WAVE_TILES_X(nx) (((size_t)(nx) + SWELL_WAVE_TILE - 1) / SWELL_WAVE_TILE)
#define SWELL_WAVE_TILES(nx, ny) (SWELL_WAVE_TILES_X(nx) * SWELL_WAVE_TILES_X(ny))
/* h and the momentum u (nx ny words each), then the tile flags */
#define SWELL_WAVE_WORDS(nx, ny) (2 * (size_t)(nx) * (size_t)(ny) + (SWELL_WAVE_TILES(nx, ny) + 3) / 4)

enum swell_wave_kernel {
	SWELL_KERNEL_AUTO = 0, /* the fastest this build and CPU have (default) */
	SWELL_KERNEL_REF = 1, /* the scalar reference: one cell at a time, the definition */
	SWELL_KERNEL_FUSED = 2, /* one pass per row segment; M4 DSP instructions on ARMv7E-M */
	SWELL_KERNEL_AVX2 = 3, /* x86-64 with AVX2: 8 cells at a time */
};

enum swell_stencil {
	SWELL_STENCIL_PAPER = 0, /* L9 as printed: waves run sqrt(2) faster than sqrt(g d) */
	SWELL_STENCIL_CALIBRATED = 1, /* L9 / 2: long waves at sqrt(g d) */
};

struct swell_wave_params {
	q30_t e; /* eq. (2), in (0, 2) */
	q30_t damping; /* t, in [0, 1) */
	enum swell_stencil stencil;
};

/* The solver's state. Its fields are the solver's own: read heights through the functions below. */
struct swell_wave {
	uint16_t nx, ny;
	/* Row-major, index j * nx + i (i the column, x; j the row, y). */
	int32_t *h; /* h(n): height above rest, LSB 2^-16 mm; h(n+1) in rows below done_row */
	int32_t *u; /* momentum u(n), LSB 2^-(16 + vel_frac) mm per step; u(n+1) in rows done */
	struct swell_wave_params p;
	q30_t e_eff; /* e (paper) or e/2 (calibrated), made even so that e_eff/2 is exact */
	q30_t q; /* 1 - t, made odd when t > 0 */
	uint32_t steps;
	uint32_t saturations; /* row segments (up to a tile row) in which a height or momentum was clamped */
	uint16_t next_row; /* first row not yet done in the step in progress */
	uint16_t done_row; /* rows [0, done_row) of the step in progress hold h(n+1) */
	uint16_t tiles_x, tiles_y;
	uint8_t *tile; /* flag byte a tile (wave.c) */
	uint8_t sleep; /* 1: skip sleeping tiles (default); 0: every cell every step */
	uint8_t band_asleep; /* every tile of the band of rows in progress sleeps */
	uint32_t tiles_skipped; /* tile-rows skipped, cumulative */
	uint8_t kernel; /* enum swell_wave_kernel in use (never AUTO) */
	int64_t vel_sum; /* sum of u(n+1) over the rows done: the residual the finish gives back */
	int64_t vel_sum_h; /* sum of the rows' height changes (without water added from outside) */
	uint8_t vel_frac; /* fraction bits of u beyond a height LSB: 4, 3, 2, 1 or 0 by e_eff */
	uint32_t fix_cursor; /* next cell the fixer gives an LSB to */
	uint64_t fixed_lsb; /* LSB given back by the fixer, cumulative */
};

/* ---- Reading the heights: h(n), the last finished step's, at any point of a step in progress
 * (rows below done_row hold h(n+1) in h: h(n) = h - dh(u) there). */

/* The solver's own change of cell a, dh(u): u rounded to a height LSB (nearest, ties away from zero;
 * u itself without fraction bits). In rows below done_row that is h(n+1) - h(n) of the step in
 * progress; elsewhere it is h(n) - h(n-1) of the last finished step less the water added from
 * outside and the volume fixer's LSBs. */
static inline int32_t swell_wave_dh(const struct swell_wave *w, size_t a)
{
	const int f = w->vel_frac;
	const int32_t u = w->u[a];

	return f ? (u + ((int32_t)1 << (f - 1)) - (u < 0)) >> f : u;
}

/* h(n) of cell a (inline: the force path reads a few cells a tick) */
static inline int32_t swell_wave_h(const struct swell_wave *w, size_t a)
{
	return a >= (size_t)w->done_row * w->nx ? w->h[a] : w->h[a] - swell_wave_dh(w, a);
}

/* h(n) of row j (nx cells) into out */
void swell_wave_row(const struct swell_wave *w, int j, int32_t *out);

/* h(n) of the four cells a .. a+3 of one row into out (inline: telemetry reads quads in the tick) */
static inline void swell_wave_quad(const struct swell_wave *w, size_t a, int32_t out[4])
{
	const int32_t *h = w->h + a;

	out[0] = h[0];
	out[1] = h[1];
	out[2] = h[2];
	out[3] = h[3];
	if (a < (size_t)w->done_row * w->nx) {
		out[0] -= swell_wave_dh(w, a);
		out[1] -= swell_wave_dh(w, a + 1);
		out[2] -= swell_wave_dh(w, a + 2);
		out[3] -= swell_wave_dh(w, a + 3);
	}
}

/* An area of cells [i0, i1] x [j0, j1] (inclusive) with weights: wx0 and wx1 of its end columns, wy0
 * and wy1 of its end rows, `one` (a whole cell's side) between (one column: wx0; one row: wy0); a
 * cell's weight is its column's times its row's. */
struct swell_wave_area {
	int32_t i0, i1, j0, j1;
	int32_t wx0, wx1, wy0, wy1, one;
};

/* Weighted sums under an area: of h(n) into *sh, and of the solver's change, u / 2^F (the weighted sum
 * of u rounded once to a height LSB), into *sv. In rows finished ahead h(n) is exact at the end cells
 * and, for the cells between, h minus their sum of u shifted once and rounded (within half an LSB a
 * cell of the per-cell dh(u)). Exact in int64 for areas up to 65 x 65 cells with weights up to 2^22.
 * Inline: the force law calls it every tick (two loads and two adds a cell). */
static inline void swell_wave_footprint(const struct swell_wave *w, const struct swell_wave_area *ar, int64_t *sh,
					int64_t *sv)
{
	const int32_t i0 = ar->i0, i1 = ar->i1, ox0 = ar->wx0, ox1 = ar->wx1; /* one cell: the same */
	const int frac = w->vel_frac;
	int64_t su = 0;
	int32_t i, j;

	*sh = 0;

	for (j = ar->j0; j <= ar->j1; j++) {
		const int32_t oy = j == ar->j0 ? ar->wy0 : j == ar->j1 ? ar->wy1 : ar->one;
		const int32_t *h = w->h + (size_t)j * w->nx, *u = w->u + (size_t)j * w->nx;
		int64_t mh = 0, mu = 0, rh, ru;
		int32_t he0 = h[i0], he1 = h[i1];

		for (i = i0 + 1; i < i1; i++) {
			mh += h[i];
			mu += u[i];
		}
		if (j < w->done_row) { /* h holds h(n+1): int27 - int28, no overflow */
			he0 -= swell_wave_dh(w, (size_t)j * w->nx + (size_t)i0);
			he1 -= swell_wave_dh(w, (size_t)j * w->nx + (size_t)i1);
			mh -= frac ? swell_shr_rn(mu, frac) : mu;
		}
		rh = (int64_t)ox0 * he0 + mh * ar->one;
		ru = (int64_t)ox0 * u[i0] + mu * ar->one;
		if (i1 > i0) {
			rh += (int64_t)ox1 * he1;
			ru += (int64_t)ox1 * u[i1];
		}
		*sh += oy * rh;
		su += oy * ru;
	}
	*sv = frac ? swell_shr_rn(su, frac) : su;
}

/* The ceiling of rows [j0, j1): the highest of h and h - floor(u / 2^F) (the solver's change rounded
 * down: never above dh(u), so an upper bound at most one LSB high), that is of the two levels a row
 * holds (h(n+1) and h(n) below done_row, h(n) and about h(n-1) elsewhere), into *top if higher; the
 * sum of h added to *sum. Eight cells an SMLA-free pass on the Cortex-M4. */
void swell_wave_ceiling(const struct swell_wave *w, int j0, int j1, int32_t *top, int64_t *sum);

/* Exact integer energy (docs/design.md, section 2), for tests: with t = 0,
 *     E * 2^31 = kin * 2^31 + e_eff * pot2
 * is conserved exactly in exact arithmetic; kin = sum (h(n) - h(n-1))^2 and
 * pot2 = sum over edges of 2 w (h_b - h_a)(n) (h_b - h_a)(n-1), in LSB^2. Both are exact in int64 while
 * heights stay below 2^23 LSB (128 mm) on grids up to 256 x 256. */
struct swell_energy {
	int64_t kin;
	int64_t pot2;
	q30_t e_eff;
};

/* Validate parameters: SWELL_EINVAL (unknown stencil), SWELL_ERANGE (e <= 0, e_eff > 1,
 * t outside [0, 1)), SWELL_EUNSTABLE (e_eff >= (1+q)/(4q)). */
enum swell_err swell_wave_check(const struct swell_wave_params *p);

/* The exclusive stability limit on e (not e_eff) for damping t and a stencil, in Q1.30: the smallest
 * e that swell_wave_check refuses as unstable (with the even e_eff and odd 1-t that run), saturated
 * to INT32_MAX when it exceeds the Q1.30 range. */
q30_t swell_wave_e_limit(q30_t damping, enum swell_stencil stencil);

/* Bind caller storage (at least SWELL_WAVE_WORDS(nx, ny) words) and set the water flat and at rest.
 * On error *w is untouched. */
enum swell_err swell_wave_init(struct swell_wave *w, uint16_t nx, uint16_t ny, int32_t *storage, size_t words,
			       const struct swell_wave_params *p);

/* The same with the momentum u apart from the rest (a port may put it in another memory): storage
 * holds h and the tile flags (SWELL_WAVE_WORDS(nx, ny) - nx ny words), u nx ny words. The same bits
 * as swell_wave_init; on error *w is untouched. */
enum swell_err swell_wave_init_vel_apart(struct swell_wave *w, uint16_t nx, uint16_t ny, int32_t *storage, size_t words,
					 int32_t *u, size_t u_words, const struct swell_wave_params *p);

/* Change parameters on a running field; on error nothing changes. */
enum swell_err swell_wave_set_params(struct swell_wave *w, const struct swell_wave_params *p);

/* Make the present heights the rest state: u zero (h(n-1) = h(n)). A step in progress is dropped:
 * rows finished ahead go back to h(n). */
void swell_wave_rest(struct swell_wave *w);

/* Advance one solver step. Bounded: one stencil per cell, no data-dependent loops.
 * Same as swell_wave_step_rows(w, ny) followed by swell_wave_step_finish(w). */
void swell_wave_step(struct swell_wave *w);

/* Do the next `rows` rows of the step in progress (at most up to the last row); returns the number
 * of rows still to do. Writes u of those rows and h(n+1) one row behind (done_row = next_row - 1). */
int swell_wave_step_rows(struct swell_wave *w, int rows);

/* Finish the step: every remaining row, the last row's heights, the fixers and the tile flags. */
void swell_wave_step_finish(struct swell_wave *w);

/* Add dh (LSB) to cell (i, j), saturating: the way to move water in from outside (an object's
 * displacement) without disturbing a step in progress. Into h at once (see above); the momentum is
 * unchanged, so the added volume is conserved from then on; the tile wakes (TOUCHED). */
void swell_wave_add(struct swell_wave *w, int i, int j, int32_t dh);

/* swell_wave_add(w, i, j, dh) for i0 <= i < i1 in order (cells outside the grid ignored, nothing
 * for dh 0), with the row's tests made once: the coupling's wholly covered cells. */
void swell_wave_add_span(struct swell_wave *w, int i0, int i1, int j, int32_t dh);

/* 1 when a cell of tile t (row-major, tiles_x a row) may have changed in the last finished step, 0 when
 * none did: h(n) there is h(n-1). Never 0 for a tile that changed (the sleeping tiles rest on it), so a
 * reader that keeps what it last saw of the heights need only look again where this is 1. */
int swell_wave_tile_changed(const struct swell_wave *w, size_t t);

/* Cell (i, j) was written from outside: wake its tile and the neighbours (outside the grid: ignored). */
void swell_wave_touched(struct swell_wave *w, int i, int j);

/* Turn tile sleeping on (default) or off; results are bit-identical either way. */
void swell_wave_set_sleep(struct swell_wave *w, int on);

/* Choose the kernel (results are bit-identical); SWELL_EINVAL if this build or CPU lacks it, and
 * nothing changes. AUTO picks the fastest available. */
enum swell_err swell_wave_set_kernel(struct swell_wave *w, enum swell_wave_kernel k);

/* "ref", "fused", "fused-dsp" (ARMv7E-M), "avx2"; NULL for AUTO or an unknown value. */
const char *swell_wave_kernel_name(enum swell_wave_kernel k);

/* sum of h(n) in LSB: the volume, exact at any point of a step (water added from outside included). */
int64_t swell_wave_volume(const struct swell_wave *w);

struct swell_energy swell_wave_energy(const struct swell_wave *w);

/* CRC-32 of the state: heights, then u, in cell order (int32 little-endian). */
uint32_t swell_wave_checksum(const struct swell_wave *w);

/* e = g dt^2 d / dx^2 from integer physical units, rounded to nearest Q1.30.
 * g in mm/s^2, dt in us, depth and dx in um. SWELL_ERANGE when a value is 0 or e >= 2. */
enum swell_err swell_wave_e_from_physical(uint32_t g_mm_s2, uint32_t dt_us, uint32_t depth_um, uint32_t dx_um,
					  q30_t *e);

#endif
