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
 * heights' update one row behind (wave.c's update_rows) goes along in the same pass: row j - 1's
 * heights are loaded for row j's stencil anyway, and each vector is written once the loads past it
 * are done (struct va_fold); on its own (swell_wave_vel_update_avx2) only where the kernel does not
 * run (a band asleep, the last row at the finish). C = e_eff 2^(F+1) above
 * INT32_MAX (e_eff = 1 undamped at F = 0) is left to the fused kernel (wave.c). */
#include "wave_priv.h"

#if SWELL_WAVE_AVX2
#include <immintrin.h>
#include <string.h>

#define VA_FN __attribute__((target("avx2"), always_inline)) static inline

/* The int32 lane sums hold a run of two rows: 16 cells of int28 sum to -2^31 .. 2^31 - 16. */
_Static_assert(2 * SWELL_WAVE_VEL_RUN <= 16, "the int32 lane sums hold 16 cells of int28");

struct va_k {
	__m256i c, q, round, half, hmin, hmax, hvmin, hvmax, zero;
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

/* A cell's height change dh(s): nearest, ties away from zero, (s + 2^(F-1) - (s < 0)) >> F; at F = 0, s */
VA_FN __m256i va_dh(const struct va_k *K, __m256i s, int f)
{
	return f ? _mm256_srai_epi32(_mm256_add_epi32(_mm256_add_epi32(s, K->half), _mm256_cmpgt_epi32(K->zero, s)), f)
		 : s;
}

/* The running sums: s and dh as int32 lanes within a run of at most SWELL_WAVE_VEL_RUN awake tiles
 * (of one row, or of two rows side by side), int64 lanes after. */
struct va_acc {
	__m256i tot, tot_h, tot64, tot_h64;
};

/* One vector of cells: x from the column sums left, centre and right, the cell, the stores, the
 * lanes that clamped into *sat, the new dh into *dho (zero in the lanes past a masked vector's);
 * returns non-zero when some new s is non-zero. */
VA_FN int va_vec(const struct va_k *K, struct va_acc *A, __m256i *sat, __m256i *dho, __m256i sm, __m256i s0, __m256i sp,
		 __m256i c, int32_t *u, __m256i mask, int masked, int damp, int f)
{
	const __m256i x = _mm256_sub_epi32(_mm256_add_epi32(_mm256_add_epi32(sm, sp), _mm256_add_epi32(s0, s0)),
					   _mm256_slli_epi32(c, 4));
	__m256i uo, s, dh, clamped;

	uo = masked ? _mm256_maskload_epi32(u, mask) : _mm256_loadu_si256((const __m256i *)u);
	s = va_cell(K, x, uo, damp, &clamped);
	dh = va_dh(K, s, f);
	if (masked) {
		_mm256_maskstore_epi32(u, mask, s);
		s = _mm256_and_si256(s, mask);
		dh = _mm256_and_si256(dh, mask);
		clamped = _mm256_and_si256(clamped, mask);
	} else {
		_mm256_storeu_si256((__m256i *)u, s);
	}
	*sat = _mm256_or_si256(*sat, clamped);
	*dho = dh;
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
		   __m256i sp, int32_t *u, __m256i mask, int masked, int awake, int damp, int f, __m256i *dh)
{
	if (!awake && (trow[b] & T_SLEEPING)) {
		*dh = K->zero;
		n->skipped++;
		if (P->run) {
			n->sat += va_sat_end(P);
			va_widen_sums(A, f);
			P->run = 0;
		}
		return;
	}
	if (va_vec(K, A, &P->sat, dh, P->sm, P->s0, sp, P->c0, u + 8 * b, mask, masked, damp, f))
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
		   __m256i sn, __m256i cn, int32_t *u, __m256i mask, int awake, int damp, int f, __m256i *dh)
{
	const __m256i t = _mm256_permute2x128_si256(P->s0, sn, 0x21); /* s0's high half, sn's low half */

	va_tile(trow, b, K, A, n, P, _mm256_alignr_epi8(t, P->s0, 4), u, mask, 0, awake, damp, f, dh);
	P->sm = _mm256_alignr_epi8(sn, t, 12);
	P->s0 = sn;
	P->c0 = cn;
}

/* The column sums of vector b of rows j .. j + q - 1 (q = 1 or 2; rows[] holds rows j - 1 .. j + q,
 * mirrored at the walls), each row's from three of the q + 2 loads: into sn[], the centre rows into
 * cn[], row j - 1's heights into *ha; the first r lanes only when masked. */
VA_FN void va_colsums(const int32_t *const *rows, int q, int i, __m256i mask, int masked, __m256i *sn, __m256i *cn,
		      __m256i *ha)
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
	*ha = l[0];
}

/* The heights one row behind, in the pass of rows j .. j + q - 1: row j - 1 (unless done already) from
 * its h(n), loaded for the stencil anyway, and its u(n+1), stored by the pass before; in a two-row
 * pass row j too, from its h(n) and new dh in registers. Row j + q - 1 is left to the next pass (or
 * the driver), as row j + q reads it. Vector b is written after the loads of vector b + 1: a pass
 * loads each vector of its rows once, and the stencil's neighbour columns come from the sums it
 * carries, so nothing reads h(n) of vector b after that. */
struct va_fold {
	int32_t *h; /* row j - 1's heights, NULL when it is not to be updated */
	const int32_t *u; /* row j - 1's u(n+1) */
	const uint8_t *ut; /* the tile flags of row j - 1's band */
	__m256i ha, sat_a, sat_b; /* row j - 1's h(n) of vector b; the lanes that clamped in rows j - 1, j */
};

/* h = clamp27(hv + dh) of one vector (hv its h(n)); the lanes that clamped into *sat */
VA_FN void va_put(const struct va_k *K, int32_t *h, __m256i hv, __m256i dh, __m256i mask, int masked, __m256i *sat)
{
	const __m256i x = _mm256_add_epi32(hv, dh); /* |h| <= 2^26, |dh| <= 2^27: no overflow */
	const __m256i t = _mm256_min_epi32(_mm256_max_epi32(x, K->hvmin), K->hvmax);

	if (masked)
		_mm256_maskstore_epi32(h, mask, t);
	else
		_mm256_storeu_si256((__m256i *)h, t);
	*sat = _mm256_or_si256(*sat, _mm256_xor_si256(x, t));
}

/* Vector b of the rows one behind (struct va_fold); c0 and dh: row j's h(n) and new dh there (q = 2).
 * Row j - 1's tiles are those with T_NONZERO (update_row in wave.c) where some tile of the band sleeps;
 * in an awake band every tile (elsewhere u(n+1) is zero and h within int27: h stays as it is). */
VA_FN void va_fold_vec(const struct va_k *K, struct va_fold *F, int b, int q, int awake, __m256i c0, __m256i dh,
		       int32_t *hj, __m256i mask, int masked, int f)
{
	if (F->h && (awake || (F->ut[b] & T_NONZERO))) {
		const int32_t *u = F->u + 8 * b;
		const __m256i uo = masked ? _mm256_maskload_epi32(u, mask) : _mm256_loadu_si256((const __m256i *)u);

		va_put(K, F->h + 8 * b, F->ha, va_dh(K, uo, f), mask, masked, &F->sat_a);
	}
	if (q == 2)
		va_put(K, hj + 8 * b, c0, dh, mask, masked, &F->sat_b);
}

/* Rows j .. j + q - 1 of one band, every tile: vectors of 8 cells (a tile's row each) from the west
 * wall to the east wall, the column sums carried from one vector to the next, the last vector masked
 * when the row's last tile is narrower. A sleeping tile is skipped (its column sums still feed its
 * neighbours). The driver's bookkeeping is here too, as step_row_vel in wave.c does it for the
 * other kernels: T_NONZERO where a tile's new s is non-zero, the tiles skipped, and the saturation
 * count of the reference's calls (runs of up to SWELL_WAVE_VEL_RUN awake tiles, split at sleeping
 * tiles: one a run that clamped). awake: no tile of the band sleeps, so the runs are the tiles
 * [8 k, 8 k + 8) and their bookkeeping leaves the loop over the vectors; then two rows (q = 2) go
 * side by side, sharing their loads of h and the loop. The heights one row behind go along (struct
 * va_fold: row j - 1 when up, and row j when q = 2), a row that clamped counted once. */
VA_FN void va_rows_pass(struct swell_wave *w, int j, int q, int awake, int up, uint8_t *trow, const struct va_k *K,
			struct va_acc *A, struct va_count *n, int damp, int f)
{
	const int nx = w->nx, nv = (nx + 7) / 8, r = nx - 8 * (nv - 1); /* the last vector's width, 1..8 */
	int32_t *hj = w->h + (size_t)j * nx;
	const int32_t *rows[4];
	int32_t *u = w->u + (size_t)j * nx;
	const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
	const __m256i mask = _mm256_cmpgt_epi32(_mm256_set1_epi32(r), lane);
	struct va_pipe P[2];
	struct va_fold F;
	__m256i sn[2], cn[2], dh[2], c0, han;
	int b = 0, k1, k;

	rows[0] = j > 0 ? hj - nx : hj;
#pragma GCC unroll 4
	for (k = 1; k <= q; k++)
		rows[k] = hj + (size_t)(k - 1) * nx;
	rows[q + 1] = j + q < w->ny ? hj + (size_t)q * nx : rows[q];
	F.h = up && j > 0 ? hj - nx : NULL;
	F.u = u - (F.h ? nx : 0);
	F.ut = w->tile + (size_t)((j - (F.h ? 1 : 0)) / SWELL_WAVE_TILE) * w->tiles_x;
	F.sat_a = F.sat_b = _mm256_setzero_si256();
	va_colsums(rows, q, 0, mask, nv == 1 && r < 8, sn, cn, &F.ha);
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
		for (; b < k1 && b < nv - 1; b++) { /* the last but one's next vector may be narrower */
			if (b == nv - 2 && r < 8)
				va_colsums(rows, q, 8 * (b + 1), mask, 1, sn, cn, &han);
			else
				va_colsums(rows, q, 8 * (b + 1), mask, 0, sn, cn, &han);
			c0 = P[0].c0;
#pragma GCC unroll 4
			for (k = 0; k < q; k++)
				va_step(trow, b, K, A, n, &P[k], sn[k], cn[k], u + (size_t)k * nx, mask, awake, damp, f,
					&dh[k]);
			va_fold_vec(K, &F, b, q, awake, c0, dh[0], hj, mask, 0, f);
			F.ha = han;
		}
		if (b < k1) { /* the last: the column right of it is its last column mirrored at the east wall */
			const __m256i east = _mm256_min_epi32(_mm256_add_epi32(lane, _mm256_set1_epi32(1)),
							      _mm256_set1_epi32(r - 1));

			c0 = P[0].c0;
#pragma GCC unroll 4
			for (k = 0; k < q; k++) {
				sn[k] = _mm256_permutevar8x32_epi32(P[k].s0, east);
				if (r < 8)
					va_tile(trow, b, K, A, n, &P[k], sn[k], u + (size_t)k * nx, mask, 1, awake,
						damp, f, &dh[k]);
				else
					va_tile(trow, b, K, A, n, &P[k], sn[k], u + (size_t)k * nx, mask, 0, awake,
						damp, f, &dh[k]);
			}
			if (r < 8)
				va_fold_vec(K, &F, b, q, awake, c0, dh[0], hj, mask, 1, f);
			else
				va_fold_vec(K, &F, b, q, awake, c0, dh[0], hj, mask, 0, f);
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
	if (F.h)
		n->sat += !_mm256_testz_si256(F.sat_a, F.sat_a);
	if (q == 2)
		n->sat += !_mm256_testz_si256(F.sat_b, F.sat_b);
}

/* Rows [j0, j1) of one band of tiles (flags trow), and the heights of rows [done_row, j1 - 1) one row
 * behind (done_row is j0 - 1, or 0 at j0 = 0): done_row becomes j1 - 1 */
VA_FN void va_rows(struct swell_wave *w, int j0, int j1, uint8_t *trow, int damp, int f)
{
	struct va_k K;
	struct va_acc A;
	struct va_count n = { 0, 0 };
	int64_t tot;
	/* a band none of whose tiles sleeps (or tiles do not sleep) runs without the tests */
	const int awake = !w->sleep || !swell_tiles_row_any(trow, w->tiles_x, T_SLEEPING, 0);
	int j;

	K.c = _mm256_set1_epi32((int32_t)((int64_t)w->e_eff << (w->vel_frac + 1)));
	K.q = _mm256_set1_epi32(w->q);
	K.round = _mm256_set1_epi64x((int64_t)1 << 31);
	K.half = _mm256_set1_epi32(f ? 1 << (f - 1) : 0);
	K.zero = _mm256_setzero_si256();
	K.hmin = _mm256_set1_epi32(SWELL_H_MIN);
	K.hmax = _mm256_set1_epi32(SWELL_H_MAX);
	K.hvmin = _mm256_set1_epi32(SWELL_HV_MIN);
	K.hvmax = _mm256_set1_epi32(SWELL_HV_MAX);
	A.tot = A.tot_h = A.tot64 = A.tot_h64 = _mm256_setzero_si256();
	/* row j0 - 1 one behind unless done (at j0 = 0 there is none); every later row is this call's */
	if (awake) {
		for (j = j0; j + 1 < j1; j += 2) /* two rows a pass */
			va_rows_pass(w, j, 2, 1, j > w->done_row, trow, &K, &A, &n, damp, f);
		if (j < j1)
			va_rows_pass(w, j, 1, 1, j > w->done_row, trow, &K, &A, &n, damp, f);
	} else {
		for (j = j0; j < j1; j++)
			va_rows_pass(w, j, 1, 0, j > w->done_row, trow, &K, &A, &n, damp, f);
	}
	w->done_row = (uint16_t)(j1 - 1);
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

/* h = clamp27(h + dh(u)) of one vector of cells (m: its lanes, or all); returns the lanes that clamped */
VA_FN __m256i va_update(int32_t *h, const int32_t *u, __m256i m, int masked, int f)
{
	const __m256i hmin = _mm256_set1_epi32(SWELL_HV_MIN), hmax = _mm256_set1_epi32(SWELL_HV_MAX);
	const __m256i uo = masked ? _mm256_maskload_epi32(u, m) : _mm256_loadu_si256((const __m256i *)u);
	/* nearest, ties away from zero: (u + 2^(F-1) - (u < 0)) >> F; at F = 0, u */
	const __m256i dh = f
		? _mm256_srai_epi32(_mm256_add_epi32(_mm256_add_epi32(uo, _mm256_set1_epi32(f ? 1 << (f - 1) : 0)),
						     _mm256_cmpgt_epi32(_mm256_setzero_si256(), uo)),
				    f)
		: uo;
	/* |h| <= 2^26, |dh| <= 2^27: no overflow */
	const __m256i x = _mm256_add_epi32(masked ? _mm256_maskload_epi32(h, m) : _mm256_loadu_si256((__m256i *)h), dh);
	const __m256i t = _mm256_min_epi32(_mm256_max_epi32(x, hmin), hmax);

	if (masked)
		_mm256_maskstore_epi32(h, m, t);
	else
		_mm256_storeu_si256((__m256i *)h, t);
	return _mm256_xor_si256(x, t);
}

/* Rows [j0, j1) of the height update, F as an immediate: the tiles whose momentum moved (T_NONZERO),
 * a band with none skipped whole; a row that clamped counted once (update_row in wave.c). */
VA_FN void va_update_rows(struct swell_wave *w, int j0, int j1, int f)
{
	const int nx = w->nx, full = nx / SWELL_WAVE_TILE;
	const __m256i m = _mm256_cmpgt_epi32(_mm256_set1_epi32(nx - full * SWELL_WAVE_TILE),
					     _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
	int j, tx;

	for (j = j0; j < j1; j++) {
		const uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;
		int32_t *h = w->h + (size_t)j * nx;
		const int32_t *u = w->u + (size_t)j * nx;
		__m256i sat = _mm256_setzero_si256();

		if (!swell_tiles_row_any(trow, w->tiles_x, T_NONZERO, 0)) { /* nothing moved in this band yet */
			j = (j / SWELL_WAVE_TILE + 1) * SWELL_WAVE_TILE - 1;
			continue;
		}
		for (tx = 0; tx < full; tx++)
			if (trow[tx] & T_NONZERO)
				sat = _mm256_or_si256(sat, va_update(h + 8 * tx, u + 8 * tx, m, 0, f));
		if (full < w->tiles_x && (trow[full] & T_NONZERO))
			sat = _mm256_or_si256(sat, va_update(h + 8 * full, u + 8 * full, m, 1, f));
		w->saturations += !_mm256_testz_si256(sat, sat);
	}
}

__attribute__((target("avx2"))) void swell_wave_vel_update_avx2(struct swell_wave *w, int j0, int j1)
{
	switch (w->vel_frac) { /* F as an immediate shift */
	case 1:
		va_update_rows(w, j0, j1, 1);
		break;
	case 2:
		va_update_rows(w, j0, j1, 2);
		break;
	case 3:
		va_update_rows(w, j0, j1, 3);
		break;
	case 4:
		va_update_rows(w, j0, j1, 4);
		break;
	default:
		va_update_rows(w, j0, j1, 0);
	}
}

#endif
