/* Fixed-point solver of eq. (1): the driver of the kernels (one a file, wave_vel_*.c), the finish
 * with its fixers, and the read functions; see wave.h for the maths and the rounding. */
#include "swell/wave.h"

#include <string.h>

#include "swell/crc.h"
#include "wave_priv.h"

/* 1 if any tile of a row of tiles has the flag, or if all have it (the flags are in wave_priv.h) */
static int tile_row_has(const struct swell_wave *w, const uint8_t *trow, uint8_t flag)
{
	return swell_tiles_row_any(trow, w->tiles_x, flag, 0);
}

#if SWELL_WAVE_DSP
static int tile_row_all(const struct swell_wave *w, const uint8_t *trow, uint8_t flag)
{
	return !swell_tiles_row_any(trow, w->tiles_x, flag, 1);
}

/* How many tiles of a row of tiles sleep */
static int tiles_asleep(const struct swell_wave *w, const uint8_t *trow)
{
	int x, n = 0;

	for (x = 0; x < w->tiles_x; x++)
		n += (trow[x] & T_SLEEPING) != 0;
	return n;
}
#endif

/* Every tile awake. In the middle of a step the flags lost include NONZERO of the rows done: the step
 * counts as non-zero everywhere, or a tile whose momentum just went to zero would sleep a step early
 * (ZERO needs two zero steps). */
static void wake_all(struct swell_wave *w)
{
	w->band_asleep = 0;
	memset(w->tile, w->next_row ? T_NONZERO : 0u, (size_t)w->tiles_x * w->tiles_y);
}

static int e_eff_stable(uint64_t e_eff, uint64_t q)
{
	/* e_eff < (1+q)/(4q) with both in Q1.30:  4 e_eff q < (2^30 + q) 2^30, exact in uint64. */
	return 4u * e_eff * q < (((uint64_t)1 << 30) + q) << 30;
}

/* 1 - t as it runs: odd when t > 0 (see wave.h) */
static uint64_t run_q(q30_t damping)
{
	const uint64_t q = (uint64_t)(SWELL_Q30_ONE - damping);

	return damping ? q | 1u : q;
}

static q30_t effective_e(const struct swell_wave_params *p)
{
	int32_t e = p->stencil == SWELL_STENCIL_CALIBRATED ? p->e / 2 : p->e;

	return e & ~(int32_t)1;
}

enum swell_err swell_wave_check(const struct swell_wave_params *p)
{
	q30_t e_eff;

	if (!p)
		return SWELL_EINVAL;
	if (p->stencil != SWELL_STENCIL_PAPER && p->stencil != SWELL_STENCIL_CALIBRATED)
		return SWELL_EINVAL;
	if (p->damping < 0 || p->damping >= SWELL_Q30_ONE)
		return SWELL_ERANGE;
	e_eff = effective_e(p);
	if (p->e <= 0 || e_eff <= 0 || e_eff > SWELL_Q30_ONE)
		return SWELL_ERANGE;
	if (!e_eff_stable((uint64_t)e_eff, run_q(p->damping)))
		return SWELL_EUNSTABLE;
	return SWELL_OK;
}

q30_t swell_wave_e_limit(q30_t damping, enum swell_stencil stencil)
{
	uint64_t q, lim;

	if (damping < 0 || damping >= SWELL_Q30_ONE)
		return 0;
	q = run_q(damping);
	/* smallest e_eff that is unstable: ceil((2^30 + q) 2^30 / (4 q)), made even (e_eff is even, so an
	 * odd one is never run); then the smallest e whose e_eff reaches it */
	lim = (((((uint64_t)1 << 30) + q) << 30) + 4 * q - 1) / (4 * q);
	lim = (lim + 1) & ~(uint64_t)1;
	if (stencil == SWELL_STENCIL_CALIBRATED)
		lim *= 2;
	return lim > INT32_MAX ? INT32_MAX : (q30_t)lim;
}

/* The fraction bits of u: undamped, as many (up to 4) as keep e_eff 2^(F+1) within int32;
 * damped, none. u is rescaled when they change (toward zero: the fixer gives back what that loses). */
static void set_vel_frac(struct swell_wave *w)
{
	const size_t n = (size_t)w->nx * w->ny;
	int f = 4, old = w->vel_frac;
	size_t a;

	while (f > 0 && ((int64_t)w->e_eff << (f + 1)) > INT32_MAX)
		f--;
	if (w->q != SWELL_Q30_ONE) /* damped: whole LSB, or fine momentum keeps single cells cycling */
		f = 0;
	w->vel_frac = (uint8_t)f;
	if (!w->u || f == old)
		return;
	for (a = 0; a < n; a++)
		w->u[a] = f > old ? swell_clamp((int32_t)swell_sat_i64((int64_t)w->u[a] * (1 << (f - old))),
						SWELL_H_MIN, SWELL_H_MAX)
				  : w->u[a] / (1 << (old - f));
}

void swell_wave_force_coeffs(struct swell_wave *w, q30_t e_eff, q30_t q)
{
	w->e_eff = e_eff;
	w->q = q;
	set_vel_frac(w);
	wake_all(w); /* new coefficients round differently: every tile awake */
}

static void apply_params(struct swell_wave *w, const struct swell_wave_params *p)
{
	w->p = *p;
	swell_wave_force_coeffs(w, effective_e(p), (q30_t)run_q(p->damping)); /* q odd: see wave.h */
}

/* The layout: h, u (unless given apart), the flags. */
static enum swell_err init_at(struct swell_wave *w, uint16_t nx, uint16_t ny, int32_t *storage, size_t words,
			      int32_t *u, const struct swell_wave_params *p)
{
	size_t n = (size_t)nx * ny;
	enum swell_err err;

	err = swell_wave_init_check(w, storage, nx, ny, p);
	if (err != SWELL_OK)
		return err;
	if (words < SWELL_WAVE_WORDS(nx, ny) - (u ? n : 0))
		return SWELL_ESIZE;

	memset(w, 0, sizeof(*w));
	w->nx = nx;
	w->ny = ny;
	w->tiles_x = (uint16_t)SWELL_WAVE_TILES_X(nx);
	w->tiles_y = (uint16_t)SWELL_WAVE_TILES_X(ny);
	w->h = storage;
	w->u = u ? u : storage + n;
	w->tile = (uint8_t *)(u ? storage + n : w->u + n);
	if (u)
		memset(u, 0, n * sizeof(*u));
	w->sleep = 1;
	swell_wave_set_kernel(w, SWELL_KERNEL_AUTO);
	memset(storage, 0, (size_t)((w->tile - (uint8_t *)storage) + w->tiles_x * w->tiles_y));
	apply_params(w, p);
	return SWELL_OK;
}

enum swell_err swell_wave_init(struct swell_wave *w, uint16_t nx, uint16_t ny, int32_t *storage, size_t words,
			       const struct swell_wave_params *p)
{
	return init_at(w, nx, ny, storage, words, NULL, p);
}

enum swell_err swell_wave_init_vel_apart(struct swell_wave *w, uint16_t nx, uint16_t ny, int32_t *storage, size_t words,
					 int32_t *u, size_t u_words, const struct swell_wave_params *p)
{
	if (!u)
		return SWELL_EINVAL;
	if (u_words < (size_t)nx * ny)
		return SWELL_ESIZE;
	return init_at(w, nx, ny, storage, words, u, p);
}

enum swell_err swell_wave_set_params(struct swell_wave *w, const struct swell_wave_params *p)
{
	enum swell_err err;

	if (!w)
		return SWELL_EINVAL;
	err = swell_wave_check(p);
	if (err != SWELL_OK)
		return err;
	apply_params(w, p);
	return SWELL_OK;
}

void swell_wave_rest(struct swell_wave *w)
{
	size_t n = (size_t)w->nx * w->ny, a;

	/* a step in progress starts over: rows finished ahead go back to h(n); a saturated height stays
	 * within the bounds */
	for (a = 0; a < (size_t)w->done_row * w->nx; a++)
		w->h[a] = swell_clamp(w->h[a] - swell_wave_dh(w, a), SWELL_HV_MIN, SWELL_HV_MAX);
	memset(w->u, 0, n * sizeof(*w->u));
	w->next_row = 0;
	w->done_row = 0;
	w->vel_sum = 0;
	w->vel_sum_h = 0;
	wake_all(w);
}

void swell_wave_touched(struct swell_wave *w, int i, int j)
{
	if (i < 0 || j < 0 || i >= w->nx || j >= w->ny)
		return;
	w->band_asleep = 0; /* the rest of this step must not skip the tile's neighbours */
	swell_tiles_touch(w->tile, w->tiles_x, w->tiles_y, i / SWELL_WAVE_TILE, j / SWELL_WAVE_TILE);
}

int swell_wave_tile_changed(const struct swell_wave *w, size_t t)
{
	return (w->tile[t] & T_CHANGED) != 0;
}

void swell_wave_set_sleep(struct swell_wave *w, int on)
{
	w->sleep = on != 0;
	wake_all(w);
}

enum swell_err swell_wave_set_kernel(struct swell_wave *w, enum swell_wave_kernel k)
{
	return w ? swell_kernel_choose(k, &w->kernel) : SWELL_EINVAL;
}

const char *swell_wave_kernel_name(enum swell_wave_kernel k)
{
	switch (k) {
	case SWELL_KERNEL_REF:
		return "ref";
	case SWELL_KERNEL_FUSED:
		return SWELL_WAVE_DSP ? "fused-dsp" : "fused";
	case SWELL_KERNEL_AVX2:
		return "avx2";
	default:
		return NULL;
	}
}

/* Row j: runs of up to SWELL_WAVE_VEL_RUN awake tiles in one kernel call. */
static void step_row_vel(struct swell_wave *w, int j, uint8_t *trow, int damp)
{
	int32_t any[SWELL_WAVE_VEL_RUN];
	int64_t sum[2] = { 0, 0 };
	/* no tile of the row sleeps (the common case in moving water): runs of SWELL_WAVE_VEL_RUN tiles
	 * without looking at each tile's flag */
	const int awake = !w->sleep || !tile_row_has(w, trow, T_SLEEPING);
	int tx = 0, t1, k;

#if SWELL_WAVE_DSP
	if (awake && damp && w->kernel != SWELL_KERNEL_REF && swell_wave_vel_row_m4(w, j, trow))
		return;
#endif
	while (tx < w->tiles_x) {
		if (awake) {
			t1 = w->tiles_x - tx > SWELL_WAVE_VEL_RUN ? tx + SWELL_WAVE_VEL_RUN : w->tiles_x;
		} else if (trow[tx] & T_SLEEPING) {
			w->tiles_skipped++;
			tx++;
			continue;
		} else {
			for (t1 = tx + 1; t1 < w->tiles_x && t1 - tx < SWELL_WAVE_VEL_RUN; t1++)
				if (trow[t1] & T_SLEEPING)
					break;
		}
		if (w->kernel == SWELL_KERNEL_REF)
			swell_wave_vel_ref(w, j, tx, t1, damp, sum, any);
		else /* the fused kernel, and AVX2's where its coefficient does not fit */
			swell_wave_vel_fused(w, j, tx, t1, damp, sum, any);
		for (k = 0; k < t1 - tx; k++)
			if (any[k])
				trow[tx + k] |= T_NONZERO;
		tx = t1;
	}
	w->vel_sum += sum[0];
	w->vel_sum_h += sum[1];
}

/* At the first row of a band of tiles, which of its tiles sleep in this step, and whether all do
 * (band_asleep). */
static inline __attribute__((always_inline)) void band_start(struct swell_wave *w, int j)
{
	if (w->sleep && j % SWELL_WAVE_TILE == 0)
		w->band_asleep = (uint8_t)swell_tiles_band(w->tile, w->tiles_x, w->tiles_y, j / SWELL_WAVE_TILE);
}

/* Row j, skipping sleeping tiles; the rows done: 1, or on the M4 those of the band up to end (the
 * last a step's) in one call */
static inline int step_row(struct swell_wave *w, int j, int end, int damp)
{
	const int ty = j / SWELL_WAVE_TILE;
	uint8_t *trow = &w->tile[ty * w->tiles_x];

	band_start(w, j);
	if (w->sleep && w->band_asleep) { /* the whole band of tiles sleeps: nothing to do in this row */
		w->tiles_skipped += w->tiles_x;
		return 1;
	}
#if SWELL_WAVE_DSP
	/* a band with a quarter of its tiles asleep or fewer: computed whole (a sleeping tile gives 0
	 * again), cheaper than runs between them */
	if (damp && w->kernel != SWELL_KERNEL_REF &&
	    (!w->sleep || !tile_row_has(w, trow, T_SLEEPING) || tiles_asleep(w, trow) * 4 <= w->tiles_x)) {
		int j1 = (ty + 1) * SWELL_WAVE_TILE < end ? (ty + 1) * SWELL_WAVE_TILE : end;

		j1 = j1 < w->ny - 1 ? j1 : w->ny - 1; /* the top wall's row on its own */
		if (j1 > j && swell_wave_vel_band_m4(w, j, j1, trow))
			return j1 - j;
	}
#else
	(void)end;
#endif
	step_row_vel(w, j, trow, damp);
	return 1;
}

#if SWELL_WAVE_DSP
/* n tile rows (8 cells each, n >= 1) of the height update, h = SSAT27(h + dh(u))
 * (SSAT sets the Q flag, which the caller reads): four cells an LDM of u, an LDM of h, the four sums
 * and an STM of h (Cortex-M4 TRM: 1 + N cycles each). At F = 0, dh = u: ADD and SSAT, about 3
 * instructions a cell with the loop; with F fraction bits dh = (u - (u < 0) + 2^(F-1)) >> F (nearest,
 * ties away from zero): SUB of u's sign bit, ADD of the half, ADD with ASR #F, SSAT, about 5.
 * Functions of their own (one for each shift, an immediate): inlined, their nine scratch registers
 * leave too few for the operands. */
#define ADD_CELL0(H, U) "add " H ", " H ", " U "\n\tssat " H ", #27, " H "\n\t"
#define ADD_CELLF(H, U, F, HALF)                                                                              \
	"sub " U ", " U ", " U ", lsr #31\n\tadd " U ", " U ", #" HALF "\n\tadd " H ", " H ", " U ", asr #" F \
	"\n\tssat " H ", #27, " H "\n\t"
#define ADD_FOUR(C0, C1, C2, C3)                                                        \
	"ldmia %[u]!, {r2, r3, r4, r5}\n\tldmia %[h], {r6, r7, r8, r9}\n\t" C0 C1 C2 C3 \
	"stmia %[h]!, {r6, r7, r8, r9}\n\t"
#define ADD_TILES(NAME, C0, C1, C2, C3)                                                             \
	static __attribute__((noinline)) void NAME(int32_t *h, const int32_t *u, int n)             \
	{                                                                                           \
		__asm__ volatile("1:\t" ADD_FOUR(C0, C1, C2, C3)                                    \
					 ADD_FOUR(C0, C1, C2, C3) "subs %[n], %[n], #1\n\tbne 1b"   \
				 : [h] "+r"(h), [u] "+r"(u), [n] "+r"(n)                            \
				 :                                                                  \
				 : "r2", "r3", "r4", "r5", "r6", "r7", "r8", "r9", "cc", "memory"); \
	}
#define ADD_TILES_F(NAME, F, HALF)                                                      \
	ADD_TILES(NAME, ADD_CELLF("r6", "r2", F, HALF), ADD_CELLF("r7", "r3", F, HALF), \
		  ADD_CELLF("r8", "r4", F, HALF), ADD_CELLF("r9", "r5", F, HALF))
ADD_TILES(add_tiles_u, ADD_CELL0("r6", "r2"), ADD_CELL0("r7", "r3"), ADD_CELL0("r8", "r4"), ADD_CELL0("r9", "r5"))
ADD_TILES_F(add_tiles_u1, "1", "1")
ADD_TILES_F(add_tiles_u2, "2", "2")
ADD_TILES_F(add_tiles_u3, "3", "4")
ADD_TILES_F(add_tiles_u4, "4", "8")

/* add_tiles_u with u's fraction bits f (0 to 4) */
static void add_tiles_uf(int32_t *h, const int32_t *u, int n, int f)
{
	static void (*const fn[5])(int32_t *, const int32_t *, int) = { add_tiles_u, add_tiles_u1, add_tiles_u2,
									add_tiles_u3, add_tiles_u4 };

	fn[f](h, u, n);
}
#endif

/* h = clamp27(h + dh(u)) over cells [0, len) of a row; 1 if a height clamped. With len a constant 8
 * the compiler unrolls it. */
static inline __attribute__((always_inline)) uint32_t update_seg(int32_t *restrict h, const int32_t *restrict u,
								 int len, int f)
{
	const int32_t half = f ? (int32_t)1 << (f - 1) : 0;
	uint32_t sat = 0;
	int a;

#pragma GCC unroll 8
	for (a = 0; a < len; a++) { /* |h| <= 2^26, |dh| <= 2^27: no overflow */
		const int32_t d = f ? (u[a] + half - (u[a] < 0)) >> f : u[a], x = h[a] + d;
		const int32_t c = x > SWELL_HV_MAX ? SWELL_HV_MAX : x < SWELL_HV_MIN ? SWELL_HV_MIN : x;

		sat |= c != x;
		h[a] = c;
	}
	return sat;
}

/* Row j becomes h(n+1) = h(n) + dh(u(n+1)), saturated (a row that clamped counted
 * once), in the tiles whose momentum moved in this step (T_NONZERO: elsewhere every new u of the step
 * is zero, so is dh). */
static void update_row(struct swell_wave *w, int j)
{
	const int nx = w->nx, f = w->vel_frac;
	const uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;
	int32_t *h = w->h + (size_t)j * nx;
	const int32_t *u = w->u + (size_t)j * nx;
	uint32_t sat = 0;
	int tx;

#if SWELL_WAVE_DSP
	swell_q_clear();
#endif
	for (tx = 0; tx < w->tiles_x; tx++) {
		const int i0 = tx * SWELL_WAVE_TILE;

		if (!(trow[tx] & T_NONZERO))
			continue;
		if (i0 + SWELL_WAVE_TILE > nx) { /* the row's last tile, narrower */
			sat |= update_seg(h + i0, u + i0, nx - i0, f);
			continue;
		}
#if SWELL_WAVE_DSP
		{ /* the run of whole tiles that moved, in one go */
			int t1 = tx + 1;

			while (t1 < w->tiles_x && (trow[t1] & T_NONZERO) && (t1 + 1) * SWELL_WAVE_TILE <= nx)
				t1++;
			add_tiles_uf(h + i0, u + i0, t1 - tx, f);
			tx = t1 - 1;
			continue;
		}
#endif
		sat |= f ? update_seg(h + i0, u + i0, SWELL_WAVE_TILE, f)
			 : update_seg(h + i0, u + i0, SWELL_WAVE_TILE, 0);
	}
#if SWELL_WAVE_DSP
	sat |= swell_q_take();
#endif
	w->saturations += sat;
}

/* The heights one row behind: rows [done_row, j1) become h(n+1) (every row that reads
 * their h(n) is done); a band of tiles none of which moved is skipped whole. */
static void update_rows(struct swell_wave *w, int j1)
{
	int j;

#if SWELL_WAVE_AVX2
	if (w->kernel == SWELL_KERNEL_AVX2 && j1 > w->done_row) {
		swell_wave_vel_update_avx2(w, w->done_row, j1);
		w->done_row = (uint16_t)j1;
		return;
	}
#endif
	for (j = w->done_row; j < j1; j++) {
		const uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;

		if (!tile_row_has(w, trow, T_NONZERO)) {
			j = (j / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE - 1; /* nothing moved in this band yet */
			continue;
		}
#if SWELL_WAVE_DSP
		if (w->nx % SWELL_WAVE_TILE == 0 && tile_row_all(w, trow, T_NONZERO)) {
			/* the whole band moved (moving water): its rows each in one go, a row that clamped
			 * counted once */
			const int end = (j / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE < j1
				? (j / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE
				: j1;

			for (; j < end; j++) {
				swell_q_clear();
				add_tiles_uf(w->h + (size_t)j * w->nx, w->u + (size_t)j * w->nx, w->tiles_x,
					     w->vel_frac);
				w->saturations += swell_q_take();
			}
			j--;
			continue;
		}
#endif
		update_row(w, j);
	}
	if (j1 > w->done_row)
		w->done_row = (uint16_t)j1;
}

int swell_wave_step_rows(struct swell_wave *w, int rows)
{
	const int damp = w->q != SWELL_Q30_ONE; /* t = 0: no damping multiply at all */
	int j, n, end = w->next_row + (rows > 0 ? rows : 0);

	if (end > w->ny)
		end = w->ny;
#if SWELL_WAVE_AVX2
	if (w->kernel == SWELL_KERNEL_AVX2 && swell_wave_vel_avx2_fits(w, damp)) {
		int j1;

		for (j = w->next_row; j < end; j = j1) { /* the rows of a band in one call */
			uint8_t *trow = &w->tile[j / SWELL_WAVE_TILE * w->tiles_x];

			j1 = (j / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE;
			j1 = j1 < end ? j1 : end;
			band_start(w, j);
			if (w->sleep && w->band_asleep) { /* the whole band of tiles sleeps */
				w->tiles_skipped += (uint32_t)(w->tiles_x * (j1 - j));
				update_rows(w, j1 - 1); /* one row behind */
			} else { /* the heights one row behind in the kernel's pass, from row j - 1 */
				update_rows(w, j - 1);
				swell_wave_vel_rows_avx2(w, j, j1, trow, damp);
			}
		}
		w->next_row = (uint16_t)end;
		return w->ny - end;
	}
#endif
	for (j = w->next_row; j < end; j += n) {
		n = damp ? step_row(w, j, end, 1) : step_row(w, j, end, 0);
		if (j + n - 1 > w->done_row) /* row j + n - 2's last reader is done */
			update_rows(w, j + n - 1);
	}
	w->next_row = (uint16_t)end;
	return w->ny - end;
}

/* d (one LSB, or a whole share) of a fixer into the n cells from a, all in one tile of one row: into
 * u (mom), or into h (every row holds h(n+1) by then). A tight loop a run: the give-back can reach
 * thousands of cells a step. */
static void fix_run(struct swell_wave *w, size_t a, int n, int32_t d, int mom, uint8_t *t)
{
	int32_t *restrict p = mom ? w->u + a : w->h + a;
	const int32_t lo = mom ? SWELL_H_MIN : SWELL_HV_MIN, hi = mom ? SWELL_H_MAX : SWELL_HV_MAX;
	uint32_t sat = 0;
	int k;

	for (k = 0; k < n; k++) {
		const int32_t x = p[k] + d, c = swell_clamp(x, lo, hi);

		sat += c != x;
		p[k] = c;
	}
	w->saturations += sat;
	*t |= mom ? T_NONZERO : T_NONZERO | T_TOUCHED;
}

/* Cells a fixer touches a step at most: a residual larger than this goes back in equal chunks, so the
 * step's end costs the same however far the rounding drifted (damped water rounds toward zero: with
 * an object resting in the pool the residual reaches thousands of LSB a step). */
#define FIX_CELLS_MAX 64u

/* Give back a residual r in whole LSBs, into u (mom) or the heights, to the cells of tiles whose
 * momentum moved in this step (the same tiles whether tiles sleep or not), from the rotating cursor:
 * q = ceil(|r| / FIX_CELLS_MAX) LSB a cell (one LSB while |r| <= FIX_CELLS_MAX), the last cell what
 * is left; the walk wraps around when fewer cells moved. */
static void give_back(struct swell_wave *w, int64_t r, int mom)
{
	const size_t n = (size_t)w->nx * w->ny;
	uint64_t left = (uint64_t)(r > 0 ? r : -r), q;
	size_t a, tn;
	int i, j, run;
	int32_t d;

	if (!r || !w->nx || !w->ny) /* sides are at least 2: the second test is for the analyser */
		return;
	w->fixed_lsb += left;
	/* a residual from a rescale of u, with nothing moving: tile 0 takes it */
	if (!swell_tiles_row_any(w->tile, w->tiles_x * w->tiles_y, T_NONZERO, 0))
		w->tile[0] |= T_NONZERO;
	q = (left + FIX_CELLS_MAX - 1) / FIX_CELLS_MAX;
	/* |r| is under 2^4 LSB a cell (rounding, or a rescale of u) and cells are under 2^24: q < 2^20 */
	d = (int32_t)(r > 0 ? -(int64_t)q : (int64_t)q);
	/* the cursor walk: cells carried by column and row, a tile that did not move skipped whole */
	a = w->fix_cursor < n ? w->fix_cursor : 0;
	i = (int)(a % w->nx);
	j = (int)(a / w->nx);
	while (left) {
		if (i == 0 && !tile_row_has(w, w->tile + (size_t)(j / SWELL_WAVE_TILE) * w->tiles_x, T_NONZERO)) {
			/* a band of tiles none of which moved: its rows are skipped whole (the same order) */
			j = (j / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE;
			j = j < w->ny ? j : 0;
			continue;
		}
		tn = (size_t)(j / SWELL_WAVE_TILE) * w->tiles_x + (size_t)(i / SWELL_WAVE_TILE);
		if (w->tile[tn] & T_NONZERO) {
			const int end = (i / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE;

			run = (end < w->nx ? end : w->nx) - i;
			if ((uint64_t)run * q > left) { /* the last cells: whole chunks, then the rest in one */
				run = (int)(left / q);
				if (!run) {
					d = r > 0 ? -(int32_t)left : (int32_t)left;
					run = 1;
					q = left;
				}
			}
			fix_run(w, (size_t)j * w->nx + (size_t)i, run, d, mom, &w->tile[tn]);
			left -= (uint64_t)run * q;
			i += run;
		} else {
			i = (i / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE;
		}
		if (i >= w->nx) {
			i = 0;
			j = j + 1 < w->ny ? j + 1 : 0;
		}
	}
	w->fix_cursor = (uint32_t)((size_t)j * w->nx + (size_t)i);
}

/* The fixers: sum u(n+1) = 0 (momentum, in u's LSB) and the heights' changes sum
 * to the water added from outside (volume, in height LSB). */
static void vel_fix(struct swell_wave *w)
{
	const int64_t r = w->vel_sum, rh = w->vel_sum_h;

	w->vel_sum = 0;
	w->vel_sum_h = 0;
	give_back(w, r, 1);
	give_back(w, rh, 0);
}

/* A finished step's tile flags in each byte of x as the last finished step's: Z1 where the step left
 * no non-zero momentum (not NONZERO), ZERO where that is the second step running (Z1 already),
 * CHANGED from TOUCHED or NONZERO (its heights changed only where its momentum moved or something
 * wrote them), every other flag cleared. Each flag is one bit moved within its byte (a shift, then a
 * mask of that bit in every byte), so a word does four tiles at once. */
_Static_assert(T_ZERO == 1u && T_NONZERO == 2u && T_Z1 == 16u && T_CHANGED == T_TOUCHED >> 1 &&
		       T_TOUCHED == T_NONZERO << 2,
	       "step_flags4 moves these bits");
static inline uint32_t step_flags4(uint32_t x)
{
	const uint32_t ones = 0x01010101u;
	const uint32_t z1 = ((x >> 1) & ones) ^ ones; /* NONZERO (bit 1) clear, at bit 0 */

	x |= (x & ones * T_NONZERO) << 2; /* NONZERO counts as TOUCHED */
	return z1 * T_Z1 | (z1 & (x >> 4)) * T_ZERO | ((x >> 1) & ones * T_CHANGED);
}

void swell_wave_step_finish(struct swell_wave *w)
{
	uint8_t *const t = w->tile;
	const int n = (int)w->tiles_x * w->tiles_y;
	int a;

	/* every row, the last row's heights, then the fixers */
	swell_wave_step_rows(w, w->ny);
	update_rows(w, w->ny);
	vel_fix(w);
	/* the step is done: its flags become the last finished step's, four tiles a word */
	for (a = 0; a + 4 <= n; a += 4) {
		uint32_t x;

		memcpy(&x, t + a, sizeof(x));
		x = step_flags4(x);
		memcpy(t + a, &x, sizeof(x));
	}
	for (; a < n; a++)
		t[a] = (uint8_t)step_flags4(t[a]);
	w->next_row = 0;
	w->done_row = 0;
	w->steps++;
}

void swell_wave_step(struct swell_wave *w)
{
	swell_wave_step_finish(w);
}

/* Water added to the cells [i0, i1) of row j, one tile, goes into h at once
 * (saturating, counted); the tile is TOUCHED and it and its neighbours awake for the rest of the step
 * where a height changed. */
static void add_vel(struct swell_wave *w, int i0, int i1, int j, int32_t dh)
{
	int32_t *restrict h = w->h + (size_t)j * w->nx;
	const int32_t lo = SWELL_HV_MIN, hi = SWELL_HV_MAX;
	uint32_t sat = 0;
	int32_t moved = 0;
	int i;

	/* beyond twice the height bound every sum clamps the same: then h + dh fits int32 */
	dh = swell_clamp(dh, 2 * lo, 2 * hi);
	for (i = i0; i < i1; i++) {
		const int32_t x = h[i] + dh, c = x > hi ? hi : x < lo ? lo : x;

		sat += c != x;
		moved |= c ^ h[i];
		h[i] = c;
	}
	w->saturations += sat;
	/* a tile TOUCHED already woke its neighbours for this step (and asleep() keeps them awake) */
	if (moved && !(w->tile[(j / SWELL_WAVE_TILE) * w->tiles_x + i0 / SWELL_WAVE_TILE] & T_TOUCHED))
		swell_wave_touched(w, i0, j);
}

void swell_wave_add(struct swell_wave *w, int i, int j, int32_t dh)
{
	if (i >= 0 && j >= 0 && i < w->nx && j < w->ny)
		add_vel(w, i, i + 1, j, dh);
}

void swell_wave_add_span(struct swell_wave *w, int i0, int i1, int j, int32_t dh)
{
	if (j < 0 || j >= w->ny || dh == 0)
		return;
	i0 = i0 > 0 ? i0 : 0;
	i1 = i1 < w->nx ? i1 : w->nx;
	while (i0 < i1) { /* tile by tile */
		const int end = (i0 / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE;

		add_vel(w, i0, end < i1 ? end : i1, j, dh);
		i0 = end;
	}
}

/* ---- Reading h(n): rows below done_row hold h(n+1), h(n) = h - dh(u) there (wave.h) */

void swell_wave_row(const struct swell_wave *w, int j, int32_t *out)
{
	const size_t a0 = (size_t)j * w->nx;
	int i;

	if (j >= w->done_row) {
		memcpy(out, w->h + a0, (size_t)w->nx * sizeof(*out));
		return;
	}
	for (i = 0; i < w->nx; i++)
		out[i] = w->h[a0 + i] - swell_wave_dh(w, a0 + i);
}

#if defined(__thumb2__)
/* The cell of register R (a value of d, the next of h in H): d's negative part (shifted right by the
 * velocity form's fraction bits: S is "" or ", asr #F") taken from h, the result compared with the
 * highest so far (a higher one, rare once the scan is under way, goes to label 1N and back to 2N), h
 * added to the group's sum. */
#define SCAN_CELL(R, H, N, S)                                               \
	"and " R ", " R ", " R ", asr #31\n\tsub " R ", " H ", " R S "\n\t" \
	"add %[part], %[part], " H "\n\tcmp " R ", %[t]\n\tbgt 1" N "f\n2" N ":\n\t"
#define SCAN_UP(R, N) "1" N ":\tmov %[t], " R "\n\tb 2" N "b\n"
/* four cells: four d in one LDM, their h two at a time */
#define SCAN_FOUR(N0, N1, N2, N3, S)                                                                  \
	"ldmia %[d]!, {r2, r3, r4, r5}\n\tldmia %[h]!, {r6, r7}\n\t" SCAN_CELL("r2", "r6", N0, S)     \
		SCAN_CELL("r3", "r7", N1, S) "ldmia %[h]!, {r6, r7}\n\t" SCAN_CELL("r4", "r6", N2, S) \
			SCAN_CELL("r5", "r7", N3, S)
/* the group's sum into the 64-bit sum, the next group; the out-of-line updates of the highest value */
#define SCAN_END \
	"adds %[lo], %[lo], %[part]\n\tadc %[hi], %[hi], %[part], asr #31\n\tsubs %[g], %[g], #1\n\tbne 3b\n\tb 9f\n"
#define SCAN_UPS(N0, N1, N2, N3) SCAN_UP("r2", N0) SCAN_UP("r3", N1) SCAN_UP("r4", N2) SCAN_UP("r5", N3)
#define SCAN_GROUP(S) "3:\tmovs %[part], #0\n\t" SCAN_FOUR("0", "1", "2", "3", S) SCAN_FOUR("4", "5", "6", "7", S)

/* swell_wave_ceiling's cells in groups of eight (g >= 1 groups): the same top and sum. Four d in one LDM, two h
 * in another, then the cell: AND (min(d, 0) from d's sign), SUB (with the shift of the fraction bits),
 * ADD to the sum, CMP and a branch not taken: about 6.4 instructions a cell with the loads and the
 * loop, against about 13 for the compiler's loop. The group's sum (eight int28 heights, exact in
 * int32) goes into the 64-bit sum with ADDS and ADC. Functions of their own, one for each shift (an
 * immediate): six scratch registers for the loads. */
#define SCAN_GROUPS8(NAME, S)                                                                                        \
	static __attribute__((noinline)) void NAME(const int32_t *h, const int32_t *d, int g, int32_t *top,          \
						   int64_t *sum)                                                     \
	{                                                                                                            \
		uint32_t lo = (uint32_t)*sum;                                                                        \
		int32_t hi = (int32_t)(*sum >> 32), t = *top, part;                                                  \
                                                                                                                     \
		__asm__ volatile(SCAN_GROUP(S) SCAN_END SCAN_UPS("0", "1", "2", "3")                                 \
					 SCAN_UPS("4", "5", "6", "7") "9:\n"                                         \
				 : [h] "+r"(h), [d] "+r"(d), [g] "+r"(g), [t] "+r"(t), [lo] "+r"(lo), [hi] "+r"(hi), \
				   [part] "=&r"(part)                                                                \
				 :                                                                                   \
				 : "r2", "r3", "r4", "r5", "r6", "r7", "cc", "memory");                              \
		*top = t;                                                                                            \
		*sum = (int64_t)((uint64_t)(uint32_t)hi << 32 | lo);                                                 \
	}
SCAN_GROUPS8(scan_groups8, "")
SCAN_GROUPS8(scan_groups8_f1, ", asr #1")
SCAN_GROUPS8(scan_groups8_f2, ", asr #2")
SCAN_GROUPS8(scan_groups8_f3, ", asr #3")
SCAN_GROUPS8(scan_groups8_f4, ", asr #4")

/* scan_groups8 with d's negative part shifted right by f (0 to 4) */
static void scan_groups8_shift(const int32_t *h, const int32_t *d, int g, int f, int32_t *top, int64_t *sum)
{
	static void (*const fn[5])(const int32_t *, const int32_t *, int, int32_t *,
				   int64_t *) = { scan_groups8, scan_groups8_f1, scan_groups8_f2, scan_groups8_f3,
						  scan_groups8_f4 };

	fn[f](h, d, g, top, sum);
}
#endif

/* Heights are int27: eight of them sum exactly in int32 (wave.h has the rule). */
void swell_wave_ceiling(const struct swell_wave *w, int j0, int j1, int32_t *top, int64_t *sum)
{
	const int32_t *h = w->h + (size_t)j0 * w->nx, *d = w->u + (size_t)j0 * w->nx;
	const int n = (j1 - j0) * w->nx;
	const int f = w->vel_frac;
	int32_t t = *top;
	int64_t s = *sum;
	int a = 0;

#if defined(__thumb2__)
	if (n >= 8) {
		scan_groups8_shift(h, d, n / 8, f, &t, &s);
		a = n / 8 * 8;
	}
#endif
	while (a < n) {
		const int end = a + 8 < n ? a + 8 : n;
		int32_t part = 0;

		for (; a < end; a++) {
			/* the higher of h and h - d is h - min(d, 0): one comparison a cell */
			const int32_t x = h[a], p = x - ((d[a] < 0 ? d[a] : 0) >> f);

			t = p > t ? p : t;
			part += x;
		}
		s += part;
	}
	*top = t;
	*sum = s;
}

int64_t swell_wave_volume(const struct swell_wave *w)
{
	const size_t n = (size_t)w->nx * w->ny;
	int64_t sum = 0;
	size_t a;

	for (a = 0; a < n; a++)
		sum += swell_wave_h(w, a);
	return sum;
}

/* The energy sums saturate at the int64 range instead of wrapping: a field of waves many times
 * the depth (heights past about 128 mm on a 256 x 256 pool) would take a sum of squares beyond it.
 * Inside the range the sums are exact, as before. */
static int64_t sat_mul64(int64_t a, int64_t b)
{
	int64_t r;

	if (__builtin_mul_overflow(a, b, &r))
		return (a < 0) != (b < 0) ? INT64_MIN : INT64_MAX;
	return r;
}

static void sat_acc64(int64_t *sum, int64_t x)
{
	if (__builtin_add_overflow(*sum, x, sum))
		*sum = x < 0 ? INT64_MIN : INT64_MAX;
}

/* 2 w (h_b - h_a)(n) (h_b - h_a)(n-1) for one edge; h(n-1) = h - change. */
static int64_t edge_pot2(const int32_t *h, int32_t (*change)(const void *, int), const void *ctx, int a, int b,
			 int64_t two_w)
{
	const int64_t d_now = (int64_t)h[b] - h[a];

	return sat_mul64(two_w, sat_mul64(d_now, d_now - ((int64_t)change(ctx, b) - change(ctx, a))));
}

struct swell_energy swell_energy_of(const int32_t *h, int nx, int ny, q30_t e_eff,
				    int32_t (*change)(const void *ctx, int a), const void *ctx)
{
	struct swell_energy en = { 0, 0, e_eff };
	int i, j, a;

	for (j = 0; j < ny; j++) {
		for (i = 0; i < nx; i++) {
			a = j * nx + i;
			sat_acc64(&en.kin, (int64_t)change(ctx, a) * change(ctx, a)); /* < 2^64: at most 2^62 */
			if (i + 1 < nx)
				sat_acc64(&en.pot2,
					  edge_pot2(h, change, ctx, a, a + 1, (j == 0 || j == ny - 1) ? 3 : 2));
			if (j + 1 >= ny)
				continue;
			sat_acc64(&en.pot2, edge_pot2(h, change, ctx, a, a + nx, (i == 0 || i == nx - 1) ? 3 : 2));
			if (i + 1 < nx)
				sat_acc64(&en.pot2, edge_pot2(h, change, ctx, a, a + nx + 1, 1));
			if (i > 0)
				sat_acc64(&en.pot2, edge_pot2(h, change, ctx, a, a + nx - 1, 1));
		}
	}
	return en;
}

/* The last step's change of cell a: the solver's own change dh(u) (wave.h) */
static int32_t last_change(const void *w, int a)
{
	return swell_wave_dh(w, (size_t)a);
}

struct swell_energy swell_wave_energy(const struct swell_wave *w)
{
	return swell_energy_of(w->h, w->nx, w->ny, w->e_eff, last_change, w);
}

uint32_t swell_wave_checksum(const struct swell_wave *w)
{
	const size_t n = (size_t)w->nx * w->ny;

	return swell_crc32_words(swell_crc32_words(0, w->h, n), w->u, n);
}

enum swell_err swell_wave_e_from_physical(uint32_t g_mm_s2, uint32_t dt_us, uint32_t depth_um, uint32_t dx_um, q30_t *e)
{
	uint64_t x, eq;

	if (!e)
		return SWELL_EINVAL;
	if (!g_mm_s2 || !dt_us || !depth_um || !dx_um)
		return SWELL_ERANGE;
	/* e = g dt^2 d / dx^2 * 1e-9 in these units; first g d dt^2 / dx^2 (in units of 1e-9), then
	 * scaled to Q1.30. Both steps round to nearest: relative error below 1e-8 for e > 0.01. */
	if (!swell_muldiv_u64((uint64_t)g_mm_s2 * depth_um, (uint64_t)dt_us * dt_us, (uint64_t)dx_um * dx_um, &x))
		return SWELL_ERANGE;
	if (!swell_muldiv_u64(x, (uint64_t)1 << 30, 1000000000u, &eq) || eq == 0 || eq > INT32_MAX)
		return SWELL_ERANGE;
	*e = (q30_t)eq;
	return SWELL_OK;
}
