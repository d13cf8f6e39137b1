/* Fixed-point solver of eq. (1) in edge-flux form; see wave.h for the maths and the rounding. */
#include "swell/wave.h"

#include <string.h>

#include "swell/crc.h"

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

/* The edges of an awake tile write acc in it and in the tiles right of it and above it: mark the
 * block of radius r around (tx, ty) so that the finish visits them (r = 1 for a tile found awake,
 * 2 around a touched tile, whose awake neighbours write around themselves). */
static void mark_dirty(struct swell_wave *w, int tx, int ty, int r)
{
	const int x0 = tx > r ? tx - r : 0, x1 = tx + r < w->tiles_x ? tx + r : w->tiles_x - 1;
	const int y0 = ty > r ? ty - r : 0, y1 = ty + r < w->tiles_y ? ty + r : w->tiles_y - 1;
	int x, y;

	for (y = y0; y <= y1; y++)
		for (x = x0; x <= x1; x++)
			w->tile[y * w->tiles_x + x] |= T_DIRTY;
}

/* 1 if any tile of a row of tiles has the flag. */
static int tile_row_has(const struct swell_wave *w, const uint8_t *trow, uint8_t flag)
{
	int x;

	for (x = 0; x < w->tiles_x; x++)
		if (trow[x] & flag)
			return 1;
	return 0;
}

/* Every tile awake, and every tile's acc and v to be visited at the next finish. */
static void wake_all(struct swell_wave *w)
{
	w->band_asleep = 0;
	memset(w->tile, T_DIRTY | T_DIRTY_PREV, (size_t)w->tiles_x * w->tiles_y);
}

static int e_eff_stable(uint64_t e_eff, uint64_t q)
{
	/* e_eff < (1+q)/(4q) with both in Q1.30:  4 e_eff q < (2^30 + q) 2^30, exact in uint64. */
	return 4u * e_eff * q < (((uint64_t)1 << 30) + q) << 30;
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
	if (!e_eff_stable((uint64_t)e_eff, (uint64_t)(SWELL_Q30_ONE - p->damping)))
		return SWELL_EUNSTABLE;
	return SWELL_OK;
}

q30_t swell_wave_e_limit(q30_t damping, enum swell_stencil stencil)
{
	uint64_t q, lim;

	if (damping < 0 || damping >= SWELL_Q30_ONE)
		return 0;
	q = (uint64_t)(SWELL_Q30_ONE - damping);
	/* smallest e_eff that is unstable: ceil((2^30 + q) 2^30 / (4 q)) */
	lim = (((((uint64_t)1 << 30) + q) << 30) + 4 * q - 1) / (4 * q);
	if (stencil == SWELL_STENCIL_CALIBRATED)
		lim *= 2;
	return lim > INT32_MAX ? INT32_MAX : (q30_t)lim;
}

static void apply_params(struct swell_wave *w, const struct swell_wave_params *p)
{
	w->p = *p;
	w->e_eff = effective_e(p);
	w->c_1 = w->e_eff;
	w->c_half = w->e_eff / 2;
	w->c_wall = w->e_eff + w->c_half;
	w->q = SWELL_Q30_ONE - p->damping;
	if (w->tile) /* new coefficients round differently: every tile awake */
		wake_all(w);
}

enum swell_err swell_wave_init(struct swell_wave *w, uint16_t nx, uint16_t ny, int32_t *storage,
			       size_t words, const struct swell_wave_params *p)
{
	size_t n = (size_t)nx * ny;
	enum swell_err err;

	if (!w || !storage)
		return SWELL_EINVAL;
	if (nx < SWELL_WAVE_MIN_SIDE || ny < SWELL_WAVE_MIN_SIDE || nx > SWELL_WAVE_MAX_SIDE ||
	    ny > SWELL_WAVE_MAX_SIDE || words < SWELL_WAVE_WORDS(nx, ny))
		return SWELL_ESIZE;
	err = swell_wave_check(p);
	if (err != SWELL_OK)
		return err;

	memset(w, 0, sizeof(*w));
	w->nx = nx;
	w->ny = ny;
	w->h = storage;
	w->v = storage + n;
	w->acc = storage + 2 * n;
	w->f_e = storage + 3 * n;
	w->f_n = storage + 4 * n;
	w->f_ne = storage + 5 * n;
	w->f_nw = storage + 6 * n;
	w->tile = (uint8_t *)(storage + 7 * n);
	w->tiles_x = (uint16_t)((nx + SWELL_WAVE_TILE - 1) / SWELL_WAVE_TILE);
	w->tiles_y = (uint16_t)((ny + SWELL_WAVE_TILE - 1) / SWELL_WAVE_TILE);
	w->sleep = 1;
	memset(storage, 0, SWELL_WAVE_WORDS(nx, ny) * sizeof(int32_t));
	apply_params(w, p);
	return SWELL_OK;
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
	size_t n = (size_t)w->nx * w->ny;

	/* v, acc and the four flow arrays are contiguous; a step in progress starts over */
	memset(w->h + n, 0, 6 * n * sizeof(int32_t));
	wake_all(w);
	w->next_row = 0;
}

void swell_wave_touched(struct swell_wave *w, int i, int j)
{
	int tx = i / SWELL_WAVE_TILE, ty = j / SWELL_WAVE_TILE, x, y;

	if (i < 0 || j < 0 || i >= w->nx || j >= w->ny)
		return;
	w->tile[ty * w->tiles_x + tx] |= T_TOUCHED;
	w->band_asleep = 0;
	mark_dirty(w, tx, ty, 2);
	for (y = ty - 1; y <= ty + 1; y++) /* the rest of this step must not skip its neighbours */
		for (x = tx - 1; x <= tx + 1; x++)
			if (x >= 0 && y >= 0 && x < w->tiles_x && y < w->tiles_y)
				w->tile[y * w->tiles_x + x] &= (uint8_t)~T_SLEEPING;
}

void swell_wave_set_sleep(struct swell_wave *w, int on)
{
	w->sleep = on != 0;
	wake_all(w);
}

/* A tile may be skipped: its edges gave zero last step and nothing around it has changed since. */
static int asleep(const struct swell_wave *w, int tx, int ty)
{
	const uint8_t *t = w->tile;
	int x0 = tx > 0 ? tx - 1 : 0, x1 = tx + 1 < w->tiles_x ? tx + 1 : tx;
	int y0 = ty > 0 ? ty - 1 : 0, y1 = ty + 1 < w->tiles_y ? ty + 1 : ty;
	int x, y;

	if (!(t[ty * w->tiles_x + tx] & T_ZERO))
		return 0;
	for (y = y0; y <= y1; y++)
		for (x = x0; x <= x1; x++)
			if (t[y * w->tiles_x + x] & (T_CHANGED | T_TOUCHED))
				return 0;
	return 1;
}

/* New flow of one edge from its old flow and the height difference (see wave.h for the rounding). */
static inline int32_t flow(int32_t f, int32_t dh, q30_t c, q30_t q, int damp, uint32_t *sat)
{
	/* No saturation needed inside: |dh| <= 2^28 and c <= 1.5 * 2^30, so the increment is below
	 * 1.5 * 2^28 and |s| < 2^30; the damping product with q <= 1 only shrinks it. Same rounding as
	 * swell_mul_q30_rn and swell_mul_q30_rz, without their int64 range checks. */
	int64_t p = (int64_t)dh * c;
	int32_t s = f + (int32_t)((p + ((int64_t)1 << 29)) >> 30);

	if (damp) {
		p = (int64_t)s * q;
		s = (int32_t)((p + (p < 0 ? ((int64_t)1 << 30) - 1 : 0)) >> 30);
	}
	if (s > SWELL_H_MAX || s < -SWELL_H_MAX) {
		s = swell_clamp(s, -SWELL_H_MAX, SWELL_H_MAX);
		(*sat)++;
	}
	return s;
}

/* The edges owned by cells [i0, i1) of row j: E edges, and N, NE, NW edges up to row j+1 (none for
 * the top row). Cells on the west and east walls are peeled off so the inner loop has no branches.
 * Returns non-zero if any new flow is non-zero. */
static inline int32_t step_segment(struct swell_wave *w, int j, int i0, int i1, int damp)
{
	const int nx = w->nx;
	const int up = j + 1 < w->ny;
	const q30_t ce = (j == 0 || j == w->ny - 1) ? w->c_wall : w->c_1;
	const q30_t c1 = w->c_1, ch = w->c_half, cw = w->c_wall, q = w->q;
	const int32_t *restrict h = w->h + j * nx;
	const int32_t *restrict hu = h + nx;
	int32_t *restrict v = w->acc + j * nx;
	int32_t *restrict vu = v + nx;
	int32_t *restrict fe = w->f_e + j * nx;
	int32_t *restrict fn = w->f_n + j * nx;
	int32_t *restrict fne = w->f_ne + j * nx;
	int32_t *restrict fnw = w->f_nw + j * nx;
	const int e_end = i1 < nx - 1 ? i1 : nx - 1;
	uint32_t sat = 0;
	int32_t f, any = 0;
	int i;

	for (i = i0; i < e_end; i++) {
		fe[i] = f = flow(fe[i], h[i + 1] - h[i], ce, q, damp, &sat);
		any |= f;
		v[i] += f;
		v[i + 1] -= f;
	}
	if (up) {
		int end = i1 == nx ? nx - 1 : i1;

		i = i0;
		if (i0 == 0) { /* N edge along the west wall, NE diagonal, no NW */
			fn[0] = f = flow(fn[0], hu[0] - h[0], cw, q, damp, &sat);
			any |= f;
			v[0] += f;
			vu[0] -= f;
			fne[0] = f = flow(fne[0], hu[1] - h[0], ch, q, damp, &sat);
			any |= f;
			v[0] += f;
			vu[1] -= f;
			i = 1;
		}
		for (; i < end; i++) {
			int32_t fs;

			fn[i] = f = flow(fn[i], hu[i] - h[i], c1, q, damp, &sat);
			fs = f;
			any |= f;
			vu[i] -= f;
			fne[i] = f = flow(fne[i], hu[i + 1] - h[i], ch, q, damp, &sat);
			fs += f;
			any |= f;
			vu[i + 1] -= f;
			fnw[i] = f = flow(fnw[i], hu[i - 1] - h[i], ch, q, damp, &sat);
			fs += f;
			any |= f;
			vu[i - 1] -= f;
			v[i] += fs;
		}
		if (i1 == nx) { /* N edge along the east wall, NW diagonal, no NE */
			i = nx - 1;
			fn[i] = f = flow(fn[i], hu[i] - h[i], cw, q, damp, &sat);
			any |= f;
			v[i] += f;
			vu[i] -= f;
			fnw[i] = f = flow(fnw[i], hu[i - 1] - h[i], ch, q, damp, &sat);
			any |= f;
			v[i] += f;
			vu[i - 1] -= f;
		}
	}
	w->saturations += sat;
	return any;
}

/* Row j, tile by tile, skipping sleeping tiles. */
static inline void step_row(struct swell_wave *w, int j, int damp)
{
	const int ty = j / SWELL_WAVE_TILE;
	int tx;

	if (!w->sleep) {
		step_segment(w, j, 0, w->nx, damp);
		return;
	}
	if (j % SWELL_WAVE_TILE == 0) {
		w->band_asleep = 1;
		for (tx = 0; tx < w->tiles_x; tx++) {
			uint8_t *f = &w->tile[ty * w->tiles_x + tx];

			if (asleep(w, tx, ty)) {
				*f |= T_SLEEPING;
			} else {
				*f &= (uint8_t)~T_SLEEPING;
				mark_dirty(w, tx, ty, 1);
				w->band_asleep = 0;
			}
		}
	}
	if (w->band_asleep) { /* the whole band of tiles sleeps: nothing to do in this row */
		w->tiles_skipped += w->tiles_x;
		return;
	}
	for (tx = 0; tx < w->tiles_x; tx++) {
		const int i0 = tx * SWELL_WAVE_TILE;
		const int i1 = i0 + SWELL_WAVE_TILE < w->nx ? i0 + SWELL_WAVE_TILE : w->nx;

		if (w->tile[ty * w->tiles_x + tx] & T_SLEEPING) {
			w->tiles_skipped++;
			continue;
		}
		if (step_segment(w, j, i0, i1, damp))
			w->tile[ty * w->tiles_x + tx] |= T_NONZERO;
	}
}

int swell_wave_step_rows(struct swell_wave *w, int rows)
{
	const int damp = w->q != SWELL_Q30_ONE; /* t = 0: no damping multiply at all */
	int j, end = w->next_row + (rows > 0 ? rows : 0);

	if (end > w->ny)
		end = w->ny;
	for (j = w->next_row; j < end; j++) {
		if (damp)
			step_row(w, j, 1);
		else
			step_row(w, j, 0);
	}
	w->next_row = (uint16_t)end;
	return w->ny - end;
}

void swell_wave_step_finish(struct swell_wave *w)
{
	const int n = w->nx * w->ny;
	int32_t *t;
	int a, i, j;

	/* v and acc swap at every finish: the six arrays after h stay contiguous, in some order */
	swell_wave_step_rows(w, w->ny);
	for (j = 0; j < w->ny; j++) {
		/* locals: the flag byte store below may alias anything, *w included */
		int32_t *restrict h = w->h + j * w->nx;
		const int32_t *restrict acc = w->acc + j * w->nx;
		uint8_t *restrict trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;
		const int nx = w->nx, all = !w->sleep;
		uint32_t sat = 0;

		if (!all && j % SWELL_WAVE_TILE == 0 && !tile_row_has(w, trow, T_DIRTY)) {
			j += SWELL_WAVE_TILE - 1; /* a calm band of tiles: nothing wrote acc in it */
			continue;
		}
		for (i = 0; i < nx; i += SWELL_WAVE_TILE) {
			const int end = i + SWELL_WAVE_TILE < nx ? i + SWELL_WAVE_TILE : nx;
			int32_t any = 0;

			if (!all && !(trow[i / SWELL_WAVE_TILE] & T_DIRTY))
				continue; /* nothing wrote acc here: it is all zero */
			for (a = i; a < end; a++) {
				int32_t d = acc[a];
				int32_t x = h[a] + d; /* |h| <= 2^27, |acc| <= 2^30: no overflow */

				any |= d;
				if (x > SWELL_H_MAX || x < -SWELL_H_MAX) {
					x = swell_clamp(x, -SWELL_H_MAX, SWELL_H_MAX);
					sat++;
				}
				h[a] = x;
			}
			if (any)
				trow[i / SWELL_WAVE_TILE] |= T_TOUCHED;
		}
		w->saturations += sat;
	}
	/* The accumulator becomes v; the old v, cleared, the next accumulator. The old v can be non-zero
	 * only where the last finished step was dirty. */
	t = w->v;
	w->v = w->acc;
	w->acc = t;
	if (!w->sleep) {
		memset(w->acc, 0, (size_t)n * sizeof(int32_t));
	} else {
		for (j = 0; j < w->ny; j++) {
			const uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;

			if (j % SWELL_WAVE_TILE == 0 && !tile_row_has(w, trow, T_DIRTY_PREV)) {
				j += SWELL_WAVE_TILE - 1;
				continue;
			}
			for (i = 0; i < w->tiles_x; i++) {
				const int i0 = i * SWELL_WAVE_TILE;
				const int len = i0 + SWELL_WAVE_TILE < w->nx ? SWELL_WAVE_TILE : w->nx - i0;

				if (trow[i] & T_DIRTY_PREV)
					memset(w->acc + j * w->nx + i0, 0, (size_t)len * sizeof(int32_t));
			}
		}
	}
	/* the step is done: its flags become the last finished step's */
	for (a = 0; a < (int)w->tiles_x * w->tiles_y; a++) {
		uint8_t f = w->tile[a];
		uint8_t z1 = f & T_NONZERO ? 0u : T_Z1;

		w->tile[a] = (uint8_t)(z1 | (z1 && (f & T_Z1) ? T_ZERO : 0u) | (f & T_TOUCHED ? T_CHANGED : 0u) |
				       (f & T_DIRTY ? T_DIRTY_PREV : 0u));
	}
	w->next_row = 0;
	w->steps++;
}

void swell_wave_step(struct swell_wave *w)
{
	swell_wave_step_finish(w);
}

void swell_wave_add(struct swell_wave *w, int i, int j, int32_t dh)
{
	int32_t *a;

	if (i < 0 || j < 0 || i >= w->nx || j >= w->ny)
		return;
	w->tile[(j / SWELL_WAVE_TILE) * w->tiles_x + i / SWELL_WAVE_TILE] |= T_DIRTY;
	a = &w->acc[j * w->nx + i];
	/* bounded to +-2^30 so that h + acc cannot overflow at the finish */
	*a = (int32_t)swell_clamp(swell_sat_add(*a, dh), -(1 << 30), 1 << 30);
}

int64_t swell_wave_volume(const struct swell_wave *w)
{
	const int n = w->nx * w->ny;
	int64_t sum = 0;
	int a;

	for (a = 0; a < n; a++)
		sum += w->h[a];
	return sum;
}

/* 2 w (h_b - h_a)(n) (h_b - h_a)(n-1) for one edge; h(n-1) = h - v. */
static int64_t edge_pot2(const struct swell_wave *w, int a, int b, int64_t two_w)
{
	int64_t d_now = (int64_t)w->h[b] - w->h[a];
	int64_t d_prev = d_now - ((int64_t)w->v[b] - w->v[a]);

	return two_w * d_now * d_prev;
}

struct swell_energy swell_wave_energy(const struct swell_wave *w)
{
	const int nx = w->nx, ny = w->ny;
	struct swell_energy en = {0, 0, w->e_eff};
	int i, j, a;

	for (j = 0; j < ny; j++) {
		for (i = 0; i < nx; i++) {
			a = j * nx + i;
			en.kin += (int64_t)w->v[a] * w->v[a];
			if (i + 1 < nx)
				en.pot2 += edge_pot2(w, a, a + 1, (j == 0 || j == ny - 1) ? 3 : 2);
			if (j + 1 >= ny)
				continue;
			en.pot2 += edge_pot2(w, a, a + nx, (i == 0 || i == nx - 1) ? 3 : 2);
			if (i + 1 < nx)
				en.pot2 += edge_pot2(w, a, a + nx + 1, 1);
			if (i > 0)
				en.pot2 += edge_pot2(w, a, a + nx - 1, 1);
		}
	}
	return en;
}

static uint32_t crc_words(uint32_t crc, const int32_t *x, size_t n)
{
	size_t k;

	for (k = 0; k < n; k++) {
		uint32_t u = (uint32_t)x[k];
		uint8_t le[4] = {(uint8_t)u, (uint8_t)(u >> 8), (uint8_t)(u >> 16), (uint8_t)(u >> 24)};

		crc = swell_crc32(crc, le, sizeof(le));
	}
	return crc;
}

uint32_t swell_wave_checksum(const struct swell_wave *w)
{
	size_t n = (size_t)w->nx * w->ny;
	uint32_t crc = crc_words(0, w->h, n);

	crc = crc_words(crc, w->f_e, n);
	crc = crc_words(crc, w->f_n, n);
	crc = crc_words(crc, w->f_ne, n);
	return crc_words(crc, w->f_nw, n);
}

enum swell_err swell_wave_e_from_physical(uint32_t g_mm_s2, uint32_t dt_us, uint32_t depth_um,
					  uint32_t dx_um, q30_t *e)
{
	uint64_t x, eq;

	if (!e)
		return SWELL_EINVAL;
	if (!g_mm_s2 || !dt_us || !depth_um || !dx_um)
		return SWELL_ERANGE;
	/* e = g dt^2 d / dx^2 * 1e-9 in these units; first g d dt^2 / dx^2 (in units of 1e-9), then
	 * scaled to Q1.30. Both steps round to nearest: relative error below 1e-8 for e > 0.01. */
	if (!swell_muldiv_u64((uint64_t)g_mm_s2 * depth_um, (uint64_t)dt_us * dt_us,
			      (uint64_t)dx_um * dx_um, &x))
		return SWELL_ERANGE;
	if (!swell_muldiv_u64(x, (uint64_t)1 << 30, 1000000000u, &eq) || eq == 0 || eq > INT32_MAX)
		return SWELL_ERANGE;
	*e = (q30_t)eq;
	return SWELL_OK;
}
