/* The velocity form's AVX2 kernel (x86-64 hosts with AVX2, chosen at run time by wave.c): one 8-lane
 * register a tile row, so that a vector is exactly one tile's cells of row j and its "any" flag one
 * VPTEST. The column sums S = h(j-1) + 2 h(j) + h(j+1) of a vector come from three loads; the
 * neighbours' S(i-1) and S(i+1) are the vector's own lanes shifted in from the vectors left and right
 * (VPERM2I128 + VPALIGNR), mirrored at the walls by a lane permutation. x C / 2^32 is taken from
 * VPMULDQ of the even and of the odd lanes (64-bit products, the high halves blended); the damping
 * as floor(4 s q / 2^32) the same way. The last tile of a row may be narrower than 8: masked loads
 * and stores. The sums of s and dh are int32 a lane within a call (at most SWELL_WAVE_VEL_RUN cells a
 * lane, |s| <= 2^27) and int64 after. Same bits as swell_wave_vel_ref (wave_priv.h has the rule),
 * the saturation count included (one a call that clamped). The finishing pass of a row is here too.
 * C = e_eff 2^(F+1) above INT32_MAX (e_eff = 1 undamped at F = 0) goes to the fused kernel. */
#include "wave_priv.h"

#if SWELL_WAVE_AVX2
#include <immintrin.h>

#define VA_FN __attribute__((target("avx2"), always_inline)) static inline

_Static_assert(SWELL_WAVE_VEL_RUN <= 15, "the int32 lane sums hold 15 cells of int28");

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

/* Column sums of 8 columns (or the first r, masked) and the centre row in *c. */
VA_FN __m256i va_colsum(const int32_t *hd, const int32_t *hc, const int32_t *hu, __m256i mask, int masked, __m256i *c)
{
	__m256i d, m;

	if (masked) {
		d = _mm256_maskload_epi32(hd, mask);
		m = _mm256_maskload_epi32(hc, mask);
		*c = m;
		return _mm256_add_epi32(_mm256_add_epi32(d, _mm256_maskload_epi32(hu, mask)), _mm256_add_epi32(m, m));
	}
	d = _mm256_loadu_si256((const __m256i *)hd);
	m = _mm256_loadu_si256((const __m256i *)hc);
	*c = m;
	return _mm256_add_epi32(_mm256_add_epi32(d, _mm256_loadu_si256((const __m256i *)hu)), _mm256_add_epi32(m, m));
}

struct va_acc {
	__m256i sat, tot, tot_h;
};

/* One vector of cells: x from the column sums left, centre and right, the cell, the stores. */
VA_FN int32_t va_vec(const struct va_k *K, struct va_acc *A, __m256i sm, __m256i s0, __m256i sp, __m256i c, int32_t *u,
		     int32_t *acc, __m256i mask, int masked, int damp, int f)
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
	A->sat = _mm256_or_si256(A->sat, clamped);
	A->tot = _mm256_add_epi32(A->tot, s);
	if (f)
		A->tot_h = _mm256_add_epi32(A->tot_h, dh);
	return !_mm256_testz_si256(s, s);
}

/* sum[0] += the lanes of a, sum[1] += those of b, in int64 */
VA_FN void va_hsum2(int64_t sum[2], __m256i a, __m256i b)
{
	const __m256i wa = _mm256_add_epi64(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(a)),
					    _mm256_cvtepi32_epi64(_mm256_extracti128_si256(a, 1)));
	const __m256i wb = _mm256_add_epi64(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(b)),
					    _mm256_cvtepi32_epi64(_mm256_extracti128_si256(b, 1)));
	const __m256i t = _mm256_add_epi64(_mm256_unpacklo_epi64(wa, wb), _mm256_unpackhi_epi64(wa, wb));
	const __m128i r = _mm_add_epi64(_mm256_castsi256_si128(t), _mm256_extracti128_si256(t, 1));

	_mm_storeu_si128((__m128i *)sum, _mm_add_epi64(_mm_loadu_si128((const __m128i *)sum), r));
}

/* A run of awake tiles of row j: vectors of 8 cells, the last one masked when the row's last tile is
 * narrower (it is then at the east wall). */
VA_FN void va_run(struct swell_wave *w, int j, int tx0, int tx1, int damp, int f, int64_t sum[2], int32_t *any)
{
	const int nx = w->nx, i0 = tx0 * SWELL_WAVE_TILE, i1 = tx1 * SWELL_WAVE_TILE < nx ? tx1 * SWELL_WAVE_TILE : nx;
	const int nv = (i1 - i0 + 7) / 8, r = i1 - i0 - 8 * (nv - 1); /* the last vector's width, 1..8 */
	const int32_t *hc = w->h + (size_t)j * nx + i0;
	const int32_t *hd = j > 0 ? hc - nx : hc, *hu = j + 1 < w->ny ? hc + nx : hc;
	int32_t *u = w->u + (size_t)j * nx + i0, *acc = w->acc + (size_t)j * nx + i0;
	const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
	const __m256i mask = _mm256_cmpgt_epi32(_mm256_set1_epi32(r), lane);
	struct va_k K;
	struct va_acc A;
	__m256i s0, c0, sn, cn, sm, sp, t;
	int b;

	K.c = _mm256_set1_epi32((int32_t)((int64_t)w->e_eff << (w->vel_frac + 1)));
	K.q = _mm256_set1_epi32(w->q);
	K.round = _mm256_set1_epi64x((int64_t)1 << 31);
	K.half = _mm256_set1_epi32(f ? 1 << (f - 1) : 0);
	K.zero = _mm256_setzero_si256();
	K.hmin = _mm256_set1_epi32(SWELL_H_MIN);
	K.hmax = _mm256_set1_epi32(SWELL_H_MAX);
	A.sat = A.tot = A.tot_h = _mm256_setzero_si256();

	s0 = va_colsum(hd, hc, hu, mask, nv == 1 && r < 8, &c0);
	/* the column left of the run: its own sum, or the run's first column mirrored at the west wall */
	sm = _mm256_permutevar8x32_epi32(s0, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6));
	if (i0 > 0)
		sm = _mm256_blend_epi32(sm, _mm256_set1_epi32(hd[-1] + hu[-1] + 2 * hc[-1]), 0x01);
	for (b = 0; b + 1 < nv; b++) {
		const int k = 8 * (b + 1);

		if (b + 2 == nv && r < 8)
			sn = va_colsum(hd + k, hc + k, hu + k, mask, 1, &cn);
		else
			sn = va_colsum(hd + k, hc + k, hu + k, mask, 0, &cn);
		t = _mm256_permute2x128_si256(s0, sn, 0x21); /* s0's high half, sn's low half */
		sp = _mm256_alignr_epi8(t, s0, 4);
		any[b] = va_vec(&K, &A, sm, s0, sp, c0, u + 8 * b, acc + 8 * b, mask, 0, damp, f);
		sm = _mm256_alignr_epi8(sn, t, 12);
		s0 = sn;
		c0 = cn;
	}
	/* the last vector: the column right of the run, or the last column mirrored at the east wall */
	sp = _mm256_permutevar8x32_epi32(
		s0, _mm256_min_epi32(_mm256_add_epi32(lane, _mm256_set1_epi32(1)), _mm256_set1_epi32(r - 1)));
	if (i1 < nx) /* then r = 8 */
		sp = _mm256_blend_epi32(sp, _mm256_set1_epi32(hd[i1 - i0] + hu[i1 - i0] + 2 * hc[i1 - i0]), 0x80);
	if (r < 8)
		any[b] = va_vec(&K, &A, sm, s0, sp, c0, u + 8 * b, acc + 8 * b, mask, 1, damp, f);
	else
		any[b] = va_vec(&K, &A, sm, s0, sp, c0, u + 8 * b, acc + 8 * b, mask, 0, damp, f);
	w->saturations += !_mm256_testz_si256(A.sat, A.sat);
	va_hsum2(sum, A.tot, f ? A.tot_h : A.tot);
}

__attribute__((target("avx2"))) void swell_wave_vel_avx2(struct swell_wave *w, int j, int tx0, int tx1, int damp,
							 int64_t sum[2], int32_t *any)
{
	const int64_t c = (int64_t)w->e_eff << (w->vel_frac + 1);

	/* e_eff = 1 at F = 0: C does not fit VPMULDQ's signed operand; damped water has F = 0 (wave.c) */
	if (c > INT32_MAX || (damp && w->vel_frac)) {
		swell_wave_vel_fused(w, j, tx0, tx1, damp, sum, any);
		return;
	}
	if (damp) {
		va_run(w, j, tx0, tx1, 1, 0, sum, any);
		return;
	}
	switch (w->vel_frac) { /* F as an immediate shift */
	case 1:
		va_run(w, j, tx0, tx1, 0, 1, sum, any);
		break;
	case 2:
		va_run(w, j, tx0, tx1, 0, 2, sum, any);
		break;
	case 3:
		va_run(w, j, tx0, tx1, 0, 3, sum, any);
		break;
	case 4:
		va_run(w, j, tx0, tx1, 0, 4, sum, any);
		break;
	default:
		va_run(w, j, tx0, tx1, 0, 0, sum, any);
	}
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

__attribute__((target("avx2"))) void swell_wave_vel_finish_avx2(struct swell_wave *w, int j, uint8_t need)
{
	const int nx = w->nx, full = nx / SWELL_WAVE_TILE;
	const uint8_t every = w->sleep ? 0 : (uint8_t)(T_DIRTY | T_DIRTY_PREV);
	uint8_t *trow = w->tile + (j / SWELL_WAVE_TILE) * w->tiles_x;
	int32_t *h = w->h + (size_t)j * nx, *v = w->v + (size_t)j * nx;
	const int32_t *acc = w->acc + (size_t)j * nx;
	const __m256i hmin = _mm256_set1_epi32(SWELL_HV_MIN), hmax = _mm256_set1_epi32(SWELL_HV_MAX);
	const __m256i zero = _mm256_setzero_si256();
	__m256i sat = zero;
	int tx;

	/* |h| <= 2^26, |acc| <= 2^29 + 8 2^27: h + acc does not overflow */
	for (tx = 0; tx < full; tx++) {
		const int i = tx * SWELL_WAVE_TILE;
		const unsigned f = (unsigned)((trow[tx] | every) & need);

		if (f & T_DIRTY)
			trow[tx] |= va_finish(h + i, acc + i, zero, 0, hmin, hmax, &sat);
		if (f & T_DIRTY_PREV)
			_mm256_storeu_si256((__m256i *)(v + i), zero);
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

#endif
