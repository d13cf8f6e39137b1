/* The edge-flux form's AVX2 kernel (x86-64): one 8-lane register a tile row and edge kind; ragged
 * tiles and the top row go to the fused kernel. Same bits as ef32_kernel_ref. */
#include "ef32_priv.h"

#if SWELL_WAVE_AVX2
#include <immintrin.h>

#define AVX2_FN __attribute__((target("avx2"))) static

/* flow_ref on 8 lanes. The 64-bit products of even and odd lanes are formed apart; the low 32 bits
 * of a product shifted right by 30 are the same whether the shift is arithmetic or logical, and
 * AVX2 has only the logical one for 64-bit lanes. codd holds c in the odd lanes' low halves. */
AVX2_FN __m256i mulshift30(__m256i a, __m256i b, __m256i bodd, __m256i round)
{
	__m256i pe = _mm256_mul_epi32(a, b);
	__m256i po = _mm256_mul_epi32(_mm256_srli_epi64(a, 32), bodd);

	pe = _mm256_srli_epi64(_mm256_add_epi64(pe, round), 30);
	po = _mm256_slli_epi64(_mm256_srli_epi64(_mm256_add_epi64(po, round), 30), 32);
	return _mm256_blend_epi32(pe, po, 0xAA);
}

struct avx2_k {
	__m256i q, qodd, half, zero, hmin, hmax;
};

AVX2_FN __m256i flow8(const struct avx2_k *K, __m256i f, __m256i dh, __m256i c, int damp, __m256i *sat)
{
	__m256i s = _mm256_add_epi32(f, mulshift30(dh, c, _mm256_srli_epi64(c, 32), K->half));
	__m256i t;

	if (damp)
		s = _mm256_sub_epi32(mulshift30(s, K->q, K->qodd, K->zero), _mm256_srai_epi32(s, 31));
	t = _mm256_min_epi32(_mm256_max_epi32(s, K->hmin), K->hmax);
	*sat = _mm256_or_si256(*sat, _mm256_xor_si256(s, t));
	return t;
}

/* A whole tile row (i1 = i0 + 8) that is not the top row. Lanes whose edge does not exist (E and NE
 * on the east wall, NW on the west wall) get coefficient 0: their flow stays 0, and their neighbour
 * loads are replaced by in-row copies so that nothing outside the field is read. */
AVX2_FN int32_t segment_avx2_tile(struct ef32 *w, int j, int i0, int damp)
{
	const int nx = w->nx, west = i0 == 0, east = i0 + 8 == nx;
	const int32_t *h = w->h + j * nx + i0, *hu = h + nx;
	int32_t *v = w->acc + j * nx + i0, *vu = v + nx;
	int32_t *fb = flows_at(w, i0, j);
	const int32_t ce0 = (j == 0) ? w->c_wall : w->c_1;
	const __m256i up1 = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7);
	const __m256i dn1 = _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6);
	struct avx2_k K;
	__m256i H, Hr, HU, HUr, HUl, ce, cn, cne, cnw, fe, fn, fne, fnw, sat, own, upv, t;
	int32_t last_fe, last_fne;

	K.q = _mm256_set1_epi32(w->q);
	K.qodd = _mm256_srli_epi64(K.q, 32);
	K.half = _mm256_set1_epi64x((int64_t)1 << 29);
	K.zero = _mm256_setzero_si256();
	K.hmin = _mm256_set1_epi32(SWELL_H_MIN);
	K.hmax = _mm256_set1_epi32(SWELL_H_MAX);
	sat = K.zero;

	H = _mm256_loadu_si256((const __m256i *)h);
	HU = _mm256_loadu_si256((const __m256i *)hu);
	Hr = east ? _mm256_permutevar8x32_epi32(H, up1) : _mm256_loadu_si256((const __m256i *)(h + 1));
	HUr = east ? _mm256_permutevar8x32_epi32(HU, up1) : _mm256_loadu_si256((const __m256i *)(hu + 1));
	HUl = west ? _mm256_permutevar8x32_epi32(HU, dn1) : _mm256_loadu_si256((const __m256i *)(hu - 1));

	ce = _mm256_set1_epi32(ce0);
	cn = _mm256_set1_epi32(w->c_1);
	cne = cnw = _mm256_set1_epi32(w->c_half);
	if (west) {
		cn = _mm256_blend_epi32(cn, _mm256_set1_epi32(w->c_wall), 0x01);
		cnw = _mm256_blend_epi32(cnw, K.zero, 0x01);
	}
	if (east) {
		cn = _mm256_blend_epi32(cn, _mm256_set1_epi32(w->c_wall), 0x80);
		ce = _mm256_blend_epi32(ce, K.zero, 0x80);
		cne = _mm256_blend_epi32(cne, K.zero, 0x80);
	}

	fe = flow8(&K, _mm256_loadu_si256((const __m256i *)(fb + FE)), _mm256_sub_epi32(Hr, H), ce, damp, &sat);
	fn = flow8(&K, _mm256_loadu_si256((const __m256i *)(fb + FN)), _mm256_sub_epi32(HU, H), cn, damp, &sat);
	fne = flow8(&K, _mm256_loadu_si256((const __m256i *)(fb + FNE)), _mm256_sub_epi32(HUr, H), cne, damp, &sat);
	fnw = flow8(&K, _mm256_loadu_si256((const __m256i *)(fb + FNW)), _mm256_sub_epi32(HUl, H), cnw, damp, &sat);
	_mm256_storeu_si256((__m256i *)(fb + FE), fe);
	_mm256_storeu_si256((__m256i *)(fb + FN), fn);
	_mm256_storeu_si256((__m256i *)(fb + FNE), fne);
	_mm256_storeu_si256((__m256i *)(fb + FNW), fnw);

	/* own row: + all four, - the E flow of the west neighbour inside the tile */
	own = _mm256_add_epi32(_mm256_add_epi32(fe, fn), _mm256_add_epi32(fne, fnw));
	t = _mm256_blend_epi32(_mm256_permutevar8x32_epi32(fe, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6)), K.zero,
			       0x01);
	own = _mm256_sub_epi32(own, t);
	_mm256_storeu_si256((__m256i *)v, _mm256_add_epi32(_mm256_loadu_si256((const __m256i *)v), own));
	/* the row above: - N, - NE from the left, - NW from the right, inside the tile */
	upv = _mm256_add_epi32(fn, _mm256_blend_epi32(_mm256_permutevar8x32_epi32(fne, dn1), K.zero, 0x01));
	upv = _mm256_add_epi32(upv, _mm256_blend_epi32(_mm256_permutevar8x32_epi32(fnw, up1), K.zero, 0x80));
	_mm256_storeu_si256((__m256i *)vu, _mm256_sub_epi32(_mm256_loadu_si256((const __m256i *)vu), upv));
	/* across the tile's ends */
	last_fe = _mm256_extract_epi32(fe, 7);
	last_fne = _mm256_extract_epi32(fne, 7);
	if (!east) {
		v[8] -= last_fe;
		vu[8] -= last_fne;
	}
	if (!west)
		vu[-1] -= _mm256_extract_epi32(fnw, 0);
	if (!_mm256_testz_si256(sat, sat))
		w->saturations++;
	t = _mm256_or_si256(_mm256_or_si256(fe, fn), _mm256_or_si256(fne, fnw));
	return !_mm256_testz_si256(t, t);
}

int32_t ef32_kernel_avx2(struct ef32 *w, int j, int i0, int i1, int damp)
{
	if (i1 - i0 != 8 || j + 1 >= w->ny) /* a ragged tile or the top row */
		return ef32_kernel_fused(w, j, i0, i1, damp);
	return segment_avx2_tile(w, j, i0, damp);
}
#endif
