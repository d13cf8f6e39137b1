// The object against a solver whose rows hold h(n+1) one row behind its kernel and a ceiling scan
// spread over the solver period (swell_body_scan_ahead), as the controller core schedules them: the
// force law must read what it reads when the step's field is scanned whole at the period's end, to
// within the LSBs the solver's volume fixer gives back into rows already scanned at the step's end.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>

#include "body_scene.hpp"

extern "C" {
#include "swell/shape.h"
}

namespace {

const int32_t MM = SWELL_H_ONE_MM;

// One solver period split over K ticks in two ways: "whole" does the rows in slices and scans the
// field at the last tick; "ahead" also scans rows as the slices complete them.
struct twin {
	body_scene whole, ahead;
	std::mt19937 rng;
	int phase = 0;
	int32_t worst_surface = 0; // the largest surface difference the force law saw, LSB
	uint64_t fixed_at_step = 0; // the fixers' LSBs given back before the last step
	explicit twin(uint32_t seed, double damping = 0.001) : whole(64, damping), ahead(64, damping), rng(seed) {}

	void field(int32_t amp)
	{
		for (body_scene *s : {&whole, &ahead}) {
			swell_shape_gauss(s->w.h, 64, 64, 20 << 16, 40 << 16, 4 << 16, amp);
			swell_wave_rest(&s->w);
			swell_body_rescan(&s->b, &s->w);
		}
	}

	// the background part of a tick: a slice, or the step's end
	void background()
	{
		const int kk = (int)whole.b.ticks_per_step;
		if (phase + 1 < kk) {
			const int rows = 64 * (phase + 1) / (kk - 1) - whole.w.next_row;
			swell_wave_step_rows(&whole.w, rows);
			swell_wave_step_rows(&ahead.w, rows);
			swell_body_scan_ahead(&ahead.b, &ahead.w);
		} else {
			fixed_at_step = whole.w.fixed_lsb;
			for (body_scene *s : {&whole, &ahead}) {
				swell_wave_step_finish(&s->w);
				swell_body_solver_stepped(&s->b, &s->w);
			}
		}
		phase = (phase + 1) % kk;
	}

	// the force part of a tick; returns where the two differ ("" when they agree)
	std::string force(int32_t x, int32_t y, int32_t z, int32_t vz)
	{
		int32_t pos[3] = {x, y, z}, vel[3] = {0, 0, vz};
		swell_body_out a, b;
		swell_body_tick(&whole.b, &whole.w, pos, vel, &a);
		swell_body_tick(&ahead.b, &ahead.w, pos, vel, &b);
		worst_surface = std::max(worst_surface, std::abs(a.surface_lsb - b.surface_lsb));
		if (swell_body_invariant(&whole.b, &whole.w) != swell_body_invariant(&ahead.b, &ahead.w))
			return "invariant";
		if (a.surface_lsb != b.surface_lsb && !ahead.b.wet && !whole.b.wet)
			return "surface out of the water " + std::to_string(a.surface_lsb) + " vs " +
				std::to_string(b.surface_lsb);
		return "";
	}
};

} // namespace

TEST_CASE("the ceiling scan spread over the period finds the whole scan's ceiling and sum", "[body][scan][ahead]")
{
	for (uint32_t seed = 1; seed <= 3; seed++) {
		twin t(seed);
		t.field((int32_t)(seed * 3) * MM);
		int adopted = 0;
		for (int k = 0; k < 10 * 60; k++) { // 60 solver periods, the object held clear of the water
			const std::string diff = t.force(200000, 200000, 40000, 0);
			REQUIRE(diff.empty());
			t.background();
			if (t.phase == 0) {
				INFO("seed " << seed << " step " << t.whole.w.steps);
				REQUIRE(t.whole.b.ceiling_ok == 1);
				REQUIRE(t.ahead.b.ceiling_ok == 1);
				// the fixer's LSBs of the step: a bound on what rows scanned ahead missed
				const int64_t fixed = (int64_t)(t.whole.w.fixed_lsb - t.fixed_at_step);
				REQUIRE(std::llabs((int64_t)t.ahead.b.ceiling_lsb - t.whole.b.ceiling_lsb) <= fixed);
				REQUIRE(std::llabs(t.ahead.b.water_sum - t.whole.b.water_sum) <= fixed);
				adopted++;
			}
		}
		CHECK(adopted == 60);
		CHECK(t.ahead.b.scan_ahead == 1);
	}
}

TEST_CASE("with rows finished ahead the force law reads the last finished step: the surface within a few LSB "
	  "of the whole scan's, the invariant exact",
	  "[body][ahead]")
{
	for (uint32_t seed = 1; seed <= 3; seed++) {
		twin t(seed);
		t.field(2 * MM);
		std::mt19937 rng(seed + 10);
		int wet = 0;
		for (int k = 0; k < 2500; k++) { // 1 s: sinks from 20 mm above to 25 mm below, sways sideways
			const int32_t z = 20000 - k * 20 > -25000 ? 20000 - k * 20 : -25000;
			const int32_t x = 200000 + (int32_t)(rng() % 4001) - 2000, y = 200000 + (k % 400) * 10;
			const std::string diff = t.force(x, y, z, -50000);
			INFO("seed " << seed << " tick " << k << " phase " << t.phase << " done_row " << t.ahead.w.done_row
				     << ": " << diff);
			REQUIRE(diff.empty());
			wet += t.ahead.b.wet;
			t.background();
		}
		INFO("surface differs by up to " << t.worst_surface << " LSB");
		CHECK(wet > 1000);
		CHECK(t.ahead.b.coupled > 1000);
		CHECK(t.worst_surface <= 64); // 2^-10 mm: the mean level's share of the fixer's LSBs
		CHECK(t.whole.w.saturations == 0);
	}
}

TEST_CASE("leaving the water mid-period: the ceiling is not claimed for the next period, then found again", "[body][scan][ahead]")
{
	twin t(7);
	t.field(2 * MM);
	for (int k = 0; k < 10 * 30; k++) {
		// in the water for 10 periods, out for 20, the exit in the middle of a period
		const int32_t z = k < 105 ? -10000 : 40000;
		t.force(200000, 200000, z, 0);
		t.background();
		if (t.phase != 0)
			continue;
		const int step = (int)t.ahead.w.steps;
		if (step >= 12) { // two whole dry periods after the exit: found again (to the fixer's LSBs)
			const int64_t fixed = (int64_t)(t.whole.w.fixed_lsb - t.fixed_at_step);
			INFO("step " << step);
			REQUIRE(t.ahead.b.ceiling_ok == 1);
			REQUIRE(std::llabs((int64_t)t.ahead.b.ceiling_lsb - t.whole.b.ceiling_lsb) <= fixed);
			REQUIRE(std::llabs(t.ahead.b.water_sum - t.whole.b.water_sum) <= fixed);
		} else if (t.ahead.b.ceiling_ok) { // never a ceiling below the water it must bound
			int32_t top = INT32_MIN;
			for (int a = 0; a < 64 * 64; a++)
				top = std::max(top,
					       std::max(t.ahead.w.h[a], t.ahead.w.h[a] - swell_wave_dh(&t.ahead.w, (size_t)a)));
			REQUIRE(t.ahead.b.ceiling_lsb >= top);
		}
	}
}
