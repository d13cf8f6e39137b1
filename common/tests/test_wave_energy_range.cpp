// The solver's energy sums (common/src/wave.c, swell_energy_of): exact inside the int64 range,
// saturated beyond it instead of wrapping (a wrapped sum would read as a calm pool).
#include <catch2/catch.hpp>

#include <cstdint>
#include <vector>

extern "C" {
#include "../src/wave_priv.h"
}

namespace {
struct field {
	std::vector<int32_t> h, dh;
};

int32_t change_of(const void *ctx, int a) { return static_cast<const field *>(ctx)->dh[size_t(a)]; }
} // namespace

TEST_CASE("energy sums: a small field's sums are exact, a checkerboard at the height range saturates instead of wrapping",
	  "[wave][energy]")
{
	const int n = 8;
	field f;

	f.h.assign(n * n, 0);
	f.dh.assign(n * n, 0);
	f.h[3 * n + 3] = 1000; // one raised cell, still (no change): 2 w d^2 summed over its 8 edges
	f.dh[0] = 7;
	struct swell_energy small = swell_energy_of(f.h.data(), n, n, 1 << 28, change_of, &f);
	// edges of an inner cell: 4 axis edges (2 w = 2 each) and 4 diagonals (2 w = 1 each)
	CHECK(small.pot2 == (4 * 2 + 4 * 1) * int64_t(1000) * 1000);
	CHECK(small.kin == 49);

	const int m = 256;
	field big;
	big.h.resize(size_t(m) * m);
	big.dh.resize(size_t(m) * m);
	for (int j = 0; j < m; j++)
		for (int i = 0; i < m; i++) {
			const bool odd = (i + j) % 2 != 0;
			big.h[size_t(j * m + i)] = odd ? INT32_MAX : INT32_MIN;
			big.dh[size_t(j * m + i)] = odd ? INT32_MIN : INT32_MAX; // the step before was the other way round
		}
	struct swell_energy e = swell_energy_of(big.h.data(), m, m, 1 << 28, change_of, &big);
	INFO("kin " << e.kin << ", pot2 " << e.pot2);
	CHECK(e.kin == INT64_MAX);
	CHECK(e.pot2 == INT64_MAX); // every axis edge's term is positive and huge: the sum stops at the top
}
