/* The integer cos of shape.h against an exact model over the whole int64 range of its arguments. */
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>

extern "C" {
#include "swell/shape.h"
}

namespace {

/* cos(pi num / den), the argument reduced exactly in 128 bits, then in long double */
double cos_model(int64_t num, int64_t den)
{
	__int128 r = (__int128)num % (2 * (__int128)den);
	if (r < 0)
		r += 2 * (__int128)den;
	return (double)cosl(3.141592653589793238462643383279502884L * ((long double)r / (long double)den));
}

} // namespace

TEST_CASE("integer cos(pi num / den) is within 1e-8 for any num and den > 0, int64 extremes included", "[shape]")
{
	const int64_t big[][2] = {
		{(int64_t)1 << 38, (int64_t)1 << 40}, /* pi / 4 */
		{INT64_MAX, INT64_MAX}, /* pi */
		{INT64_MIN, INT64_MAX}, /* -pi - pi / (2^63 - 1) */
		{((int64_t)1 << 62) + 1, (int64_t)1 << 62},
		{INT64_MAX / 3, INT64_MAX},
		{INT64_MIN, 3},
		{-1, INT64_MAX},
	};
	for (const auto &c : big) {
		const double got = (double)swell_cos_pi_frac(c[0], c[1]) / SWELL_Q30_ONE, want = cos_model(c[0], c[1]);
		INFO("cos(pi " << c[0] << " / " << c[1] << "): " << got << " against " << want);
		CHECK(std::fabs(got - want) < 1e-8);
	}
	std::mt19937_64 rng(42);
	double worst = 0;
	for (int k = 0; k < 200000; k++) {
		const int64_t num = (int64_t)(rng() >> (rng() % 64));
		int64_t den = (int64_t)(rng() >> (1 + rng() % 63));
		if (den <= 0)
			den = 1;
		const int64_t n = (k & 1) ? -num : num;
		const double got = (double)swell_cos_pi_frac(n, den) / SWELL_Q30_ONE, want = cos_model(n, den);
		INFO("cos(pi " << n << " / " << den << "): " << got << " against " << want);
		REQUIRE(std::fabs(got - want) < 1e-8);
		worst = std::max(worst, std::fabs(got - want));
	}
	WARN("worst error of 200000 random (num, den): " << worst);
	CHECK(swell_cos_pi_frac(1, 0) == 0);
	CHECK(swell_cos_pi_frac(1, -5) == 0);
}

TEST_CASE("integer exp and cos match the exact functions", "[shape]")
{
	double worst_exp = 0, worst_cos = 0;
	for (int k = 0; k < 32 * 64; k++) {
		q16_t x = (q16_t)(k * (SWELL_Q16_ONE / 64));
		worst_exp =
			std::max(worst_exp,
				 std::fabs((double)swell_exp_neg_q16(x) / SWELL_Q30_ONE - std::exp(-(double)x / SWELL_Q16_ONE)));
	}
	for (int num = -500; num <= 500; num++)
		worst_cos = std::max(worst_cos,
				     std::fabs((double)swell_cos_pi_frac(num, 97) / SWELL_Q30_ONE - std::cos(M_PI * num / 97)));
	WARN("integer exp error " << worst_exp << ", cos error " << worst_cos);
	CHECK(worst_exp < 2e-6);
	CHECK(worst_cos < 1e-8);
	CHECK(swell_exp_neg_q16(0) == SWELL_Q30_ONE);
	CHECK(swell_exp_neg_q16(40 << 16) == 0);
}
