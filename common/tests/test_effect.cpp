// Effect mode (swell/effect.h): the effect set the controller sends at an update instant produces, at
// the device, the force the force law computes at that instant, within the wire's quantisation.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>

#include "body_scene.hpp"

extern "C" {
#include "swell/effect.h"
#include "swell/shape.h"
}

namespace {

constexpr int32_t MM = 65536; // solver LSB per mm

int64_t iabs(int64_t x) { return x < 0 ? -x : x; }

} // namespace

TEST_CASE("effect set: springs + damper + bias at the device equal the force law's k clamp(w - z, 0, H) + viscous + "
	  "gravity at every update instant, within the wire's quantisation",
	  "[effect]")
{
	std::mt19937 rng(17);
	auto uni = [&](int32_t lo, int32_t hi) { return std::uniform_int_distribution<int32_t>(lo, hi)(rng); };
	int states = 0, wet = 0, exact_springs = 0, exact_gravity = 0;
	double worst_ratio = 0, worst_uN = 0;

	for (int n = 0; n < 400; n++) {
		body_scene s(64, 0.002);
		s.p.a_um = (uint32_t)uni(20, 100) * 1000;
		s.p.b_um = (uint32_t)uni(20, 100) * 1000;
		s.p.h_um = (uint32_t)uni(20, 80) * 1000 + (uint32_t)uni(0, 999);
		s.p.mass_g = (uint32_t)uni(10, 400);
		s.p.damper_uN_per_mm_s = (uint32_t)uni(0, 30000);
		REQUIRE(swell_body_set_params(&s.b, &s.p, &s.xf) == SWELL_OK);
		swell_shape_seiche(s.w.h, s.w.nx, s.w.ny, (uint16_t)uni(1, 3), (uint16_t)uni(0, 2), uni(0, 5 * MM));
		swell_body_rescan(&s.b, &s.w);
		// the box held at a random depth (above the floor at -50 mm: effect mode renders no floor),
		// moving at a random speed, for a random number of ticks: the waves and u_w's filter move
		const int32_t x = uni(60000, 340000), y = uni(60000, 340000);
		swell_body_out out{};
		int32_t z = 0, vz = 0;
		const int ticks = uni(1, 60);
		for (int t = 0; t < ticks; t++) {
			z = uni(-4800, 1500) * 10; // um, on the wire's 0.01 mm grid
			vz = uni(-3000, 3000) * 100; // um/s, on the wire's 0.1 mm/s grid
			s.tick(x, y, z, vz, &out);
		}
		REQUIRE(out.f.floor_uN == 0);
		swell_effect e{};
		swell_effect_from_body(&e, &s.b, &out, 0, 10000000, 500000000);
		const int64_t f_dev = swell_effect_force_uN(&e, z / 10, vz / 100);
		const int64_t f_law = out.f.total_uN;
		const int64_t diff = f_dev - f_law;

		// the quantisation, term by term (each clamp is 1-Lipschitz):
		// springs: k to 0.01 N/m (10 uN/mm) over at most H, w and H to 0.01 mm, both roundings (1 uN)
		const double k_uN_mm = s.b.k_q8 / 256.0, k_wire = e.k_10mN_m * 10.0;
		const double w_um = out.surface_lsb * 1000.0 / MM, delta_mm = out.delta_lsb / (double)MM;
		const double h_err_um = std::fabs(e.h_10um * 10.0 - s.b.h_lsb * 1000.0 / MM); // H to 0.01 mm
		const double b_spr = std::fabs(k_wire - k_uN_mm) * delta_mm +
			k_wire * (std::fabs(e.surface_10um * 10.0 - w_um) + h_err_um) / 1000.0 + 1.0;
		// damper: b s to 0.01 N s/m (10 uN per mm/s), u_w to 0.1 mm/s, both roundings (1 uN)
		// the force law's own b s: rounded to a whole uN per mm/s, as body.c has it
		const double bs = (double)(((int64_t)s.p.damper_uN_per_mm_s * out.delta_lsb + s.b.h_lsb / 2) / s.b.h_lsb);
		const double dv_mm_s = (vz - out.surface_um_s) / 1000.0;
		const double b_visc = std::fabs(e.b_10mNs_m * 10.0 - bs) * std::fabs(dv_mm_s) +
			e.b_10mNs_m * 10.0 * std::fabs(e.uw_100ums * 100.0 - out.surface_um_s) / 1000.0 + 1.0;
		// gravity: to the mN
		const double b_grav = std::fabs(e.bias_mN * 1000.0 - out.f.gravity_uN);
		const double bound = b_spr + b_visc + b_grav;
		INFO("state " << n << ": z " << z << " um, v " << vz << " um/s, w " << w_um << " um, delta " << delta_mm
			      << " mm, k " << k_uN_mm << " uN/mm (wire " << k_wire << "), b s " << bs << " (wire "
			      << e.b_10mNs_m * 10 << "), u_w " << out.surface_um_s << " um/s (wire " << e.uw_100ums * 100
			      << "), m g " << -out.f.gravity_uN << " uN (wire " << -e.bias_mN * 1000 << "): device " << f_dev
			      << " uN, force law " << f_law << " uN, difference " << diff << ", bound " << bound);
		CHECK((double)iabs(diff) <= bound);
		// the gravity is exact whenever m g is a whole mN, and the springs whenever w and k are on the
		// wire's grid; tally how often
		exact_gravity += b_grav == 0;
		exact_springs += b_spr <= 1.0;
		states++;
		wet += out.delta_lsb > 0;
		worst_uN = std::max(worst_uN, (double)iabs(diff));
		worst_ratio = std::max(worst_ratio, iabs(diff) / bound);
	}
	std::printf("effect set against the force law: %d states (%d in the water), largest difference %.0f uN, "
		    "at most %.2f of its bound; gravity exact in %d, springs within 1 uN in %d\n",
		    states, wet, worst_uN, worst_ratio, exact_gravity, exact_springs);
	CHECK(wet > states / 2);
}

TEST_CASE("effect set: the device takes a set only when the three parts of one update are in, never a mix", "[effect]")
{
	swell_effect a{}, b{}, got{};
	a.surface_10um = -1234;
	a.uw_100ums = 56;
	a.k_10mN_m = 2453;
	a.b_10mNs_m = 1200;
	a.bias_mN = -981;
	a.h_10um = 5000;
	a.fmax_cN = 1000;
	a.rate_100mN_s = 5000;
	a.seq = 7;
	b = a;
	b.surface_10um = 99;
	b.seq = 8;
	swell_msg ma[3], mb[3];
	swell_effect_encode(&a, 0, ma);
	swell_effect_encode(&b, 0, mb);
	swell_effect_rx r{};
	// spring and damper of update 7, then the limit of update 8 and the rest of 8: only 8 completes
	CHECK(swell_effect_recv(&r, &ma[0], &got) == 0);
	CHECK(swell_effect_recv(&r, &ma[1], &got) == 0);
	CHECK(swell_effect_recv(&r, &mb[2], &got) == 0);
	CHECK(swell_effect_recv(&r, &mb[0], &got) == 0);
	CHECK(swell_effect_recv(&r, &mb[1], &got) == 1);
	CHECK(got.seq == 8);
	CHECK(got.surface_10um == 99);
	CHECK(got.b_10mNs_m == 1200);
	CHECK(got.fmax_cN == 1000);
	// in any order, one update completes once
	got = swell_effect{};
	CHECK(swell_effect_recv(&r, &ma[2], &got) == 0);
	CHECK(swell_effect_recv(&r, &ma[0], &got) == 0);
	CHECK(swell_effect_recv(&r, &ma[1], &got) == 1);
	CHECK(got.surface_10um == -1234);
	CHECK(got.uw_100ums == 56);
	CHECK(got.k_10mN_m == 2453);
	CHECK(got.bias_mN == -981);
	CHECK(got.h_10um == 5000);
	CHECK(got.rate_100mN_s == 5000);
	swell_msg other{};
	other.type = SWELL_MSG_HEARTBEAT;
	CHECK(swell_effect_recv(&r, &other, &got) == -1);
	// the set's force: k clamp(surface - z, 0, H) - b (v - u_w) + bias, in uN
	CHECK(swell_effect_force_uN(&a, 0, 56) == -981000); // above the surface, at u_w: gravity only
	CHECK(swell_effect_force_uN(&a, -1234 - 4000, 56) == 2453 * 4000 / 10 - 981000); // 40 mm in, at u_w
	CHECK(swell_effect_force_uN(&a, -1234 - 9000, 56) == 2453 * 5000 / 10 - 981000); // under: k H
	CHECK(swell_effect_force_uN(&a, -1234 - 4000, 156) == 2453 * 4000 / 10 - 1200 * 100 - 981000);
}
