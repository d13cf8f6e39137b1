/* ef32's fused kernel: one pass a row segment, a cell's four flows and the sums in registers.
 * Same bits as ef32_kernel_ref. */
#include "ef32_priv.h"

/* Fused: one pass over the segment's cells computes the cell's four flows, adds them and the
 * negative of its west neighbour's E flow to the cell's accumulator, and finishes the accumulator
 * of the cell above-left (its N flow, the NE flow from its left and the NW flow from its right, kept
 * in registers). Whatever crosses the segment's ends (the last E and NE flows, the first NW flow) is
 * scattered there, as the reference does. Heights are carried from cell to cell: two loads a cell.
 */
static inline __attribute__((always_inline)) int32_t segment_fused(struct ef32 *w, int j, int i0, int i1, int damp,
								   int shape)
{
	/* shape (segment_shape): 0 any segment; else a whole tile row (8 cells) of a row other than
	 * the first and the last, 1 away from the walls, 2 on the west wall, 3 on the east wall: the
	 * common cases, unrolled with constant offsets */
	const int fixed = shape != 0, nx = w->nx, n = fixed ? SWELL_WAVE_TILE : i1 - i0;
	const int west = fixed ? shape == 2 : i0 == 0, east = fixed ? shape == 3 : i1 == nx;
	const int32_t c1 = w->c_1, ch = w->c_half, cw = w->c_wall;
	const int32_t ce = (!fixed && (j == 0 || j == w->ny - 1)) ? cw : c1, q = w->q;
	const int32_t *restrict h = w->h + j * nx + i0;
	int32_t *restrict v = w->acc + j * nx + i0;
	int32_t *restrict fb = flows_at(w, i0, j);
	int32_t any = 0, fe = 0, fe_prev = 0, fn, fne, fnw, fne_prev = 0, up = 0;
	int32_t ha = h[0], hr, hul, huc, hur;
	uint32_t sat = 0;
	int k = 0;

#define WAVE_FLOW(old, dh, c) flow_ref(old, dh, c, q, damp, &sat)
	if (!fixed && j + 1 >= w->ny) { /* the top row: E edges only */
		for (; k < n; k++) {
			fe = 0;
			if (i0 + k + 1 < nx) {
				hr = h[k + 1];
				fb[FE + k] = fe = WAVE_FLOW(fb[FE + k], hr - ha, ce);
				ha = hr;
			}
			any |= fe;
			v[k] += fe - fe_prev;
			fe_prev = fe;
		}
	} else {
		const int end = east ? n - 1 : n;

		huc = h[nx];
		hul = west ? 0 : h[nx - 1];
		if (west) { /* the west wall: N along it, NE, no NW */
			hr = h[1];
			hur = h[nx + 1];
			fb[FE] = fe = WAVE_FLOW(fb[FE], hr - ha, ce);
			fb[FN] = fn = WAVE_FLOW(fb[FN], huc - ha, cw);
			fb[FNE] = fne = WAVE_FLOW(fb[FNE], hur - ha, ch);
			any |= fe | fn | fne;
			v[0] += fe + fn + fne;
			up = fn;
			fne_prev = fne;
			fe_prev = fe;
			ha = hr;
			hul = huc;
			huc = hur;
			k = 1;
		}
#pragma GCC unroll 8
		for (; k < end; k++) {
			hr = h[k + 1];
			hur = h[nx + k + 1];
			fb[FE + k] = fe = WAVE_FLOW(fb[FE + k], hr - ha, ce);
			fb[FN + k] = fn = WAVE_FLOW(fb[FN + k], huc - ha, c1);
			fb[FNE + k] = fne = WAVE_FLOW(fb[FNE + k], hur - ha, ch);
			fb[FNW + k] = fnw = WAVE_FLOW(fb[FNW + k], hul - ha, ch);
			any |= fe | fn | fne | fnw;
			v[nx + k - 1] -= up + fnw;
			v[k] += fe + fn + fne + fnw - fe_prev;
			up = fn + fne_prev;
			fne_prev = fne;
			fe_prev = fe;
			ha = hr;
			hul = huc;
			huc = hur;
		}
		if (east) { /* the east wall: N along it, NW, no E, no NE */
			fb[FN + k] = fn = WAVE_FLOW(fb[FN + k], huc - ha, cw);
			fb[FNW + k] = fnw = WAVE_FLOW(fb[FNW + k], hul - ha, ch);
			any |= fn | fnw;
			v[nx + k - 1] -= up + fnw;
			v[k] += fn + fnw - fe_prev;
			up = fn + fne_prev;
			fne_prev = fe_prev = 0;
		}
		v[nx + n - 1] -= up;
		if (!east)
			v[nx + n] -= fne_prev;
	}
#undef WAVE_FLOW
	if (!east)
		v[n] -= fe_prev;
	w->saturations += sat;
	return any;
}

static inline int segment_shape(const struct ef32 *w, int j, int i0, int i1)
{
	if (i1 != i0 + SWELL_WAVE_TILE || j == 0 || j + 1 >= w->ny || (i0 == 0 && i1 == w->nx))
		return 0;
	return i0 == 0 ? 2 : i1 == w->nx ? 3 : 1;
}

int32_t ef32_kernel_fused(struct ef32 *w, int j, int i0, int i1, int damp)
{
	switch (segment_shape(w, j, i0, i1)) {
	case 1:
		return damp ? segment_fused(w, j, i0, i1, 1, 1) : segment_fused(w, j, i0, i1, 0, 1);
	case 2:
		return damp ? segment_fused(w, j, i0, i1, 1, 2) : segment_fused(w, j, i0, i1, 0, 2);
	case 3:
		return damp ? segment_fused(w, j, i0, i1, 1, 3) : segment_fused(w, j, i0, i1, 0, 3);
	default:
		return damp ? segment_fused(w, j, i0, i1, 1, 0) : segment_fused(w, j, i0, i1, 0, 0);
	}
}
