// The object's coupling apart from its force (swell_body_tick_force, then swell_body_couple), as a
// real-time port runs them: the interrupt sends the force, the background part moves the water.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "body_scene.hpp"

extern "C" {
#include "swell/shape.h"
}

namespace {

const int32_t MM = SWELL_H_ONE_MM;

// z of the object's bottom at tick k: down from 20 mm to -25 mm and back, 40 um a tick
int32_t z_at(int k)
{
	const int span = 45000 / 40;
	const int p = k % (2 * span);
	return 20000 - 40 * (p < span ? p : 2 * span - p);
}

} // namespace

TEST_CASE("the force part and the coupling run apart give swell_body_tick's bits", "[body][couple]")
{
	body_scene one(64, 0.001), two(64, 0.001);
	for (body_scene *s : {&one, &two}) {
		swell_shape_gauss(s->w.h, 64, 64, 20 << 16, 40 << 16, 4 << 16, 3 * MM);
		swell_wave_rest(&s->w);
		swell_body_rescan(&s->b, &s->w);
	}
	for (int k = 0; k < 10 * 120; k++) {
		// the object sinks, rises and drifts sideways, so footprints change as well as depths
		const int32_t x = 200000 + 30 * (k % 700), y = 200000 - 20 * (k % 500), z = z_at(k * 2);
		int32_t pos[3] = {x, y, z}, vel[3] = {0, 0, 0};
		swell_body_out a, b;

		if (k % 10 == 0 && k > 0) {
			for (body_scene *s : {&one, &two}) {
				swell_wave_step(&s->w);
				swell_body_solver_stepped(&s->b, &s->w);
			}
		}
		swell_body_tick(&one.b, &one.w, pos, vel, &a);
		swell_body_tick_force(&two.b, &two.w, pos, vel, &b);
		swell_body_couple(&two.b, &two.w);
		INFO("tick " << k);
		REQUIRE(std::memcmp(&a, &b, sizeof(a)) == 0);
		REQUIRE(one.b.v_displaced == two.b.v_displaced);
		REQUIRE(one.b.wet == two.b.wet);
		if (k % 10 == 9)
			REQUIRE(swell_wave_checksum(&one.w) == swell_wave_checksum(&two.w));
	}
	CHECK(one.b.coupled > 500); // the coupling really ran, tick after tick
}

TEST_CASE("re-couplings over one footprint leave exactly the water of one deposit", "[body][couple]")
{
	// within one solver period the field does not move, so every re-coupling's difference telescopes
	// to one deposit of the last depth: taking the object out then leaves every height at 0
	body_scene s(64);
	swell_body_out out;
	int64_t held = 0;
	for (int k = 0; k < 8; k++) { // 9 ticks in all: no solver step in between
		s.tick(200000, 200000, -1000 - 2300 * k, 0, &out);
		REQUIRE(out.delta_lsb > 0);
		held = s.b.v_displaced;
	}
	const uint32_t coupled = s.b.coupled;
	s.tick(-900000, 200000, 0, 0, &out); // wholly outside the pool: lets go of what it held
	size_t differ = 0;
	for (size_t a = 0; a < (size_t)64 * 64; a++)
		differ += s.w.h[a] != 0;
	INFO("held " << held << " LSB cells before letting go");
	CHECK(held > 0);
	CHECK(coupled == 8);
	CHECK(s.b.v_displaced == 0);
	CHECK(differ == 0);
}

TEST_CASE("the coupling kept back and placed once a period after the step's finish keeps the volume exact", "[body][couple]")
{
	// as the controller core schedules the step: slices and rows scanned ahead, the coupling kept back
	// (swell_body_couple_later) and placed into h(n+1) after the finish (swell_body_place)
	body_scene s(64, 0.001);
	swell_shape_gauss(s.w.h, 64, 64, 20 << 16, 40 << 16, 4 << 16, 3 * MM);
	swell_wave_rest(&s.w);
	swell_body_rescan(&s.b, &s.w);
	const int64_t inv0 = swell_body_invariant(&s.b, &s.w);
	const int kk = (int)s.b.ticks_per_step;
	int kept = 0, placed_whole = 0;
	for (int k = 0; k < 10 * 240; k++) {
		// in and out of the water, drifting sideways: depths and footprints change, the object leaves
		const int32_t x = 200000 + 30 * (k % 700), y = 200000 - 20 * (k % 500), z = z_at(k * 3);
		int32_t pos[3] = {x, y, z}, vel[3] = {0, 0, -1000};
		swell_body_out b;
		const int phase = k % kk;

		swell_body_tick_force(&s.b, &s.w, pos, vel, &b);
		swell_body_couple_later(&s.b, &s.w);
		kept += s.b.v_unplaced != 0;
		INFO("tick " << k);
		REQUIRE(swell_body_invariant(&s.b, &s.w) == inv0);
		if (phase + 1 < kk) {
			const int rows = (64 * (phase + 1) + kk - 2) / (kk - 1) - s.w.next_row;
			swell_wave_step_rows(&s.w, rows);
			swell_body_scan_ahead(&s.b, &s.w);
		} else {
			placed_whole += s.b.v_unplaced != 0;
			swell_wave_step_finish(&s.w);
			swell_body_place(&s.b, &s.w);
			REQUIRE(s.b.v_unplaced == 0);
			swell_body_solver_stepped(&s.b, &s.w);
			REQUIRE(swell_body_invariant(&s.b, &s.w) == inv0);
		}
	}
	WARN(kept << " ticks with water kept back, " << placed_whole << " periods placed at the step's end");
	CHECK(kept > 500); // the water really waited
	CHECK(placed_whole > 50);
	CHECK(s.b.coupled > 1000);
}

TEST_CASE("the surface under the object ramps over the period with its own water", "[body][couple]")
{
	// The solver keeps no h(n) - h(n-1): the body adds its own water's change (dep_v), so that the
	// force law's surface ramps from h(n-1) to h(n) and its damper sees that change. Pushed into still
	// water at the core's schedule (the coupling kept back and placed at the step's end).
	body_scene s(64, 0.001);
	const int kk = (int)s.b.ticks_per_step;
	int32_t peak_speed = 0;
	for (int k = 0; k < 2500; k++) {
		// from 10 mm above the water down to 30 mm below in 1 s, then held
		const int32_t z = k < 2000 ? 10000 - 20 * k : -30000;
		int32_t pos[3] = {200000, 200000, z}, vel_um_s[3] = {0, 0, k < 2000 ? -50000 : 0};
		swell_body_out b;

		swell_body_tick_force(&s.b, &s.w, pos, vel_um_s, &b);
		peak_speed = std::max(peak_speed, std::abs(b.surface_raw_um_s));
		swell_body_couple_later(&s.b, &s.w);
		if (k % kk + 1 < kk)
			continue;
		swell_wave_step(&s.w);
		swell_body_place(&s.b, &s.w); // into h(n+1) after the finish
		swell_body_solver_stepped(&s.b, &s.w);
		REQUIRE(swell_body_invariant(&s.b, &s.w) == 0);
	}
	INFO("surface speed peak " << peak_speed << " um/s");
	// measured with the edge-flux form alongside: a peak of 49046 um/s, the two within 355 um/s
	CHECK(peak_speed > 2000); // the object's own water moves the surface under it
	CHECK(peak_speed < 100000);
}
