/* The finishing pass spread over the slices (swell_wave_finish_rows) against the whole finish
 * (swell_wave_step_finish alone) of the scalar reference, for every kernel: between slices the rows
 * finished ahead must read back h(n) as h - acc and every other row h(n) as h, v untouched; after the
 * step everything must be the same bits: heights, v, acc, flows, tile flags, saturations, skipped
 * tiles. */
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

namespace {

/* The reference too: its own finish ahead against its whole finish. */
std::vector<swell_wave_kernel> kernels()
{
	std::vector<swell_wave_kernel> ks = fast_kernels();
	ks.insert(ks.begin(), SWELL_KERNEL_REF);
	return ks;
}

} // namespace

TEST_CASE("the finish spread over the slices is bit-identical to the whole finish, for every kernel", "[wave][split][finish]")
{
	const Case cases[] = {
		{64, 64, 0.2009, 0.001, SWELL_STENCIL_PAPER, 2.0, 1}, /* the controller's reference scene */
		{64, 64, 0.2009, 0.0, SWELL_STENCIL_PAPER, 2.0, 0},
		{23, 17, 0.3, 0.01, SWELL_STENCIL_CALIBRATED, 3.0, 1}, /* ragged tiles and bands */
		{40, 29, 0.45, 0.0, SWELL_STENCIL_PAPER, 1.0, 1},
		{9, 33, 0.2, 0.05, SWELL_STENCIL_PAPER, 2000.0, 1}, /* saturating heights */
	};
	int checked_ahead = 0;
	for (const Case &c : cases) {
		for (swell_wave_kernel k : kernels()) {
			for (uint32_t seed = 1; seed <= 4; seed++) {
				Field ref(c.nx, c.ny, q30(c.e), q30(c.t), c.st, SWELL_KERNEL_REF),
					ahead(c.nx, c.ny, q30(c.e), q30(c.t), c.st, k);
				std::mt19937 rng(seed);
				const int32_t amp = (int32_t)std::min<double>(c.amp_mm * SWELL_H_ONE_MM, SWELL_H_MAX);
				std::uniform_int_distribution<int32_t> d(-amp, amp);
				if (seed % 2) {
					for (int a = 0; a < ref.n(); a++)
						ref.w.h[a] = d(rng);
				} else { /* a splash in calm water: sleeping tiles */
					swell_shape_gauss(ref.w.h, ref.w.nx, ref.w.ny, (c.nx / 3) << 16, (c.ny / 2) << 16,
							  2 << 16, amp);
				}
				std::memcpy(ahead.w.h, ref.w.h, sizeof(int32_t) * ref.n());
				for (Field *f : {&ref, &ahead}) {
					swell_wave_rest(&f->w);
					swell_wave_set_sleep(&f->w, c.sleep);
				}
				for (int s = 0; s < 25; s++) {
					int left = c.ny;
					while (left > 0) {
						const int rows = 1 + (int)(rng() % 9);
						left = swell_wave_step_rows(&ref.w, rows);
						REQUIRE(swell_wave_step_rows(&ahead.w, rows) == left);
						const int before = ahead.w.done_row;
						const int done = swell_wave_finish_rows(&ahead.w, 1 + (int)(rng() % 12));
						REQUIRE(ahead.w.done_row == before + done);
						/* ready: a band once the next band has begun, or everything at the end */
						REQUIRE((ahead.w.done_row <= (ahead.w.next_row - 1) / 8 * 8 ||
							 ahead.w.next_row == ahead.w.ny));
						if (rng() % 3 == 0) { /* an object moving water, in finished rows too */
							const int i = (int)(rng() % c.nx), j = (int)(rng() % c.ny);
							const int32_t dh = d(rng) / 4;
							swell_wave_add(&ref.w, i, j, dh);
							swell_wave_add(&ahead.w, i, j, dh);
						}
						if (rng() % 16 == 0 &&
						    ahead.w.done_row < c.ny) { /* a cell written from outside */
							const int j = ahead.w.done_row + (int)(rng() % (c.ny - ahead.w.done_row));
							const int a = j * c.nx + (int)(rng() % c.nx);
							ref.w.h[a] = ahead.w.h[a] = d(rng);
							swell_wave_touched(&ref.w, a % c.nx, j);
							swell_wave_touched(&ahead.w, a % c.nx, j);
						}
						/* what a reader sees between slices: h(n) and v, everywhere */
						int bad = -1;
						for (int a = 0; a < ref.n() && bad < 0; a++) {
							const bool sat =
								ahead.w.h[a] <= SWELL_H_MIN || ahead.w.h[a] >= SWELL_H_MAX;
							if ((!sat && ahead.h_last(a) != ref.w.h[a]) || ahead.w.v[a] != ref.w.v[a])
								bad = a;
						}
						INFO(swell_wave_kernel_name(k)
						     << " " << c.nx << "x" << c.ny << " seed " << seed << " step " << s
						     << " done_row " << ahead.w.done_row << ": cell " << bad << " reads "
						     << (bad < 0 ? 0 : ahead.h_last(bad)) << " for "
						     << (bad < 0 ? 0 : ref.w.h[bad]));
						REQUIRE(bad < 0);
						checked_ahead += ahead.w.done_row > 0;
					}
					swell_wave_step_finish(&ref.w);
					swell_wave_step_finish(&ahead.w);
					const std::string diff = differs(ref, ahead);
					INFO(swell_wave_kernel_name(k)
					     << " " << c.nx << "x" << c.ny << " e " << c.e << " t " << c.t << " sleep " << c.sleep
					     << " seed " << seed << ": after step " << s << ": " << diff);
					REQUIRE(diff.empty());
					REQUIRE(ahead.w.done_row == 0);
				}
			}
		}
	}
	CHECK(checked_ahead > 1000);
}

TEST_CASE("finishing ahead waits for the next band and never passes the rows done", "[wave][split][finish]")
{
	Field f(64, 20, q30(0.2), 0, SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
	CHECK(swell_wave_finish_rows(&f.w, 64) == 0); /* nothing computed */
	swell_wave_step_rows(&f.w, 8);
	CHECK(swell_wave_finish_rows(&f.w, 64) == 0); /* band 0 waits for band 1's first row */
	swell_wave_step_rows(&f.w, 1);
	CHECK(swell_wave_finish_rows(&f.w, 3) == 3);
	CHECK(swell_wave_finish_rows(&f.w, 64) == 5);
	CHECK(f.w.done_row == 8);
	swell_wave_step_rows(&f.w, 10); /* rows 9..18: band 2 begun at 16 */
	CHECK(swell_wave_finish_rows(&f.w, 64) == 8);
	CHECK(swell_wave_finish_rows(&f.w, 64) == 0);
	swell_wave_step_rows(&f.w, 5); /* the last row: everything ready */
	CHECK(swell_wave_finish_rows(&f.w, 64) == 4);
	CHECK(f.w.done_row == 20);
	CHECK(swell_wave_finish_rows(&f.w, -3) == 0);
	const uint32_t steps = f.w.steps;
	swell_wave_step_finish(&f.w);
	CHECK(f.w.steps == steps + 1);
	CHECK(f.w.done_row == 0);
	CHECK(f.w.next_row == 0);
}

TEST_CASE("water added to a row finished ahead is in h at once and conserved like any other", "[wave][split][finish][add]")
{
	Field f(16, 24, q30(0.25), q30(0.02), SWELL_STENCIL_PAPER, SWELL_KERNEL_AUTO);
	std::mt19937 rng(9);
	for (int a = 0; a < f.n(); a++)
		f.w.h[a] = (int32_t)(rng() % 20000) - 10000;
	swell_wave_rest(&f.w);
	const int64_t v0 = swell_wave_volume(&f.w);
	swell_wave_step_rows(&f.w, 17);
	REQUIRE(swell_wave_finish_rows(&f.w, 24) == 16);
	const int32_t h_before = f.w.h[3 * 16 + 5], h_last = f.w.h[3 * 16 + 5] - f.w.acc[3 * 16 + 5];
	swell_wave_add(&f.w, 5, 3, 1000); /* finished ahead: in h now */
	swell_wave_add(&f.w, 5, 20, -250); /* not yet: at the finish */
	CHECK(f.w.h[3 * 16 + 5] == h_before + 1000);
	CHECK(f.w.h[3 * 16 + 5] - f.w.acc[3 * 16 + 5] == h_last); /* h(n) as a reader sees it: unchanged */
	swell_wave_step_finish(&f.w);
	CHECK(swell_wave_volume(&f.w) == v0 + 750);
	for (int k = 0; k < 500; k++) {
		swell_wave_step_rows(&f.w, 9);
		swell_wave_finish_rows(&f.w, 24);
		swell_wave_step_finish(&f.w);
	}
	CHECK(swell_wave_volume(&f.w) == v0 + 750);
}

namespace {

/* A 16 x 24 field of either form, rows 0..15 finished ahead (h(n+1)) and 16..23 not, from the same
 * seed. */
struct SpanField {
	std::vector<int32_t> store;
	swell_wave w{};
	explicit SpanField(swell_wave_form form)
	    : store(form == SWELL_FORM_VELOCITY ? SWELL_WAVE_VEL_WORDS(16, 24) : SWELL_WAVE_WORDS(16, 24))
	{
		const swell_wave_params p{q30(0.25), q30(0.02), SWELL_STENCIL_PAPER};
		std::mt19937 rng(3);

		REQUIRE(swell_wave_init_form(&w, 16, 24, store.data(), store.size(), &p, form) == SWELL_OK);
		for (int a = 0; a < 16 * 24; a++)
			w.h[a] = (int32_t)(rng() % 20000) - 10000;
		w.h[2 * 16 + 7] = (1 << 26) - 9; /* near the velocity form's bound */
		swell_wave_rest(&w);
		swell_wave_step_rows(&w, 17);
		if (form == SWELL_FORM_EDGE)
			REQUIRE(swell_wave_finish_rows(&w, 24) == 16);
		else /* the velocity form's rows hold h(n+1) one row behind the kernel: nothing to finish */
			REQUIRE(swell_wave_finish_rows(&w, 24) == 0);
		REQUIRE(w.done_row == 16);
	}
};

} // namespace

TEST_CASE("adding one change to a span of a row is swell_wave_add cell by cell, ahead or not, near the bounds too",
	  "[wave][split][finish][add]")
{
	/* spans clipped at both walls and rows outside the grid; changes that saturate acc (+-2^29) and
	 * h; the whole storage compared (h, v, acc, flows or u, tile flags) and the saturation count */
	const int32_t changes[] = {1, -700, 123456, (1 << 29) - 5, -(1 << 30), INT32_MAX, 0};
	for (swell_wave_form form : {SWELL_FORM_EDGE, SWELL_FORM_VELOCITY}) {
		for (int32_t d : changes) {
			SpanField a(form), b(form);
			for (int j : {-1, 2, 9, 15, 16, 20, 24}) {
				swell_wave_add_span(&a.w, -3, 19, j, d);
				swell_wave_add_span(&a.w, 5, 5, j, d); /* empty */
				for (int i = -3; i < 19; i++)
					if (d)
						swell_wave_add(&b.w, i, j, d);
			}
			INFO("form " << form << " change " << d);
			CHECK(a.w.saturations == b.w.saturations);
			CHECK(a.store == b.store);
			swell_wave_step_finish(&a.w);
			swell_wave_step_finish(&b.w);
			CHECK(a.store == b.store);
			CHECK(swell_wave_volume(&a.w) == swell_wave_volume(&b.w));
		}
	}
}
