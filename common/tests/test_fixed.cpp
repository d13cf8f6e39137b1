#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <random>

extern "C" {
#include "swell/crc.h"
#include "swell/err.h"
#include "swell/fixed.h"
}

TEST_CASE("crc32 matches the IEEE check value", "[crc]")
{
	const char msg[] = "123456789";
	CHECK(swell_crc32(0, msg, 9) == 0xCBF43926u);
	/* feeding in pieces gives the same CRC */
	CHECK(swell_crc32(swell_crc32(0, msg, 4), msg + 4, 5) == 0xCBF43926u);
	CHECK(swell_crc32(0, msg, 0) == 0u);
}

TEST_CASE("saturating add and sub clamp at the int32 range instead of wrapping", "[fixed]")
{
	CHECK(swell_sat_add(INT32_MAX, 1) == INT32_MAX);
	CHECK(swell_sat_add(INT32_MIN, -1) == INT32_MIN);
	CHECK(swell_sat_sub(INT32_MIN, 1) == INT32_MIN);
	CHECK(swell_sat_sub(INT32_MAX, -1) == INT32_MAX);
	CHECK(swell_sat_add(-5, 3) == -2);
}

TEST_CASE("q30 products round as documented and saturate at the extremes", "[fixed]")
{
	const q30_t half = SWELL_Q30_ONE / 2;
	/* 3 * 0.5 = 1.5: nearest (ties up) -> 2, toward zero -> 1, away -> 2 */
	CHECK(swell_mul_q30_rn(3, half) == 2);
	CHECK(swell_mul_q30_rz(3, half) == 1);
	CHECK(swell_mul_q30_ra(3, half) == 2);
	/* -3 * 0.5 = -1.5: nearest (ties up) -> -1, toward zero -> -1, away -> -2 */
	CHECK(swell_mul_q30_rn(-3, half) == -1);
	CHECK(swell_mul_q30_rz(-3, half) == -1);
	CHECK(swell_mul_q30_ra(-3, half) == -2);
	/* (2 - 2^-30) * INT32_MAX does not fit: saturates */
	CHECK(swell_mul_q30_rn(INT32_MAX, INT32_MAX) == INT32_MAX);
	CHECK(swell_mul_q30_rn(INT32_MIN, INT32_MAX) == INT32_MIN);
	CHECK(swell_mul_q30_rz(INT32_MIN, INT32_MIN) == INT32_MAX);

	/* against double over random operands: error within the rounding mode's bound */
	std::mt19937_64 rng(7);
	std::uniform_int_distribution<int32_t> dx(INT32_MIN, INT32_MAX);
	std::uniform_int_distribution<int32_t> dc(-SWELL_Q30_ONE, SWELL_Q30_ONE);
	double worst_rn = 0;
	for (int k = 0; k < 100000; k++) {
		int32_t x = dx(rng) >> (k % 31);
		q30_t c = dc(rng);
		long double exact = (long double)x * c / SWELL_Q30_ONE;
		if (std::fabs((double)exact) > 2.0e9)
			continue;
		long double rn = swell_mul_q30_rn(x, c), rz = swell_mul_q30_rz(x, c), ra = swell_mul_q30_ra(x, c);
		REQUIRE(std::fabs((double)(rn - exact)) <= 0.5);
		REQUIRE(std::fabs((double)rz) <= std::fabs((double)exact));
		REQUIRE(std::fabs((double)(rz - exact)) < 1.0);
		REQUIRE(std::fabs((double)ra) >= std::fabs((double)exact));
		REQUIRE(std::fabs((double)(ra - exact)) < 1.0);
		worst_rn = std::fmax(worst_rn, std::fabs((double)(rn - exact)));
	}
	INFO("worst round-to-nearest error " << worst_rn << " LSB");
	CHECK(worst_rn <= 0.5);
}

TEST_CASE("muldiv_u64 is exact to nearest with a 128-bit intermediate", "[fixed]")
{
	uint64_t out = 0;
	REQUIRE(swell_muldiv_u64(10, 10, 3, &out));
	CHECK(out == 33);
	REQUIRE(swell_muldiv_u64(10, 10, 6, &out));
	CHECK(out == 17); /* 16.67 */
	REQUIRE(swell_muldiv_u64(UINT64_MAX, UINT64_MAX, UINT64_MAX, &out));
	CHECK(out == UINT64_MAX);
	REQUIRE(swell_muldiv_u64((uint64_t)1 << 40, (uint64_t)1 << 40, (uint64_t)1 << 20, &out));
	CHECK(out == (uint64_t)1 << 60);
	out = 42;
	CHECK_FALSE(swell_muldiv_u64(1, 1, 0, &out));
	CHECK_FALSE(swell_muldiv_u64(UINT64_MAX, UINT64_MAX, 1, &out));
	CHECK(out == 42); /* untouched on failure */
}

TEST_CASE("every error value has its own text", "[err]")
{
	for (int e = 0; e < SWELL_ERR_COUNT; e++)
		CHECK(std::string(swell_err_str((enum swell_err)e)) != "unknown error");
	CHECK(std::string(swell_err_str((enum swell_err)999)) == "unknown error");
}
