/* Fixed-point arithmetic for swell: formats named in the type, saturation and rounding in the name.
 *
 * Formats
 *   q30_t   Q1.30 in int32: value = raw / 2^30, range [-2, 2). Solver coefficients (e, t, 1-t).
 *   q16_t   Q15.16 in int32: value = raw / 2^16, range [-32768, 32768).
 *
 * Rounding, stated once and used everywhere:
 *   _rn  round to nearest, ties toward +infinity ((p + half) >> n, an arithmetic shift).
 *   _rz  round toward zero (truncation of the magnitude): |result| <= |exact|.
 *   _ra  round away from zero: |result| >= |exact|.
 * Every function that can overflow saturates to the int32 range instead of wrapping.
 * Right shifts of negative values are arithmetic: GCC and Clang define it so on every target we build
 * for, and SWELL_ASR_CHECK below refuses to compile anywhere it is not. */
#ifndef SWELL_FIXED_H
#define SWELL_FIXED_H

#include <stdint.h>

typedef int32_t q30_t;
typedef int32_t q16_t;

#define SWELL_Q30_ONE ((q30_t)1 << 30)
#define SWELL_Q16_ONE ((q16_t)1 << 16)

/* Compile-time check that >> on a negative signed value is arithmetic. */
typedef char swell_asr_check[((-8 >> 1) == -4 && ((int64_t)-8 >> 1) == -4) ? 1 : -1];

/* x / 2^n (n >= 1) rounded to nearest, ties toward +inf, without a 64-bit division (a library call on
 * the Cortex-M4). >> of a negative int64 is arithmetic on every compiler this project supports (GCC,
 * Clang), so it floors. */
static inline int64_t swell_shr_rn(int64_t x, int n)
{
	return (x + ((int64_t)1 << (n - 1))) >> n;
}

static inline int32_t swell_sat_i64(int64_t x)
{
	if (x > INT32_MAX)
		return INT32_MAX;
	if (x < INT32_MIN)
		return INT32_MIN;
	return (int32_t)x;
}

static inline int32_t swell_sat_add(int32_t a, int32_t b)
{
	return swell_sat_i64((int64_t)a + b);
}

static inline int32_t swell_sat_sub(int32_t a, int32_t b)
{
	return swell_sat_i64((int64_t)a - b);
}

/* Clamp x into [lo, hi]. */
static inline int32_t swell_clamp(int32_t x, int32_t lo, int32_t hi)
{
	return x < lo ? lo : (x > hi ? hi : x);
}

/* x * c, c in Q1.30, rounded to nearest (ties toward +inf), saturated. */
static inline int32_t swell_mul_q30_rn(int32_t x, q30_t c)
{
	return swell_sat_i64(((int64_t)x * c + ((int64_t)1 << 29)) >> 30);
}

/* x * c, c in Q1.30, rounded toward zero, saturated. For |c| <= 1 the result never grows |x|. */
static inline int32_t swell_mul_q30_rz(int32_t x, q30_t c)
{
	int64_t p = (int64_t)x * c;
	int64_t bias = (p < 0) ? (((int64_t)1 << 30) - 1) : 0;
	return swell_sat_i64((p + bias) >> 30);
}

/* x * c, c in Q1.30, rounded away from zero, saturated. */
static inline int32_t swell_mul_q30_ra(int32_t x, q30_t c)
{
	int64_t p = (int64_t)x * c;
	int64_t bias = (p > 0) ? (((int64_t)1 << 30) - 1) : 0;
	return swell_sat_i64((p + bias) >> 30);
}

/* x * c, c in Q15.16, rounded to nearest (ties toward +inf), saturated. */
static inline int32_t swell_mul_q16_rn(int32_t x, q16_t c)
{
	return swell_sat_i64(((int64_t)x * c + ((int64_t)1 << 15)) >> 16);
}

/* (a * b) / c for unsigned 64-bit operands with a 128-bit intermediate, rounded to nearest
 * (ties up). Returns 0 and leaves *out untouched when c == 0 or the quotient exceeds 64 bits.
 * Slow (bit-serial): for parameter conversion, never for a hot path. */
int swell_muldiv_u64(uint64_t a, uint64_t b, uint64_t c, uint64_t *out);

#endif
