// The pool floor under the floating object (common/src/body.c, docs/force-law.md): where it is, the
// contact force, what the coupling does there, and that the paper's law is back once off the floor.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "body_scene.hpp"

static const int32_t MM = SWELL_H_ONE_MM;

// one tick without a solver step: the coupling kept back for the step's end as the controller keeps it
// (the solver takes water in at once), so the water stands still and the force is a function of z and v
static void still_tick(body_scene &s, int32_t z_um, int32_t vz_um_s, swell_body_out *out)
{
	int32_t pos[3] = {200000, 200000, z_um}, vel[3] = {0, 0, vz_um_s};
	swell_body_tick_force(&s.b, &s.w, pos, vel, out);
	swell_body_couple_later(&s.b, &s.w);
}

TEST_CASE("the floor is at the rest depth the solver's e stands for, and follows a new e", "[body][floor]")
{
	for (uint32_t depth_um : {10000u, 30000u, 50000u, 120000u}) {
		body_scene s(16);
		swell_wave_params wp = s.w.p;
		REQUIRE(swell_wave_e_from_physical(9810, 4000, depth_um, 6250, &wp.e) == SWELL_OK);
		REQUIRE(swell_wave_set_params(&s.w, &wp) == SWELL_OK);
		swell_body_out out;
		still_tick(s, 10000, 0, &out); // out of the water: the floor is still kept current
		const double expect = -(double)depth_um * MM / 1000;
		INFO("depth " << depth_um << " um: floor " << out.floor_lsb << " LSB, expected " << expect);
		// e is rounded to 2^-30: about 2e-9 of the depth, far below one LSB
		CHECK(std::fabs(out.floor_lsb - expect) <= 1.0);
		CHECK(s.b.floor_lsb == out.floor_lsb);
	}
}

TEST_CASE("pressed to the floor the force is continuous in z, bounded, pushes and never pulls", "[body][floor]")
{
	body_scene s(64); // 50 mm deep; a 60 x 60 x 40 mm box of 60 g
	const double kc = SWELL_BODY_FLOOR_K / 65536.0; // uN per LSB
	const double bc = SWELL_BODY_FLOOR_DAMPER / 1000.0; // uN per um/s
	const double ramp = SWELL_BODY_FLOOR_RAMP_UM * MM / 1000.0; // LSB
	const double k = s.b.k_q8 / 16777216.0; // uN per LSB
	for (int32_t vz : {0, -20000, 20000}) {
		swell_body_out out, prev;
		long n = 0, jumps = 0, pulls = 0, over = 0, flat = 0, deep = 0;
		double worst = 0;
		for (int32_t z = -30000; z >= -60000; z -= 2, n++) {
			still_tick(s, z, vz, &out);
			if (out.f.floor_uN < 0)
				pulls++;
			if (out.f.floor_uN > SWELL_BODY_FLOOR_F_MAX_UN)
				over++;
			if (n > 0) {
				// the slope bound: contact spring, its damper coming in over p_r, the buoyancy
				// springs and the damper's submersion scale (b_max / H)
				const double dz = std::fabs((double)swell_um_to_lsb(z) - swell_um_to_lsb(z + 2));
				const double bound = dz *
						(kc + bc * std::abs(vz) / ramp + k +
						 s.p.damper_uN_per_mm_s * std::abs(vz) / 1000.0 / s.b.h_lsb) +
					8; // rounding of the terms
				const double d = std::fabs((double)out.f.total_uN - prev.f.total_uN);
				worst = std::fmax(worst, d / bound);
				if (d > bound && jumps++ < 3)
					FAIL_CHECK("v " << vz << " um/s, z " << z << " um: total changed by " << d << " uN over "
							<< dz << " LSB (bound " << bound << ")");
			}
			// deep enough (spring past F_c_max): flat at the bound
			if (out.penetration_lsb > 3 * MM) {
				deep++;
				flat += out.f.floor_uN == SWELL_BODY_FLOOR_F_MAX_UN;
			}
			prev = out;
		}
		std::printf("floor sweep at v %+d mm/s: %ld ticks, worst change %.2f of the slope bound, %ld of %ld deep "
			    "ticks at F_c_max\n",
			    vz / 1000, n, worst, flat, deep);
		CHECK(jumps == 0);
		CHECK(pulls == 0);
		CHECK(over == 0);
		CHECK(deep > 1000);
		CHECK(flat == deep);
		// and its opening: 1 um above the floor no contact at all
		still_tick(s, swell_lsb_to_um(s.b.floor_lsb) + 1, vz, &out);
		CHECK(out.f.floor_uN == 0);
		CHECK(out.penetration_lsb == 0);
	}
}

TEST_CASE("at the floor the displaced depth is the water column: pushing further moves no more water", "[body][floor]")
{
	body_scene s(64, 0.01);
	s.p.h_um = 80000; // taller than the 50 mm of water
	REQUIRE(swell_body_set_params(&s.b, &s.p, &s.xf) == SWELL_OK);
	const int64_t inv0 = swell_body_invariant(&s.b, &s.w);
	swell_body_out out;
	for (int t = 0; t < 2500; t++) // lowered onto the floor over 1 s
		s.tick(200000, 200000, -(int32_t)(60000.0 * t / 2500), -60000, &out);
	for (int t = 0; t < 2500; t++) // held at the floor: the water settles
		s.tick(200000, 200000, -50000, 0, &out);
	const int64_t v_at_floor = s.b.v_displaced;
	const double level = (double)s.b.water_sum / (64 * 64);
	long changed = 0;
	for (int t = 0; t < 2500; t++) { // pressed on, 1 to 10 mm into the floor
		s.tick(200000, 200000, -51000 - (t % 10) * 1000, 0, &out);
		changed += s.b.v_displaced != v_at_floor;
	}
	const double area = 60000.0 * 60000 / (6250.0 * 6250);
	const double column = area * (level + 50 * MM);
	std::printf("H 80 mm at the floor: displaced %.1f mm*cells, A (S + d) = %.1f mm*cells; %ld of 2500 ticks "
		    "below the floor moved water\n",
		    v_at_floor / (double)MM, column / MM, changed);
	INFO("displaced " << v_at_floor << " LSB*cell, A (S + d) " << column << ", ticks that moved water " << changed);
	CHECK(changed == 0);
	CHECK(std::fabs(v_at_floor - column) < 0.001 * column + area);
	CHECK(out.delta_lsb <= s.b.h_lsb);
	CHECK(out.penetration_lsb > 0);
	CHECK(swell_body_invariant(&s.b, &s.w) == inv0);
	CHECK(s.w.saturations == 0);
}

TEST_CASE("a box heavier than its buoyancy sinks and rests on the floor: k_c p = m g - rho g V", "[body][floor]")
{
	body_scene s(64, 0.01);
	s.p.mass_g = 400; // 3.92 N against k H = 1.41 N
	REQUIRE(swell_body_set_params(&s.b, &s.p, &s.xf) == SWELL_OK);
	swell_free_body fb;
	swell_free_body_init(&fb, 10000, s.p.mass_g, s.sc.tick_hz);
	swell_body_out out;
	double pen = 0;
	int32_t fmax = 0;
	for (long t = 0; t < 4 * 2500; t++) {
		int32_t pos[3], vel[3];
		swell_free_body_pose(&fb, 200000, 200000, pos, vel);
		s.tick(pos[0], pos[1], pos[2], vel[2], &out);
		swell_free_body_step(&fb, out.f.total_uN);
		fmax = out.f.floor_uN > fmax ? out.f.floor_uN : fmax;
		if (t >= 3 * 2500)
			pen += out.penetration_lsb / 2500.0;
	}
	// resting: the contact carries the weight less the full buoyancy k H (it is under water)
	const double kh = s.b.k_q8 * (double)s.b.h_lsb / 16777216.0;
	const double expect = (-s.b.gravity_uN - kh) * 65536.0 / SWELL_BODY_FLOOR_K;
	std::printf("400 g box resting on the floor: %.4f mm into it, (m g - k H) / k_c = %.4f mm; largest contact "
		    "force %.3f N\n",
		    pen / MM, expect / MM, fmax / 1e6);
	INFO("penetration " << pen << " LSB, expected " << expect << " LSB");
	CHECK(std::fabs(pen - expect) < 0.01 * expect);
	CHECK(out.delta_lsb == s.b.h_lsb);
	CHECK(fmax <= SWELL_BODY_FLOOR_F_MAX_UN);
}

TEST_CASE("off the floor again the force is the paper's law: no contact term, k clamp(w - z, 0, H), the damper", "[body][floor]")
{
	body_scene s(64, 0.01);
	swell_body_out out;
	long checked = 0, wrong = 0, touched = 0;
	for (long t = 0; t < 4 * 2500; t++) {
		// down through the floor to 5 mm below it and back up, at 1 Hz
		const double ph = std::cos(2 * 3.14159265358979 * t / 2500.0);
		const int32_t z = (int32_t)std::lround(-30000 - 25000 * (1 - ph) / 2 * 1.0);
		const int32_t v = (int32_t)std::lround(-25000 * 3.14159265358979 * std::sin(2 * 3.14159265358979 * t / 2500.0));
		s.tick(200000, 200000, z, v, &out);
		touched += out.penetration_lsb > 0;
		if (swell_um_to_lsb(z) >= s.b.floor_lsb) {
			const int64_t zl = swell_um_to_lsb(z), st = (int64_t)out.surface_lsb - zl;
			const int64_t sub = st < 0 ? 0 : (st > s.b.h_lsb ? s.b.h_lsb : st);
			const int64_t up = ((int64_t)s.b.k_q8 * sub + ((int64_t)1 << 23)) >> 24;
			const bool ok = out.f.floor_uN == 0 && out.penetration_lsb == 0 && out.delta_lsb == sub &&
				out.f.up_uN == up && out.f.total_uN == out.f.gravity_uN + out.f.up_uN + out.f.viscous_uN;
			checked++;
			if (!ok && wrong++ < 3)
				FAIL_CHECK("tick " << t << ", z " << z << " um: floor " << out.f.floor_uN << " uN, delta "
						   << out.delta_lsb << " against " << sub << ", up " << out.f.up_uN << " against "
						   << up);
		}
	}
	INFO(checked << " ticks above the floor checked, " << touched << " below it");
	CHECK(wrong == 0);
	CHECK(touched > 1000);
	CHECK(checked > 5000);
}

TEST_CASE("random motion through the floor keeps the volume invariant exact and the contact in [0, F_c_max]",
	  "[body][floor][coupling]")
{
	body_scene s(24, 0.02); // 150 mm pool, 50 mm deep
	s.p.a_um = 40000;
	s.p.b_um = 30000;
	s.p.h_um = 70000; // taller than the water: the column limits what it displaces
	REQUIRE(swell_body_set_params(&s.b, &s.p, &s.xf) == SWELL_OK);
	const int64_t inv0 = swell_body_invariant(&s.b, &s.w);
	std::mt19937 rng(17);
	std::uniform_real_distribution<double> u(-1, 1);
	double x = 75000, z = -40000, vx = 0, vz = 0;
	long bad = 0, floor_ticks = 0, out_of_range = 0;
	swell_body_out out;
	const long n = 200000;
	for (long t = 0; t < n; t++) {
		vx += 2000 * u(rng);
		vz += 4000 * u(rng);
		if (rng() % 500 == 0)
			vz = 300000 * u(rng);
		vx *= 0.999;
		vz *= 0.995;
		x += vx / 2500;
		z += vz / 2500 - 0.002 * (z + 48000); // hovers about the floor
		if ((x < -20000 && vx < 0) || (x > 170000 && vx > 0))
			vx = -vx;
		s.tick((int32_t)x, 75000, (int32_t)z, (int32_t)vz, &out);
		floor_ticks += out.penetration_lsb > 0;
		out_of_range += out.f.floor_uN < 0 || out.f.floor_uN > SWELL_BODY_FLOOR_F_MAX_UN;
		if (t % 10 == 9) {
			const int64_t d = swell_body_invariant(&s.b, &s.w) - inv0;
			if (d != 0 && bad++ < 3)
				FAIL_CHECK("tick " << t << ": invariant drifted by " << d << " LSB*cell");
		}
	}
	std::printf("random motion about the floor: %ld of %ld ticks below it, invariant %s\n", floor_ticks, n,
		    bad ? "drifted" : "exact");
	CHECK(bad == 0);
	CHECK(out_of_range == 0);
	CHECK(floor_ticks > n / 10);
	CHECK(s.b.floor_ticks > 0);
	CHECK(s.w.saturations == 0);
}
