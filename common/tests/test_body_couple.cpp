// The object's coupling apart from its force (swell_body_tick_force, then swell_body_couple), as a
// real-time port runs them: the interrupt sends the force, the background part moves the water.
#include <catch2/catch.hpp>

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
	// to one deposit of the last depth: taking the object out then leaves every accumulator at 0
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
		differ += s.w.acc[a] != 0;
	INFO("held " << held << " LSB cells before letting go");
	CHECK(held > 0);
	CHECK(coupled == 8);
	CHECK(s.b.v_displaced == 0);
	CHECK(differ == 0);
}

TEST_CASE("the coupling kept back and placed once a period gives the coupling's bits tick by tick", "[body][couple]")
{
	// as the controller core schedules the step: slices, rows finished and scanned ahead; "now"
	// couples every tick, "later" with swell_body_couple_later and swell_body_place before the finish
	body_scene now(64, 0.001), later(64, 0.001);
	for (body_scene *s : {&now, &later}) {
		swell_shape_gauss(s->w.h, 64, 64, 20 << 16, 40 << 16, 4 << 16, 3 * MM);
		swell_wave_rest(&s->w);
		swell_body_rescan(&s->b, &s->w);
	}
	const int kk = (int)now.b.ticks_per_step;
	int kept = 0, placed_whole = 0;
	for (int k = 0; k < 10 * 240; k++) {
		// in and out of the water, drifting sideways: depths and footprints change, the object leaves
		const int32_t x = 200000 + 30 * (k % 700), y = 200000 - 20 * (k % 500), z = z_at(k * 3);
		int32_t pos[3] = {x, y, z}, vel[3] = {0, 0, -1000};
		swell_body_out a, b;
		const int phase = k % kk;

		swell_body_tick_force(&now.b, &now.w, pos, vel, &a);
		swell_body_tick_force(&later.b, &later.w, pos, vel, &b);
		INFO("tick " << k);
		REQUIRE(std::memcmp(&a, &b, sizeof(a)) == 0);
		swell_body_couple(&now.b, &now.w);
		swell_body_couple_later(&later.b, &later.w);
		kept += later.b.v_unplaced != 0;
		REQUIRE(now.b.v_displaced == later.b.v_displaced);
		REQUIRE(now.b.water_sum == later.b.water_sum);
		REQUIRE(now.b.wet == later.b.wet);
		REQUIRE(swell_body_invariant(&now.b, &now.w) == swell_body_invariant(&later.b, &later.w));
		if (phase + 1 < kk) {
			const int rows = (64 * (phase + 1) + kk - 2) / (kk - 1) - now.w.next_row;
			for (body_scene *s : {&now, &later}) {
				swell_wave_step_rows(&s->w, rows);
				swell_wave_finish_rows(&s->w, 8);
				swell_body_scan_ahead(&s->b, &s->w);
			}
		} else {
			placed_whole += later.b.v_unplaced != 0;
			swell_body_place(&later.b, &later.w);
			REQUIRE(later.b.v_unplaced == 0);
			for (body_scene *s : {&now, &later}) {
				swell_wave_step_finish(&s->w);
				swell_body_solver_stepped(&s->b, &s->w);
			}
			REQUIRE(swell_wave_checksum(&now.w) == swell_wave_checksum(&later.w));
			REQUIRE(now.b.ceiling_ok == later.b.ceiling_ok);
			REQUIRE((now.b.ceiling_ok == 0 || now.b.ceiling_lsb == later.b.ceiling_lsb));
		}
	}
	WARN(kept << " ticks with water kept back, " << placed_whole << " periods placed at the step's end");
	CHECK(kept > 500); // the water really waited
	CHECK(placed_whole > 50);
	CHECK(now.b.coupled > 1000);
}

TEST_CASE("in the velocity form the surface under the object ramps over the period with its own water, as in the "
	  "edge-flux form",
	  "[body][couple][velocity]")
{
	// The edge-flux form's v holds the water the object wrote in the last period, so the force law's
	// surface ramps from h(n-1) to h(n) and its damper sees that change; the velocity form keeps no v
	// and the body adds its own water's change (dep_v). Pushed into still water at the core's schedule
	// (the coupling kept back and placed at the step's end), both forms must see nearly the same
	// surface and surface velocity: the solver's own motion is all that differs between them.
	body_scene edge(64, 0.001), vel(64, 0.001, 6250, SWELL_FORM_VELOCITY);
	const int kk = (int)edge.b.ticks_per_step;
	int32_t worst_surface = 0, worst_speed = 0, peak_speed = 0;
	for (int k = 0; k < 2500; k++) {
		// from 10 mm above the water down to 30 mm below in 1 s, then held
		const int32_t z = k < 2000 ? 10000 - 20 * k : -30000;
		int32_t pos[3] = {200000, 200000, z}, vel_um_s[3] = {0, 0, k < 2000 ? -50000 : 0};
		swell_body_out a, b;

		swell_body_tick_force(&edge.b, &edge.w, pos, vel_um_s, &a);
		swell_body_tick_force(&vel.b, &vel.w, pos, vel_um_s, &b);
		worst_surface = std::max(worst_surface, std::abs(a.surface_lsb - b.surface_lsb));
		worst_speed = std::max(worst_speed, std::abs(a.surface_raw_um_s - b.surface_raw_um_s));
		peak_speed = std::max(peak_speed, std::abs(a.surface_raw_um_s));
		swell_body_couple_later(&edge.b, &edge.w);
		swell_body_couple_later(&vel.b, &vel.w);
		if (k % kk + 1 < kk)
			continue;
		swell_body_place(&edge.b, &edge.w); // the edge-flux form: into acc, h(n+1) at the finish
		swell_wave_step(&edge.w);
		swell_wave_step(&vel.w);
		swell_body_place(&vel.b, &vel.w); // the velocity form: into h(n+1) after the finish
		swell_body_solver_stepped(&edge.b, &edge.w);
		swell_body_solver_stepped(&vel.b, &vel.w);
		REQUIRE(swell_body_invariant(&vel.b, &vel.w) == 0);
	}
	INFO("surface differs by up to " << worst_surface << " LSB, its speed by " << worst_speed << " um/s of a peak "
					 << peak_speed << " um/s");
	// measured: 1083 LSB and 355 of 49046 um/s; without dep_v 12997 LSB and 48111 um/s
	CHECK(peak_speed > 2000); // the object's own water moves the surface under it
	CHECK(worst_surface < MM / 20); // 0.05 mm
	CHECK(worst_speed < peak_speed / 10);
}
