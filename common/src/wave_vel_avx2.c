/* The velocity form's AVX2 kernel (x86-64 hosts with AVX2, chosen at run time by wave.c): one 8-lane
 * register a tile row, so that a vector is exactly one tile's cells of row j and its "any" flag one
 * VPTEST. A call does the rows of a band of tiles within a slice, whole (the driver's bookkeeping
 * included: sleeping tiles, T_NONZERO, the sums, the saturation count), two rows side by side where
 * no tile of the band sleeps. The column sums S = h(j-1) + 2 h(j) + h(j+1) of a vector come from
 * three loads (four for two rows); the neighbours' S(i-1) and S(i+1) are the vector's own lanes
 * shifted in from the vectors left and right (VPERM2I128 + VPALIGNR), mirrored at the walls by a lane
 * permutation. x C / 2^32 is taken from VPMULDQ of the even and of the odd lanes (64-bit products, the
 * high halves blended); the damping as floor(4 s q / 2^32) the same way. The last tile of a row may be
 * narrower than 8: masked loads and stores. The sums of s and dh are int32 a lane within a run (at
 * most 16 cells a lane, |s| <= 2^27) and int64 after. Same bits as swell_wave_vel_ref (wave_priv.h
 * has the rule), the saturation count included (one a run of the reference's that clamped). The
 * finishing pass is here too, a band of tiles at a time where it can. C = e_eff 2^(F+1) above
 * INT32_MAX (e_eff = 1 undamped at F = 0) is left to the fused kernel (wave.c). */
#include "wave_priv.h"

#if SWELL_WAVE_AVX2
#include <immintrin.h>
#include <string.h>

#define VA_FN __attribute__((target("avx2"), always_inline)) static inline

/* The int32 lane sums hold a run of two rows: 16 cells of int28 sum to -2^31 .. 2^31 - 16. */
_Static_assert(2 * SWELL_WAVE_VEL_RUN <= 16, "the int32 lane sums hold 16 cells of int28");

struct va_k {
	__m256i c, q, round, half, hmin, hmax, zero;
};

/* floor((a b + round) / 2^32) a lane; b has the same value in every lane. */
VA_FN __m256i va_mulhi(__m256i a, __m256i b, __m256i round, int rnd)
{
	__m256i pe = _mm256_mul_epi32(a, b), po = _mm256_mul_epi32(_mm256_srli_epi64(a, 32), b);

	if (rnd) {
		pe = _mm256_add_epi64(pe, round);
		po = _mm256_add_epi64(po, round);
	}
	return _mm256_blend_epi32(_mm256_srli_epi64(pe, 32), po, 0xAA);
}

/* The new momentum of 8 cells from x = 2 L9 and u; *clamped gets the lanes that saturated. */
VA_FN __m256i va_cell(const struct va_k *K, __m256i x, __m256i u, int damp, __m256i *clamped)
{
	__m256i s, t;

	if (damp) { /* toward half the kick (one up where s + u < 0), then the damping toward zero */
		s = _mm256_add_epi32(u, va_mulhi(x, K->c, K->round, 0));
		s = _mm256_sub_epi32(s, _mm256_cmpgt_epi32(K->zero, _mm256_add_epi32(s, u)));
	} else {
		s = _mm256_add_epi32(u, va_mulhi(x, K->c, K->round, 1));
	}
	t = _mm256_min_epi32(_mm256_max_epi32(s, K->hmin), K->hmax);
	*clamped = _mm256_xor_si256(s, t);
	if (damp) /* |t| <= 2^27: 4 t fits, and floor(4 t q / 2^32) = floor(t q / 2^30) */
		t = _mm256_sub_epi32(va_mulhi(_mm256_slli_epi32(t, 2), K->q, K->round, 0),
				     _mm256_cmpgt_epi32(K->zero, t));
	return t;
}

/* The running sums: s and dh as int32 lanes within a run of at most SWELL_WAVE_VEL_RUN awake tiles
 * (of one row, or of two rows side by side), int64 lanes after. */
struct va_acc {
	__m256i tot, tot_h, tot64, tot_h64;
};

/* One vector of cells: x from the column sums left, centre and right, the cell, the stores, the
 * lanes that clamped into *sat; returns non-zero when some new s is non-zero. */
VA_FN int va_vec(const struct va_k *K, struct va_acc *A, __m256i *sat, __m256i sm, __m256i s0, __m256i sp, __m256i c,
		 int32_t *u, int32_t *acc, __m256i mask, int masked, int damp, int f)
{
	const __m256i x = _mm256_sub_epi32(_mm256_add_epi32(_mm256_add_epi32(sm, sp), _mm256_add_epi32(s0, s0)),
					   _mm256_slli_epi32(c, 4));
	__m256i uo, ao, s, dh, clamped;

	uo = masked ? _mm256_maskload_epi32(u, mask) : _mm256_loadu_si256((const __m256i *)u);
	ao = masked ? _mm256_maskload_epi32(acc, mask) : _mm256_loadu_si256((const __m256i *)acc);
	s = va_cell(K, x, uo, damp, &clamped);
	/* nearest, ties away from zero: (s + 2^(F-1) - (s < 0)) >> F; at F = 0, s */
	dh = f ? _mm256_srai_epi32(_mm256_add_epi32(_mm256_add_epi32(s, K->half), _mm256_cmpgt_epi32(K->zero, s)), f)
	       : s;
	if (masked) {
		_mm256_maskstore_epi32(u, mask, s);
		_mm256_maskstore_epi32(acc, mask, _mm256_add_epi32(ao, dh));
		s = _mm256_and_si256(s, mask);
		dh = _mm256_and_si256(dh, mask);
		clamped = _mm256_and_si256(clamped, mask);
	} else {
		_mm256_storeu_si256((__m256i *)u, s);
		_mm256_storeu_si256((__m256i *)acc, _mm256_add_epi32(ao, dh));
	}
	*sat = _mm256_or_si256(*sat, clamped);
	A->tot = _mm256_add_epi32(A->tot, s);
	if (f)
		A->tot_h = _mm256_add_epi32(A->tot_h, dh);
	return !_mm256_testz_si256(s, s);
}

/* a + the int32 lanes of b, widened to int64 */
VA_FN __m256i va_widen(__m256i a, __m256i b)
{
	return _mm256_add_epi64(a,
				_mm256_add_epi64(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(b)),
						 _mm256_cvtepi32_epi64(_mm256_extracti128_si256(b, 1))));
}

/* The int32 sums into the int64 ones (at the end of a run). */
VA_FN void va_widen_sums(struct va_acc *A, int f)
{
	A->tot64 = va_widen(A->tot64, A->tot);
	A->tot = _mm256_setzero_si256();
	if (f) {
		A->tot_h64 = va_widen(A->tot_h64, A->tot_h);
		A->tot_h = _mm256_setzero_si256();
	}
}

/* the sum of the int64 lanes */
VA_FN int64_t va_hsum64(__m256i a)
{
	const __m128i t = _mm_add_epi64(_mm256_castsi256_si128(a), _mm256_extracti128_si256(a, 1));

	return _mm_cvtsi128_si64(t) + _mm_extract_epi64(t, 1);
}

/* What a call counts: the saturations (one a run that clamped) and the tiles skipped. */
struct va_count {
	uint32_t sat, skipped;
};

/* A row in progress: the column sums left of and at vector b, the centre row's heights of vector b,
 * the lanes that clamped in the current run and its awake tiles. */
struct va_pipe {
	__m256i sm, s0, c0, sat;
	int run;
};

/* The end of a run of awake tiles of a row (the reference's call): one saturation count if a lane
 * clamped. */
VA_FN uint32_t va_sat_end(struct va_pipe *P)
{
	const uint32_t sat = !_mm256_testz_si256(P->sat, P->sat);

	P->sat = _mm256_setzero_si256();
	return sat;
}

/* Vector b of row j with the column sums sp right of it: its cells when its tile is awake, and the
 * run's bookkeeping; awake: no tile of the row sleeps, the caller ends the runs. */
VA_FN void va_tile(uint8_t *trow, int b, const struct va_k *K, struct va_acc *A, struct va_count *n, struct va_pipe *P,
		   __m256i sp, int32_t *u, int32_t *acc, __m256i mask, int masked, int awake, int damp, int f)
{
	if (!awake && (trow[b] & T_SLEEPING)) {
		n->skipped++;
		if (P->run) {
			n->sat += va_sat_end(P);
			va_widen_sums(A, f);
			P->run = 0;
		}
		return;
	}
	if (va_vec(K, A, &P->sat, P->sm, P->s0, sp, P->c0, u + 8 * b, acc + 8 * b, mask, masked, damp, f))
		trow[b] |= T_NONZERO;
	if (!awake && ++P->run == SWELL_WAVE_VEL_RUN) {
		n->sat += va_sat_end(P);
		va_widen_sums(A, f);
		P->run = 0;
	}
}

/* Vector b of a row whose next vector's column sums are sn (centre row cn): vector b, then the
 * pipeline moves on by one vector. */
VA_FN void va_step(uint8_t *trow, int b, const struct va_k *K, struct va_acc *A, struct va_count *n, struct va_pipe *P,
		   __m256i sn, __m256i cn, int32_t *u, int32_t *acc, __m256i mask, int awake, int damp, int f)
{
	const __m256i t = _mm256_permute2x128_si256(P->s0, sn, 0x21); /* s0's high half, sn's low half */

	va_tile(trow, b, K, A, n, P, _mm256_alignr_epi8(t, P->s0, 4), u, acc, mask, 0, awake, damp, f);
	P->sm = _mm256_alignr_epi8(sn, t, 12);
	P->s0 = sn;
	P->c0 = cn;
}

/* The column sums of vector b of rows j .. j + q - 1 (q = 1 or 2; rows[] holds rows j - 1 .. j + q,
 * mirrored at the walls), each row's from three of the q + 2 loads: into sn[], the centre rows into
 * cn[]; the first r lanes only when masked. */
VA_FN void va_colsums(const int32_t *const *rows, int q, int i, __m256i mask, int masked, __m256i *sn, __m256i *cn)
{
	__m256i l[4];
	int k;

#pragma GCC unroll 4
	for (k = 0; k < q + 2; k++)
		l[k] = masked ? _mm256_maskload_epi32(rows[k] + i, mask)
			      : _mm256_loadu_si256((const __m256i *)(rows[k] + i));
#pragma GCC unroll 4
	for (k = 0; k < q; k++) {
		sn[k] = _mm256_add_epi32(_mm256_add_epi32(l[k], l[k + 2]), _mm256_add_epi32(l[k + 1], l[k + 1]));
		cn[k] = l[k + 1];
	}
}

/* Rows j .. j + q - 1 of one band, every tile: vectors of 8 cells (a tile's row each) from the west
 * wall to the east wall, the column sums carried from one vector to the next, the last vector masked
 * when the row's last tile is narrower. A sleeping tile is skipped (its column sums still feed its
 * neighbours). The driver's bookkeeping is here too, as step_row_vel in wave.c does it for the
 * other kernels: T_NONZERO where a tile's new s is non-zero, the tiles skipped, and the saturation
 * count of the reference's calls (runs of up to SWELL_WAVE_VEL_RUN awake tiles, split at sleeping
 * tiles: one a run that clamped). awake: no tile of the band sleeps, so the runs are the tiles
 * [8 k, 8 k + 8) and their bookkeeping leaves the loop over the vectors; then two rows (q = 2) go
 * side by side, sharing their loads of h and the loop. */
VA_FN void va_rows_pass(struct swell_wave *w, int j, int q, int awake, uint8_t *trow, const struct va_k *K,
			struct va_acc *A, struct va_count *n, int damp, int f)
{
	const int nx = w->nx, nv = (nx + 7) / 8, r = nx - 8 * (nv - 1); /* the last vector's width, 1..8 */
	const int32_t *hc = w->h + (size_t)j * nx;
	const int32_t *rows[4];
	int32_t *u = w->u + (size_t)j * nx, *acc = w->acc + (size_t)j * nx;
	const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
	const __m256i mask = _mm256_cmpgt_epi32(_mm256_set1_epi32(r), lane);
	struct va_pipe P[2];
	__m256i sn[2], cn[2];
	int b = 0, k1, whole, k;

	rows[0] = j > 0 ? hc - nx : hc;
#pragma GCC unroll 4
	for (k = 1; k <= q; k++)
		rows[k] = hc + (size_t)(k - 1) * nx;
	rows[q + 1] = j + q < w->ny ? hc + (size_t)q * nx : rows[q];
	va_colsums(rows, q, 0, mask, nv == 1 && r < 8, sn, cn);
#pragma GCC unroll 4
	for (k = 0; k < q; k++) {
		P[k].run = 0;
		P[k].sat = _mm256_setzero_si256();
		P[k].s0 = sn[k];
		P[k].c0 = cn[k];
		/* the column left of the row: its first column mirrored at the west wall */
		P[k].sm = _mm256_permutevar8x32_epi32(sn[k], _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6));
	}
	while (b < nv) { /* SWELL_WAVE_VEL_RUN tiles (the reference's run when awake), the last ones fewer */
		k1 = b + SWELL_WAVE_VEL_RUN < nv ? b + SWELL_WAVE_VEL_RUN : nv;
		whole = k1 < nv - 1 ? k1 : nv - 2; /* vectors before it have a whole next vector */
		for (; b < whole; b++) {
			va_colsums(rows, q, 8 * (b + 1), mask, 0, sn, cn);
#pragma GCC unroll 4
			for (k = 0; k < q; k++)
				va_step(trow, b, K, A, n, &P[k], sn[k], cn[k], u + (size_t)k * nx, acc + (size_t)k * nx,
					mask, awake, damp, f);
		}
		if (b < k1 && b == nv - 2) { /* the last but one: the next vector may be narrower */
			if (r < 8)
				va_colsums(rows, q, 8 * (b + 1), mask, 1, sn, cn);
			else
				va_colsums(rows, q, 8 * (b + 1), mask, 0, sn, cn);
#pragma GCC unroll 4
			for (k = 0; k < q; k++)
				va_step(trow, b, K, A, n, &P[k], sn[k], cn[k], u + (size_t)k * nx, acc + (size_t)k * nx,
					mask, awake, damp, f);
			b++;
		}
		if (b < k1) { /* the last: the column right of it is its last column mirrored at the east wall */
			const __m256i east = _mm256_min_epi32(_mm256_add_epi32(lane, _mm256_set1_epi32(1)),
							      _mm256_set1_epi32(r - 1));

#pragma GCC unroll 4
			for (k = 0; k < q; k++) {
				sn[k] = _mm256_permutevar8x32_epi32(P[k].s0, east);
				if (r < 8)
					va_tile(trow, b, K, A, n, &P[k], sn[k], u + (size_t)k * nx,
						acc + (size_t)k * nx, mask, 1, awake, damp, f);
				else
					va_tile(trow, b, K, A, n, &P[k], sn[k], u + (size_t)k * nx,
						acc + (size_t)k * nx, mask, 0, awake, damp, f);
			}
			b++;
		}
		if (awake) {
#pragma GCC unroll 4
			for (k = 0; k < q; k++)
				n->sat += va_sat_end(&P[k]);
			va_widen_sums(A, f);
		}
	}
	if (!awake && P[0].run) { /* the row's last run */
		n->sat += va_sat_end(&P[0]);
		va_widen_sums(A, f);
	}
}

/* Rows [j0, j1) of one band of tiles (flags trow) */
VA_FN void va_rows(struct swell_wave *w, int j0, int j1, uint8_t *trow, int damp, int f)
{
	struct va_k K;
	struct va_acc A;
	struct va_count n = { 0, 0 };
	int64_t tot;
	int j, tx, awake = 1;

	/* a band none of whose tiles sleeps (or tiles do not sleep) runs without the tests */
	if (w->sleep)
		for (tx = 0; tx < w->tiles_x && awake; tx++)
			awake = !(trow[tx] & T_SLEEPING);
	K.c = _mm256_set1_epi32((int32_t)((int64_t)w->e_eff << (w->vel_frac + 1)));
	K.q = _mm256_set1_epi32(w->q);
	K.round = _mm256_set1_epi64x((int64_t)1 << 31);
	K.half = _mm256_set1_epi32(f ? 1 << (f - 1) : 0);
	K.zero = _mm256_setzero_si256();
	K.hmin = _mm256_set1_epi32(SWELL_H_MIN);
	K.hmax = _mm256_set1_epi32(SWELL_H_MAX);
	A.tot = A.tot_h = A.tot64 = A.tot_h64 = _mm256_setzero_si256();
	if (awake) {
		for (j = j0; j + 1 < j1; j += 2) /* two rows a pass */
			va_rows_pass(w, j, 2, 1, trow, &K, &A, &n, damp, f);
		if (j < j1)
			va_rows_pass(w, j, 1, 1, trow, &K, &A, &n, damp, f);
	} else {
		for (j = j0; j < j1; j++)
			va_rows_pass(w, j, 1, 0, trow, &K, &A, &n, damp, f);
	}
	w->saturations += n.sat;
	w->tiles_skipped += n.skipped;
	tot = va_hsum64(A.tot64);
	w->vel_sum += tot;
	w->vel_sum_h += f ? va_hsum64(A.tot_h64) : tot;
}

__attribute__((target("avx2"))) void swell_wave_vel_rows_avx2(struct swell_wave *w, int j0, int j1, uint8_t *trow,
							      int damp)
{
	if (damp) { /* then F = 0 (swell_wave_vel_avx2_fits) */
		va_rows(w, j0, j1, trow, 1, 0);
		return;
	}
	switch (w->vel_frac) { /* F as an immediate shift */
	case 1:
		va_rows(w, j0, j1, trow, 0, 1);
		break;
	case 2:
		va_rows(w, j0, j1, trow, 0, 2);
		break;
	case 3:
		va_rows(w, j0, j1, trow, 0, 3);
		break;
	case 4:
		va_rows(w, j0, j1, trow, 0, 4);
		break;
	default:
		va_rows(w, j0, j1, trow, 0, 0);
	}
}

/* h = clamp(h + a) of 8 cells; returns the lanes that clamped */
VA_FN __m256i va_add_clamp(int32_t *h, __m256i a, __m256i hmin, __m256i hmax)
{
	const __m256i x = _mm256_add_epi32(_mm256_loadu_si256((__m256i *)h), a);
	const __m256i t = _mm256_min_epi32(_mm256_max_epi32(x, hmin), hmax);

	_mm256_storeu_si256((__m256i *)h, t);
	return _mm256_xor_si256(x, t);
}

/* h += acc of one vector (m: its lanes, or all), clamped, the lanes that clamped in *sat; returns
 * T_TOUCHED when some acc is non-zero */
VA_FN uint8_t va_finish(int32_t *h, const int32_t *acc, __m256i m, int masked, __m256i hmin, __m256i hmax, __m256i *sat)
{
	const __m256i a = masked ? _mm256_maskload_epi32(acc, m) : _mm256_loadu_si256((const __m256i *)acc);
	const __m256i x = _mm256_add_epi32(masked ? _mm256_maskload_epi32(h, m) : _mm256_loadu_si256((__m256i *)h), a);
	const __m256i t = _mm256_min_epi32(_mm256_max_epi32(x, hmin), hmax);

	*sat = _mm256_or_si256(*sat, _mm256_xor_si256(x, t));
	if (masked)
		_mm256_maskstore_epi32(h, m, t);
	else
		_mm256_storeu_si256((__m256i *)h, t);
	return _mm256_testz_si256(a, a) ? 0 : T_TOUCHED;
}

/* Row j of the finish where every tile needs what the pass does (add: h += acc, clear: v = 0), the
 * row's whole tiles only; the lanes that clamped into *sat. */
VA_FN void va_finish_tiles(int32_t *h, const int32_t *acc, int32_t *v, uint8_t *trow, int full, int add, int clear,
			   __m256i *sat)
{
	const __m256i hmin = _mm256_set1_epi32(SWELL_HV_MIN), hmax = _mm256_set1_epi32(SWELL_HV_MAX);
	const __m256i zero = _mm256_setzero_si256();
	int tx;

	for (tx = 0; tx < full; tx++) {
		const int i = tx * SWELL_WAVE_TILE;

		if (add)
			trow[tx] |= va_finish(h + i, acc + i, zero, 0, hmin, hmax, sat);
		if (clear)
			_mm256_storeu_si256((__m256i *)(v + i), zero);
	}
}

/* Row j of the finish, tile by tile as the flags say (f = what a tile needs, of need), the last tile
 * masked when it is narrower than 8. every: the flags every tile has when tiles do not sleep. */
VA_FN void va_finish_row(struct swell_wave *w, int j, uint8_t need, uint8_t every, int whole)
{
	const int nx = w->nx, full = nx / SWELL_WAVE_TILE;
	uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;
	int32_t *h = w->h + (size_t)j * nx, *v = w->v + (size_t)j * nx;
	const int32_t *acc = w->acc + (size_t)j * nx;
	const __m256i hmin = _mm256_set1_epi32(SWELL_HV_MIN), hmax = _mm256_set1_epi32(SWELL_HV_MAX);
	const __m256i zero = _mm256_setzero_si256();
	__m256i sat = zero;
	int tx;

	/* |h| <= 2^26, |acc| <= 2^29 + 8 2^27: h + acc does not overflow */
	if (whole) { /* every tile needs all of need: no flags to test */
		if (need == (T_DIRTY | T_DIRTY_PREV))
			va_finish_tiles(h, acc, v, trow, full, 1, 1, &sat);
		else if (need == T_DIRTY)
			va_finish_tiles(h, acc, v, trow, full, 1, 0, &sat);
		else
			va_finish_tiles(h, acc, v, trow, full, 0, 1, &sat);
	} else {
		for (tx = 0; tx < full; tx++) {
			const int i = tx * SWELL_WAVE_TILE;
			const unsigned f = (unsigned)((trow[tx] | every) & need);

			if (f & T_DIRTY)
				trow[tx] |= va_finish(h + i, acc + i, zero, 0, hmin, hmax, &sat);
			if (f & T_DIRTY_PREV)
				_mm256_storeu_si256((__m256i *)(v + i), zero);
		}
	}
	if (full * SWELL_WAVE_TILE < nx) { /* the row's last tile, narrower than 8 */
		const int i = full * SWELL_WAVE_TILE;
		const unsigned f = (unsigned)((trow[full] | every) & need);
		const __m256i m =
			_mm256_cmpgt_epi32(_mm256_set1_epi32(nx - i), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));

		if (f & T_DIRTY)
			trow[full] |= va_finish(h + i, acc + i, m, 1, hmin, hmax, &sat);
		if (f & T_DIRTY_PREV)
			_mm256_maskstore_epi32(v + i, m, zero);
	}
	w->saturations += !_mm256_testz_si256(sat, sat);
}

/* Four rows from h, acc and v (a row nx apart), their whole tiles (full) each needing h += acc (and
 * v = 0 with clear): tile by tile, T_TOUCHED one test for the four rows. Returns the rows that
 * clamped, a bit each. */
VA_FN uint32_t va_finish_rows4(int32_t *h, const int32_t *acc, int32_t *v, uint8_t *trow, int nx, int full, int clear)
{
	const __m256i hmin = _mm256_set1_epi32(SWELL_HV_MIN), hmax = _mm256_set1_epi32(SWELL_HV_MAX);
	const __m256i zero = _mm256_setzero_si256();
	__m256i sat0 = zero, sat1 = zero, sat2 = zero, sat3 = zero;
	int tx;

	for (tx = 0; tx < full; tx++) {
		const size_t i = (size_t)tx * SWELL_WAVE_TILE;
		const __m256i a0 = _mm256_loadu_si256((const __m256i *)(acc + i));
		const __m256i a1 = _mm256_loadu_si256((const __m256i *)(acc + i + (size_t)nx));
		const __m256i a2 = _mm256_loadu_si256((const __m256i *)(acc + i + 2 * (size_t)nx));
		const __m256i a3 = _mm256_loadu_si256((const __m256i *)(acc + i + 3 * (size_t)nx));
		const __m256i any = _mm256_or_si256(_mm256_or_si256(a0, a1), _mm256_or_si256(a2, a3));

		sat0 = _mm256_or_si256(sat0, va_add_clamp(h + i, a0, hmin, hmax));
		sat1 = _mm256_or_si256(sat1, va_add_clamp(h + i + (size_t)nx, a1, hmin, hmax));
		sat2 = _mm256_or_si256(sat2, va_add_clamp(h + i + 2 * (size_t)nx, a2, hmin, hmax));
		sat3 = _mm256_or_si256(sat3, va_add_clamp(h + i + 3 * (size_t)nx, a3, hmin, hmax));
		if (clear) {
			_mm256_storeu_si256((__m256i *)(v + i), zero);
			_mm256_storeu_si256((__m256i *)(v + i + (size_t)nx), zero);
			_mm256_storeu_si256((__m256i *)(v + i + 2 * (size_t)nx), zero);
			_mm256_storeu_si256((__m256i *)(v + i + 3 * (size_t)nx), zero);
		}
		trow[tx] |= _mm256_testz_si256(any, any) ? 0 : T_TOUCHED;
	}
	return (uint32_t)(!_mm256_testz_si256(sat0, sat0)) | (uint32_t)(!_mm256_testz_si256(sat1, sat1)) << 1 |
		(uint32_t)(!_mm256_testz_si256(sat2, sat2)) << 2 | (uint32_t)(!_mm256_testz_si256(sat3, sat3)) << 3;
}

/* The 8 rows of the band of tiles from row j where every whole tile needs h += acc (and v = 0 with
 * clear): four rows at a time, tile by tile (a row that clamped is counted once, as row by row).
 * The row's last tile, narrower than 8, as its flags say. */
VA_FN void va_finish_band(struct swell_wave *w, int j, int clear, uint8_t need, uint8_t every)
{
	const int nx = w->nx, full = nx / SWELL_WAVE_TILE;
	uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;
	int32_t *h = w->h + (size_t)j * nx, *v = w->v + (size_t)j * nx;
	const int32_t *acc = w->acc + (size_t)j * nx;
	uint32_t rows; /* the rows that clamped, a bit each */
	int r;

	rows = va_finish_rows4(h, acc, v, trow, nx, full, clear);
	rows |= va_finish_rows4(h + 4 * (size_t)nx, acc + 4 * (size_t)nx, v + 4 * (size_t)nx, trow, nx, full, clear)
		<< 4;
	if (full * SWELL_WAVE_TILE < nx) { /* the row's last tile, narrower than 8: row by row */
		const int i = full * SWELL_WAVE_TILE;
		const unsigned f = (unsigned)((trow[full] | every) & need);
		const __m256i m =
			_mm256_cmpgt_epi32(_mm256_set1_epi32(nx - i), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
		const __m256i hmin = _mm256_set1_epi32(SWELL_HV_MIN), hmax = _mm256_set1_epi32(SWELL_HV_MAX);

		for (r = 0; r < SWELL_WAVE_TILE; r++) {
			const size_t a = (size_t)r * nx + (size_t)i;
			__m256i sat = _mm256_setzero_si256();

			if (f & T_DIRTY)
				trow[full] |= va_finish(h + a, acc + a, m, 1, hmin, hmax, &sat);
			if (f & T_DIRTY_PREV)
				_mm256_maskstore_epi32(v + a, m, _mm256_setzero_si256());
			rows |= (uint32_t)(!_mm256_testz_si256(sat, sat)) << r;
		}
	}
	w->saturations += (uint32_t)__builtin_popcount(rows);
}

/* The flags of need that some tile of a band has (*any), and that every whole tile (the first full)
 * has with every added (*all): eight tiles a word. */
VA_FN void va_band_flags(const uint8_t *trow, int tiles, int full, uint8_t need, uint8_t every, unsigned *any,
			 unsigned *all)
{
	const uint64_t ones = 0x0101010101010101u, n8 = need * ones, e8 = every * ones;
	uint64_t a = 0, e = n8, t;
	int tx = 0;

	for (; tx + 8 <= full; tx += 8) {
		memcpy(&t, trow + tx, sizeof(t));
		a |= t;
		e &= t | e8;
	}
	for (; tx < tiles; tx++) {
		a |= trow[tx];
		e &= tx < full ? (uint64_t)(trow[tx] | every) * ones : n8;
	}
	a &= n8; /* the bytes folded into one */
	a |= a >> 32;
	a |= a >> 16;
	a |= a >> 8;
	e &= e >> 32;
	e &= e >> 16;
	e &= e >> 8;
	*any = (unsigned)(a & 0xff);
	*all = (unsigned)(e & need);
}

__attribute__((target("avx2"))) void swell_wave_vel_finish_avx2(struct swell_wave *w, int j0, int j1, uint8_t need)
{
	const uint8_t every = w->sleep ? 0 : (uint8_t)(T_DIRTY | T_DIRTY_PREV);
	const int full = w->nx / SWELL_WAVE_TILE;
	unsigned any = 0, all = 0;
	int j;

	for (j = j0; j < j1; j++) {
		if (j == j0 || j % SWELL_WAVE_TILE == 0) { /* the band's flags: which tiles need what */
			const uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;

			va_band_flags(trow, w->tiles_x, full, need, every, &any, &all);
			/* a calm band of tiles: nothing wrote acc or v in it (the same test as wave.c's) */
			if (w->sleep && j % SWELL_WAVE_TILE == 0 && (j + SWELL_WAVE_TILE <= j1 || j1 == w->ny) &&
			    !any) {
				j += SWELL_WAVE_TILE - 1;
				continue;
			}
		}
		if (all == need && (need & T_DIRTY) && j % SWELL_WAVE_TILE == 0 && j + SWELL_WAVE_TILE <= j1) {
			if (need & T_DIRTY_PREV) /* the whole band */
				va_finish_band(w, j, 1, need, every);
			else
				va_finish_band(w, j, 0, need, every);
			j += SWELL_WAVE_TILE - 1;
		} else if (all == need) {
			va_finish_row(w, j, need, every, 1);
		} else {
			va_finish_row(w, j, need, every, 0);
		}
	}
}

#endif
