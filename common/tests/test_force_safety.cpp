// The safety stage on every force output (common/src/force_safety.c), alone and behind the force law.
#include <catch2/catch.hpp>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>

#include "body_scene.hpp"

extern "C" {
#include "swell/force_safety.h"
#include "swell/pool.h"
}

static swell_fsafety_params limits(uint32_t f_max, uint32_t rate)
{
	swell_fsafety_params p{};
	p.gain = SWELL_Q16_ONE;
	p.f_max_uN = f_max;
	p.rate_uN_per_s = rate;
	p.tick_hz = SWELL_POOL_TICK_HZ;
	return p;
}

TEST_CASE("under random force inputs the output never exceeds f_max nor changes faster than the rate", "[safety]")
{
	std::mt19937 rng(7);
	for (int trial = 0; trial < 20; trial++) {
		std::uniform_int_distribution<uint32_t> fm(1, 50000000), rt(2500, 2000000000);
		swell_fsafety_params p = limits(fm(rng), rt(rng));
		p.gain = (q16_t)(rng() % (SWELL_FSAFETY_MAX_GAIN + 1));
		swell_fsafety s;
		REQUIRE(swell_fsafety_init(&s, &p) == SWELL_OK);
		const int64_t step = p.rate_uN_per_s / p.tick_hz;
		int32_t prev = 0;
		long over = 0, fast = 0;
		for (int t = 0; t < 20000; t++) {
			int32_t in = (int32_t)rng(); // any int32, including the extremes
			if (t % 97 == 0)
				in = t % 2 ? INT32_MIN : INT32_MAX;
			int32_t out = swell_fsafety_apply(&s, in, 1);
			over += (int64_t)std::abs((int64_t)out) > p.f_max_uN;
			fast += std::abs((int64_t)out - prev) > step;
			prev = out;
		}
		INFO("f_max " << p.f_max_uN << " uN, rate " << p.rate_uN_per_s << " uN/s: " << over << " ticks over f_max, "
			      << fast << " ticks too fast");
		CHECK(over == 0);
		CHECK(fast == 0);
		if (step < 2 * (int64_t)p.f_max_uN) // else no change can be too fast
			CHECK(s.rate_limited > 0);
		CHECK(s.force_limited > 0);
	}
}

TEST_CASE("behind the force law, random trajectories never give more than f_max or faster than the rate", "[safety][body]")
{
	body_scene sc(32, 0.01);
	swell_fsafety_params p = limits(2000000, 200000000); // 2 N, 200 N/s (80 mN a tick)
	swell_fsafety s;
	REQUIRE(swell_fsafety_init(&s, &p) == SWELL_OK);
	std::mt19937 rng(9);
	std::uniform_real_distribution<double> u(-1, 1);
	double x = 100000, y = 100000, z = 0, vz = 0;
	int32_t prev = 0, raw_max = 0;
	int64_t raw_step_max = 0, prev_raw = 0, out_max = 0, step_max = 0;
	for (long t = 0; t < 200000; t++) {
		vz += 20000 * u(rng);
		if (rng() % 300 == 0)
			vz = 1000000 * u(rng); // slams at up to 1 m/s
		vz *= 0.99;
		z += vz / 2500 - 0.001 * z;
		x += 50 * u(rng);
		y += 50 * u(rng);
		swell_body_out o;
		sc.tick((int32_t)x, (int32_t)y, (int32_t)z, (int32_t)vz, &o);
		int running = (t / 20000) % 5 != 4; // stopped now and then
		int32_t f = swell_fsafety_apply(&s, o.f.total_uN, running);
		raw_max = std::max(raw_max, std::abs(o.f.total_uN));
		raw_step_max = std::max(raw_step_max, std::abs((int64_t)o.f.total_uN - prev_raw));
		prev_raw = o.f.total_uN;
		if (!running)
			REQUIRE(f == 0);
		else
			step_max = std::max(step_max, std::abs((int64_t)f - prev));
		out_max = std::max(out_max, std::abs((int64_t)f));
		prev = f;
	}
	std::printf("random trajectories: force law up to %.3f N and %.3f N per tick; after safety %.3f N "
		    "(limit %.3f) and %.4f N per tick (limit %.4f)\n",
		    raw_max * 1e-6, raw_step_max * 1e-6, out_max * 1e-6, p.f_max_uN * 1e-6, step_max * 1e-6,
		    p.rate_uN_per_s * 1e-6 / p.tick_hz);
	INFO("raw max " << raw_max << " uN, out max " << out_max << " uN, step max " << step_max << " uN");
	CHECK(out_max <= p.f_max_uN);
	CHECK(step_max <= p.rate_uN_per_s / p.tick_hz);
	// the limits were really exercised
	CHECK(raw_max > (int32_t)p.f_max_uN);
	CHECK(raw_step_max > p.rate_uN_per_s / p.tick_hz);
}

TEST_CASE("not running gives zero at once, and running again ramps up from zero", "[safety]")
{
	swell_fsafety_params p = limits(1000000, 25000000); // 1 N, 10 mN a tick
	swell_fsafety s;
	REQUIRE(swell_fsafety_init(&s, &p) == SWELL_OK);
	int32_t out = 0;
	for (int t = 0; t < 200; t++)
		out = swell_fsafety_apply(&s, 800000, 1);
	CHECK(out == 800000);
	CHECK(swell_fsafety_apply(&s, 800000, 0) == 0);
	CHECK(s.zeroed == 1);
	CHECK(swell_fsafety_apply(&s, 800000, 1) == 10000);
	CHECK(swell_fsafety_apply(&s, 800000, 1) == 20000);
}

TEST_CASE("the haptic gain scales the force before the limits", "[safety]")
{
	swell_fsafety_params p = limits(1000000, 4000000000u); // 1.6 N a tick
	p.gain = SWELL_Q16_ONE / 4;
	swell_fsafety s;
	REQUIRE(swell_fsafety_init(&s, &p) == SWELL_OK);
	CHECK(swell_fsafety_apply(&s, 400000, 1) == 100000);
	CHECK(swell_fsafety_apply(&s, -400001, 1) == -100000);
	CHECK(swell_fsafety_apply(&s, 8000000, 1) == 1000000); // 2 N after gain, cut to 1 N
	CHECK(s.force_limited == 1);
}

TEST_CASE("every safety limit is validated and a rejected value changes nothing", "[safety]")
{
	swell_fsafety_params good = limits(1000000, 25000000);
	swell_fsafety s;
	REQUIRE(swell_fsafety_init(&s, &good) == SWELL_OK);
	for (int t = 0; t < 100; t++)
		swell_fsafety_apply(&s, 500000, 1);
	REQUIRE(s.out_uN == 500000);
	swell_fsafety before = s;

	swell_fsafety_params bad[6] = {good, good, good, good, good, good};
	bad[0].gain = -1;
	bad[1].gain = SWELL_FSAFETY_MAX_GAIN + 1;
	bad[2].f_max_uN = 0;
	bad[3].f_max_uN = SWELL_FSAFETY_MAX_FORCE_UN + 1;
	bad[4].rate_uN_per_s = good.tick_hz - 1; // less than 1 uN a tick
	bad[5].tick_hz = 5;
	for (auto &b : bad) {
		CHECK(swell_fsafety_set(&s, &b) == SWELL_ERANGE);
		CHECK(std::memcmp(&s, &before, sizeof(s)) == 0);
	}
	CHECK(swell_fsafety_set(&s, nullptr) == SWELL_EINVAL);
	swell_fsafety fresh;
	std::memset(&fresh, 0x33, sizeof(fresh));
	swell_fsafety fresh0 = fresh;
	CHECK(swell_fsafety_init(&fresh, &bad[2]) == SWELL_ERANGE);
	CHECK(std::memcmp(&fresh, &fresh0, sizeof(fresh)) == 0);

	// a lowered limit cuts the output at once: the force bound beats the rate bound
	swell_fsafety_params lower = good;
	lower.f_max_uN = 100000;
	REQUIRE(swell_fsafety_set(&s, &lower) == SWELL_OK);
	CHECK(swell_fsafety_apply(&s, 500000, 1) == 100000);
}
