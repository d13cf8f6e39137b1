/* The edge-flux form's fused kernel: one pass a row segment, a cell's four flows and the sums in
 * registers; on ARMv7E-M with SMMLAR, SMMUL and SSAT (wave.h). Same bits as swell_wave_edge_ref. */
#include "wave_priv.h"

#if SWELL_WAVE_DSP
/* flow_ref with three DSP instructions: SMMLAR gives f + ((a b + 2^31) >> 32), which is the nearest
 * rounding of c dh / 2^30 with a b = (4 c) dh (mode 1, when 4 c_wall < 2^31) or c (4 dh) (mode 2);
 * SMMUL gives floor(4 s q / 2^32) = floor(s q / 2^30); SSAT saturates to int28 and sets the sticky
 * Q flag, read once a segment. */
static inline int32_t flow_dsp(int32_t f, int32_t dh, int32_t c, int32_t q, int damp, int c_times4)
{
	int32_t s, r;

	if (!c_times4)
		dh *= 4;
	__asm__("smmlar %0, %1, %2, %3" : "=r"(s) : "r"(dh), "r"(c), "r"(f));
	if (damp) {
		__asm__("smmul %0, %1, %2" : "=r"(r) : "r"(s * 4), "r"(q));
		s = r - (s >> 31);
	}
	return __ssat(s, 28);
}
#endif

/* Fused: one pass over the segment's cells computes the cell's four flows, adds them and the
 * negative of its west neighbour's E flow to the cell's accumulator, and finishes the accumulator
 * of the cell above-left (its N flow, the NE flow from its left and the NW flow from its right, kept
 * in registers). Whatever crosses the segment's ends (the last E and NE flows, the first NW flow) is
 * scattered there, as the reference does. Heights are carried from cell to cell: two loads a cell.
 * mode 0: flow_ref; 1, 2: flow_dsp (c times 4, dh times 4). */
static inline __attribute__((always_inline)) int32_t segment_fused(struct swell_wave *w, int j, int i0, int i1,
								   int damp, int mode, int shape)
{
	/* shape (segment_shape): 0 any segment; else a whole tile row (8 cells) of a row other than
	 * the first and the last, 1 away from the walls, 2 on the west wall, 3 on the east wall: the
	 * common cases, unrolled with constant offsets */
	const int fixed = shape != 0, nx = WAVE_NX(w), n = fixed ? SWELL_WAVE_TILE : i1 - i0;
	const int west = fixed ? shape == 2 : i0 == 0, east = fixed ? shape == 3 : i1 == nx;
	const int sh = mode == 1 ? 2 : 0;
	const int32_t c1 = w->c_1 << sh, ch = w->c_half << sh, cw = w->c_wall << sh;
	const int32_t ce = (!fixed && (j == 0 || j == w->ny - 1)) ? cw : c1, q = w->q;
	const int32_t *restrict h = w->h + j * nx + i0;
	int32_t *restrict v = w->acc + j * nx + i0;
	int32_t *restrict fb = flows_at(w, i0, j);
	int32_t any = 0, fe = 0, fe_prev = 0, fn, fne, fnw, fne_prev = 0, up = 0;
	int32_t ha = h[0], hr, hul, huc, hur;
	uint32_t sat = 0;
	int k = 0;

#if SWELL_WAVE_DSP
#define WAVE_FLOW(old, dh, c) \
	(mode == 0 ? flow_ref(old, dh, c, q, damp, &sat) : flow_dsp(old, dh, c, q, damp, mode == 1))
	if (mode)
		__set_saturation_occurred(0);
#else
#define WAVE_FLOW(old, dh, c) flow_ref(old, dh, c, q, damp, &sat)
#endif
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
#if SWELL_WAVE_DSP
	if (mode)
		sat = (uint32_t)__saturation_occurred();
#endif
	w->saturations += sat;
	return any;
}

static inline int segment_shape(const struct swell_wave *w, int j, int i0, int i1)
{
	if (i1 != i0 + SWELL_WAVE_TILE || j == 0 || j + 1 >= w->ny || (i0 == 0 && i1 == WAVE_NX(w)))
		return 0;
	return i0 == 0 ? 2 : i1 == WAVE_NX(w) ? 3 : 1;
}

#if !SWELL_WAVE_DSP
static int32_t segment_fused_c(struct swell_wave *w, int j, int i0, int i1, int damp)
{
	switch (segment_shape(w, j, i0, i1)) {
	case 1:
		return damp ? segment_fused(w, j, i0, i1, 1, 0, 1) : segment_fused(w, j, i0, i1, 0, 0, 1);
	case 2:
		return damp ? segment_fused(w, j, i0, i1, 1, 0, 2) : segment_fused(w, j, i0, i1, 0, 0, 2);
	case 3:
		return damp ? segment_fused(w, j, i0, i1, 1, 0, 3) : segment_fused(w, j, i0, i1, 0, 0, 3);
	default:
		return damp ? segment_fused(w, j, i0, i1, 1, 0, 0) : segment_fused(w, j, i0, i1, 0, 0, 0);
	}
}
#endif

#if SWELL_WAVE_DSP
static int32_t segment_fused_dsp(struct swell_wave *w, int j, int i0, int i1, int damp)
{
	if (w->c_wall < ((int32_t)1 << 29)) { /* 4 c fits int32: no multiply of dh */
		switch (segment_shape(w, j, i0, i1)) {
		case 1:
			return damp ? segment_fused(w, j, i0, i1, 1, 1, 1) : segment_fused(w, j, i0, i1, 0, 1, 1);
		case 2:
			return damp ? segment_fused(w, j, i0, i1, 1, 1, 2) : segment_fused(w, j, i0, i1, 0, 1, 2);
		case 3:
			return damp ? segment_fused(w, j, i0, i1, 1, 1, 3) : segment_fused(w, j, i0, i1, 0, 1, 3);
		default:
			return damp ? segment_fused(w, j, i0, i1, 1, 1, 0) : segment_fused(w, j, i0, i1, 0, 1, 0);
		}
	}
	return damp ? segment_fused(w, j, i0, i1, 1, 2, 0) : segment_fused(w, j, i0, i1, 0, 2, 0);
}
#endif

int32_t swell_wave_edge_fused(struct swell_wave *w, int j, int i0, int i1, int damp)
{
#if SWELL_WAVE_DSP
	return segment_fused_dsp(w, j, i0, i1, damp);
#else
	return segment_fused_c(w, j, i0, i1, damp);
#endif
}
