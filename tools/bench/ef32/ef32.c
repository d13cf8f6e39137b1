/* ef32's driver (ef32.h): the tiles, the kernels of ef32_*.c over the rows, the finishing pass. */
#include "ef32.h"

#include <string.h>

#include "ef32_priv.h"
#include "swell/crc.h"

/* The edges of an awake tile write acc in it and in the tiles right of it and above it: mark the
 * block of radius r around (tx, ty) so that the finish visits them (r = 1 for a tile found awake,
 * 2 around a touched tile, whose awake neighbours write around themselves). */
static void mark_dirty(struct ef32 *w, int tx, int ty, int r)
{
	swell_tiles_block(w->tile, w->tiles_x, w->tiles_y, tx, ty, r, 0xffu, T_DIRTY);
}

/* Every tile awake, and every tile's acc and v to be visited at the next finish. */
static void wake_all(struct ef32 *w)
{
	w->band_asleep = 0;
	memset(w->tile, T_DIRTY | T_DIRTY_PREV, (size_t)w->tiles_x * w->tiles_y);
}

void ef32_force(struct ef32 *w, q30_t e_eff, q30_t q)
{
	w->e_eff = e_eff & ~(q30_t)1;
	w->c_1 = w->e_eff;
	w->c_half = w->e_eff / 2;
	w->c_wall = w->e_eff + w->c_half;
	w->q = q;
	wake_all(w);
}

enum swell_err ef32_init(struct ef32 *w, uint16_t nx, uint16_t ny, int32_t *storage, size_t words,
			 const struct swell_wave_params *p)
{
	const size_t n = (size_t)nx * ny;
	enum swell_err err;

	err = swell_wave_init_check(w, storage, nx, ny, p);
	if (err != SWELL_OK)
		return err;
	if (words < EF32_WORDS(nx, ny))
		return SWELL_ESIZE;
	memset(w, 0, sizeof(*w));
	w->nx = nx;
	w->ny = ny;
	w->tiles_x = (uint16_t)SWELL_WAVE_TILES_X(nx);
	w->tiles_y = (uint16_t)SWELL_WAVE_TILES_X(ny);
	w->h = storage;
	w->v = storage + n;
	w->acc = storage + 2 * n;
	w->f = storage + 3 * n;
	w->tile = (uint8_t *)(w->f + 4 * SWELL_WAVE_TILE * (size_t)w->tiles_x * ny);
	w->sleep = 1;
	ef32_set_kernel(w, SWELL_KERNEL_AUTO);
	memset(storage, 0, (size_t)((w->tile - (uint8_t *)storage) + w->tiles_x * w->tiles_y));
	w->p = *p;
	ef32_force(w, p->stencil == SWELL_STENCIL_CALIBRATED ? p->e / 2 : p->e,
		   p->damping ? (SWELL_Q30_ONE - p->damping) | 1 : SWELL_Q30_ONE); /* odd: see ef32.h */
	return SWELL_OK;
}

void ef32_rest(struct ef32 *w)
{
	const size_t n = (size_t)w->nx * w->ny;

	/* v, acc and the flows are contiguous, up to the tile flags */
	memset(w->h + n, 0, (size_t)((uint8_t *)w->tile - (uint8_t *)(w->h + n)));
	wake_all(w);
}

void ef32_touched(struct ef32 *w, int i, int j)
{
	if (i < 0 || j < 0 || i >= w->nx || j >= w->ny)
		return;
	w->band_asleep = 0; /* the rest of this step must not skip the tile's neighbours */
	mark_dirty(w, i / SWELL_WAVE_TILE, j / SWELL_WAVE_TILE, 2);
	swell_tiles_touch(w->tile, w->tiles_x, w->tiles_y, i / SWELL_WAVE_TILE, j / SWELL_WAVE_TILE);
}

void ef32_set_sleep(struct ef32 *w, int on)
{
	w->sleep = on != 0;
	wake_all(w);
}

enum swell_err ef32_set_kernel(struct ef32 *w, enum swell_wave_kernel k)
{
	return w ? swell_kernel_choose(k, &w->kernel) : SWELL_EINVAL;
}

/* The edges owned by cells [i0, i1) of row j; non-zero if any new flow is non-zero. */
static int32_t step_segment(struct ef32 *w, int j, int i0, int i1, int damp)
{
	switch (w->kernel) {
#if SWELL_WAVE_AVX2
	case SWELL_KERNEL_AVX2:
		return ef32_kernel_avx2(w, j, i0, i1, damp);
#endif
	case SWELL_KERNEL_FUSED:
		return ef32_kernel_fused(w, j, i0, i1, damp);
	default:
		return ef32_kernel_ref(w, j, i0, i1, damp);
	}
}

/* Row j, tile by tile, skipping sleeping tiles; at the first row of a band of tiles, which of its
 * tiles sleep in this step, and whether all do. */
static void step_row(struct ef32 *w, int j, int damp)
{
	const int ty = j / SWELL_WAVE_TILE;
	uint8_t *trow = &w->tile[ty * w->tiles_x];
	int tx;

	if (w->sleep && j % SWELL_WAVE_TILE == 0) {
		w->band_asleep = (uint8_t)swell_tiles_band(w->tile, w->tiles_x, w->tiles_y, ty);
		for (tx = 0; tx < w->tiles_x; tx++)
			if (!(trow[tx] & T_SLEEPING))
				mark_dirty(w, tx, ty, 1);
	}
	if (w->sleep && w->band_asleep) { /* the whole band of tiles sleeps: nothing to do in this row */
		w->tiles_skipped += w->tiles_x;
		return;
	}
	for (tx = 0; tx < w->tiles_x; tx++) {
		const int i0 = tx * SWELL_WAVE_TILE;
		const int i1 = i0 + SWELL_WAVE_TILE < w->nx ? i0 + SWELL_WAVE_TILE : w->nx;

		if (w->sleep && (trow[tx] & T_SLEEPING)) {
			w->tiles_skipped++;
			continue;
		}
		if (step_segment(w, j, i0, i1, damp))
			trow[tx] |= T_NONZERO;
	}
}

/* One tile row of the finish: h += acc (add), and the old v cleared (clear); returns non-zero if any
 * cell changed. With len a constant 8 the compiler unrolls it. */
static inline __attribute__((always_inline)) int32_t finish_seg(int32_t *restrict h, const int32_t *restrict acc,
								int32_t *restrict v, int len, int add, int clear,
								uint32_t *sat)
{
	int32_t any = 0;
	int a;

#pragma GCC unroll 8
	for (a = 0; a < len; a++) {
		if (add) { /* |h| <= 2^27, |acc| <= 2^29 + 8 2^27: no overflow */
			any |= acc[a];
			h[a] = sat28(h[a] + acc[a], sat);
		}
		if (clear)
			v[a] = 0;
	}
	return any;
}

/* Row j of the finishing pass: h += acc where the step wrote acc (DIRTY), the old v cleared where the
 * last step wrote it (DIRTY_PREV); sets TOUCHED where a cell changed. */
static void finish_row(struct ef32 *w, int j)
{
	const int nx = w->nx, all = !w->sleep;
	uint8_t *restrict trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;
	int32_t *restrict h = w->h + j * nx;
	const int32_t *restrict acc = w->acc + j * nx;
	int32_t *restrict v = w->v + j * nx;
	uint32_t sat = 0;
	int tx;

	for (tx = 0; tx < w->tiles_x; tx++) {
		const int i0 = tx * SWELL_WAVE_TILE, f = all ? T_DIRTY | T_DIRTY_PREV : trow[tx];
		int32_t any;

		if (i0 + SWELL_WAVE_TILE <= nx) {
			if ((f & T_DIRTY) && (f & T_DIRTY_PREV))
				any = finish_seg(h + i0, acc + i0, v + i0, SWELL_WAVE_TILE, 1, 1, &sat);
			else if (f & T_DIRTY)
				any = finish_seg(h + i0, acc + i0, v + i0, SWELL_WAVE_TILE, 1, 0, &sat);
			else if (f & T_DIRTY_PREV)
				any = finish_seg(h + i0, acc + i0, v + i0, SWELL_WAVE_TILE, 0, 1, &sat);
			else
				continue;
		} else {
			any = finish_seg(h + i0, acc + i0, v + i0, nx - i0, (f & T_DIRTY) != 0, (f & T_DIRTY_PREV) != 0,
					 &sat);
		}
		if (any)
			trow[tx] |= T_TOUCHED;
	}
	w->saturations += sat;
}

/* A finished step's tile flags as the last finished step's: Z1 where the step left no non-zero flow,
 * ZERO where that is the second step running, CHANGED from TOUCHED, DIRTY_PREV from DIRTY. */
static uint8_t step_flags(uint8_t x)
{
	const uint8_t z1 = !(x & T_NONZERO);

	return (uint8_t)((z1 ? T_Z1 : 0u) | (z1 && (x & T_Z1) ? T_ZERO : 0u) | (x & T_TOUCHED ? T_CHANGED : 0u) |
			 (x & T_DIRTY ? T_DIRTY_PREV : 0u));
}

void ef32_step(struct ef32 *w)
{
	const int damp = w->q != SWELL_Q30_ONE; /* t = 0: no damping multiply at all */
	const size_t n = (size_t)w->tiles_x * w->tiles_y;
	int32_t *tmp;
	size_t a;
	int j;

	for (j = 0; j < w->ny; j++)
		step_row(w, j, damp);
	/* h += acc where the step wrote acc; the old v, which becomes the next accumulator, cleared
	 * where the last step wrote it; a band of tiles with neither is skipped whole; then the two swap */
	for (j = 0; j < w->ny; j++) {
		if (w->sleep && j % SWELL_WAVE_TILE == 0 &&
		    !swell_tiles_row_any(w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x, w->tiles_x,
					 T_DIRTY | T_DIRTY_PREV, 0)) {
			j += SWELL_WAVE_TILE - 1;
			continue;
		}
		finish_row(w, j);
	}
	tmp = w->v;
	w->v = w->acc;
	w->acc = tmp;
	for (a = 0; a < n; a++)
		w->tile[a] = step_flags(w->tile[a]);
	w->steps++;
}

int64_t ef32_volume(const struct ef32 *w)
{
	const int n = w->nx * w->ny;
	int64_t sum = 0;
	int a;

	for (a = 0; a < n; a++)
		sum += w->h[a];
	return sum;
}

/* The last step's change of cell a */
static int32_t last_change(const void *w, int a)
{
	return ((const struct ef32 *)w)->v[a];
}

struct swell_energy ef32_energy(const struct ef32 *w)
{
	return swell_energy_of(w->h, w->nx, w->ny, w->e_eff, last_change, w);
}

uint32_t ef32_checksum(const struct ef32 *w)
{
	const size_t n = (size_t)w->nx * w->ny;
	uint32_t crc = swell_crc32_words(0, w->h, n);
	int k, i, j;

	for (k = 0; k < 4; k++)
		for (j = 0; j < w->ny; j++)
			for (i = 0; i < w->nx; i++)
				crc = swell_crc32_words(crc, flows_at(w, i, j) + 8 * k, 1);
	return crc;
}
