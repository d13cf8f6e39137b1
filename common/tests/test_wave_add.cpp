/* Water added from outside (swell_wave_add, swell_wave_add_span) in the middle of a step: into h at
 * once, in rows finished ahead as well as the others, and conserved from then on. */
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

extern "C" {
#include "swell/shape.h"
#include "swell/wave.h"
}

#include "wave_field.hpp"

using namespace wave_test;

TEST_CASE("water added to a row finished ahead is in h at once and conserved like any other", "[wave][split][finish][add]")
{
	Field f(16, 24, q30(0.25), q30(0.02), SWELL_STENCIL_PAPER, SWELL_KERNEL_AUTO);
	std::mt19937 rng(9);
	for (int a = 0; a < f.n(); a++)
		f.w.h[a] = (int32_t)(rng() % 20000) - 10000;
	swell_wave_rest(&f.w);
	const int64_t v0 = swell_wave_volume(&f.w);
	swell_wave_step_rows(&f.w, 17);
	REQUIRE(f.w.done_row == 16); /* rows 0..15 hold h(n+1) */
	const int32_t h_before = f.w.h[3 * 16 + 5], h_last = swell_wave_h(&f.w, 3 * 16 + 5);
	const int32_t h_late = swell_wave_h(&f.w, 20 * 16 + 5);
	swell_wave_add(&f.w, 5, 3, 1000); /* finished ahead: in h(n+1) now, and in h - dh(u) */
	swell_wave_add(&f.w, 5, 20, -250); /* not yet finished: in h(n), which the rest of the step reads */
	CHECK(f.w.h[3 * 16 + 5] == h_before + 1000);
	CHECK(swell_wave_h(&f.w, 3 * 16 + 5) == h_last + 1000);
	CHECK(swell_wave_h(&f.w, 20 * 16 + 5) == h_late - 250);
	swell_wave_step_finish(&f.w); /* the step's volume is exact at its finish (the fixer) */
	CHECK(swell_wave_volume(&f.w) == v0 + 750);
	for (int k = 0; k < 500; k++) {
		swell_wave_step_rows(&f.w, 9);
		swell_wave_step_finish(&f.w);
	}
	CHECK(swell_wave_volume(&f.w) == v0 + 750);
}

namespace {

/* A 16 x 24 field, rows 0..15 finished ahead (h(n+1)) and 16..23 not, from the same seed. */
struct SpanField {
	std::vector<int32_t> store;
	swell_wave w{};
	SpanField() : store(SWELL_WAVE_WORDS(16, 24))
	{
		const swell_wave_params p{q30(0.25), q30(0.02), SWELL_STENCIL_PAPER};
		std::mt19937 rng(3);

		REQUIRE(swell_wave_init(&w, 16, 24, store.data(), store.size(), &p) == SWELL_OK);
		for (int a = 0; a < 16 * 24; a++)
			w.h[a] = (int32_t)(rng() % 20000) - 10000;
		w.h[2 * 16 + 7] = (1 << 26) - 9; /* near the height bound */
		swell_wave_rest(&w);
		swell_wave_step_rows(&w, 17); /* rows hold h(n+1) one row behind the kernel */
		REQUIRE(w.done_row == 16);
	}
};

} // namespace

TEST_CASE("adding one change to a span of a row is swell_wave_add cell by cell, ahead or not, near the bounds too",
	  "[wave][split][finish][add]")
{
	/* spans clipped at both walls and rows outside the grid; changes that saturate h; the whole
	 * storage compared (h, u, tile flags) and the saturation count */
	const int32_t changes[] = {1, -700, 123456, (1 << 29) - 5, -(1 << 30), INT32_MAX, 0};
	{
		for (int32_t d : changes) {
			SpanField a, b;
			for (int j : {-1, 2, 9, 15, 16, 20, 24}) {
				swell_wave_add_span(&a.w, -3, 19, j, d);
				swell_wave_add_span(&a.w, 5, 5, j, d); /* empty */
				for (int i = -3; i < 19; i++)
					if (d)
						swell_wave_add(&b.w, i, j, d);
			}
			INFO("change " << d);
			CHECK(a.w.saturations == b.w.saturations);
			CHECK(a.store == b.store);
			swell_wave_step_finish(&a.w);
			swell_wave_step_finish(&b.w);
			CHECK(a.store == b.store);
			CHECK(swell_wave_volume(&a.w) == swell_wave_volume(&b.w));
		}
	}
}
