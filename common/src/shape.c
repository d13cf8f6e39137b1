/* Integer exp and cos by range reduction and Horner polynomials in Q1.30 (int64 products). */
#include "swell/shape.h"

#include "swell/wave.h"

#define ONE ((int64_t)1 << 30)
#define LN2_Q30 ((int64_t)744261118) /* ln 2 * 2^30 */
#define LOG2E_Q16 ((int64_t)94548) /* log2(e) * 2^16 */
#define PI_Q30 ((int64_t)3373259426) /* pi * 2^30 */

static int64_t mul30(int64_t a, int64_t b)
{
	return (a * b + (ONE >> 1)) >> 30;
}

q30_t swell_exp_neg_q16(q16_t x)
{
	int64_t y, z, p;
	int k, shift;

	if (x <= 0)
		return (q30_t)ONE;
	if (x >= 32 * SWELL_Q16_ONE)
		return 0;
	/* exp(-x) = 2^-(x log2 e) = 2^-shift * 2^-u, u in [0, 1); 2^-u = exp(-u ln 2) by Taylor to
	 * degree 9 (z <= 0.694: remainder below 2e-9). */
	y = (int64_t)x * LOG2E_Q16; /* Q32 */
	shift = (int)(y >> 32);
	z = mul30((y & 0xffffffffLL) >> 2, LN2_Q30); /* u in Q30, times ln 2 */
	p = ONE;
	for (k = 9; k >= 1; k--)
		p = ONE - mul30(z, p) / k;
	return (q30_t)(p >> shift);
}

q30_t swell_cos_pi_frac(int64_t num, int64_t den)
{
	int64_t q, r, x, x2, p;
	int k, neg = 0;

	if (den <= 0)
		return 0;
	/* num = q den + r, 0 <= r < den (2 den may not fit int64) */
	q = num / den;
	r = num % den;
	if (r < 0) {
		r += den;
		q--; /* den >= 2 here: no overflow */
	}
	if ((uint64_t)q & 1u) /* cos(pi + a) = cos(pi - a): fold [pi, 2pi) onto [0, pi] */
		r = den - r;
	if (r > den - r) { /* cos(pi - a) = -cos(a) */
		r = den - r;
		neg = 1;
	}
	/* r <= den / 2; pi r overflows int64 above 2^31.35: drop low bits of both (2^-31 of the angle) */
	while (r > INT64_MAX / PI_Q30) {
		r >>= 1;
		den >>= 1;
	}
	x = PI_Q30 * r / den; /* in [0, pi/2] */
	x2 = mul30(x, x);
	/* cos x = 1 - x^2/2! (1 - x^2/(3*4) (1 - ...)) to degree 14: remainder below 1e-9 */
	p = ONE;
	for (k = 7; k >= 1; k--)
		p = ONE - mul30(x2, p) / ((2 * k - 1) * (2 * k));
	return (q30_t)(neg ? -p : p);
}

static int32_t add_sat_h(int32_t h, int64_t d)
{
	int64_t s = (int64_t)h + d;

	if (s > SWELL_H_MAX)
		return SWELL_H_MAX;
	if (s < -SWELL_H_MAX)
		return -SWELL_H_MAX;
	return (int32_t)s;
}

void swell_shape_gauss(int32_t *h, uint16_t nx, uint16_t ny, q16_t x_cells, q16_t y_cells, q16_t sigma_cells,
		       int32_t amp_lsb)
{
	int64_t two_s2;
	int i, j;

	if (!h || sigma_cells < SWELL_Q16_ONE / 2)
		return;
	two_s2 = (2 * (int64_t)sigma_cells * sigma_cells) >> 16; /* Q16 */
	for (j = 0; j < ny; j++) {
		for (i = 0; i < nx; i++) {
			int64_t dx = ((int64_t)i << 16) - x_cells, dy = ((int64_t)j << 16) - y_cells;
			int64_t r2 = dx * dx + dy * dy; /* Q32 */
			int64_t arg = r2 / two_s2; /* Q16 */
			q30_t g;

			if (arg >= 32 * SWELL_Q16_ONE)
				continue;
			g = swell_exp_neg_q16((q16_t)arg);
			h[j * nx + i] = add_sat_h(h[j * nx + i], mul30(amp_lsb, g));
		}
	}
}

void swell_shape_seiche(int32_t *h, uint16_t nx, uint16_t ny, uint16_t m, uint16_t n, int32_t amp_lsb)
{
	int i, j;

	if (!h || !nx || !ny)
		return;
	for (j = 0; j < ny; j++) {
		int64_t cy = swell_cos_pi_frac((int64_t)n * (2 * j + 1), 2 * (int64_t)ny);

		for (i = 0; i < nx; i++) {
			int64_t cx = swell_cos_pi_frac((int64_t)m * (2 * i + 1), 2 * (int64_t)nx);

			h[j * nx + i] = add_sat_h(h[j * nx + i], mul30(amp_lsb, mul30(cx, cy)));
		}
	}
}
