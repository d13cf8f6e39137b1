/* The energy account (swell_ctl_energy) and the passivity controller (force.passivity): the fixed
 * point sums against double arithmetic, W against the analytic work, a passive scene in lockstep
 * with the HapticMaster model, an active one (a delayed stiff contact), and the safety limits. */
#include <catch2/catch.hpp>

#include "swell_msgs.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <random>
#include <vector>

extern "C" {
#include "hm_hand.h"
#include "hm_model.h"
#include "swell/ctl.h"
#include "swell/proto.h"
}

namespace {

swell_ctl_config pool()
{
	swell_ctl_config cfg;
	swell_ctl_default_config(&cfg);
	cfg.autorun = 1;
	return cfg;
}

struct Ctl {
	std::vector<int32_t> arena;
	swell_ctl c{};
	uint8_t seq = 0;
	explicit Ctl(const swell_ctl_config &cfg) : arena(swell_ctl_arena_words(cfg.nx, cfg.ny))
	{
		REQUIRE(swell_ctl_init(&c, &cfg, arena.data(), arena.size()) == SWELL_OK);
	}
	/* One device sample: position (um) and velocity (um/s), device frame, powered. */
	void sample(const int32_t x_um[3], const int32_t v_um_s[3])
	{
		swell_msg m{};
		m.type = SWELL_MSG_DEVICE_POS;
		m.u.device_pos.x_10um = (int16_t)std::lround(x_um[0] / 10.0);
		m.u.device_pos.y_10um = (int16_t)std::lround(x_um[1] / 10.0);
		m.u.device_pos.z_10um = (int16_t)std::lround(x_um[2] / 10.0);
		m.u.device_pos.seq = seq;
		m.u.device_pos.status = SWELL_DEV_POWERED;
		swell_ctl_rx(&c, SWELL_LINK_DEVICE, &m);
		m = swell_msg{};
		m.type = SWELL_MSG_DEVICE_VEL;
		m.u.device_vel.vx_100ums = (int16_t)std::clamp(std::lround(v_um_s[0] / 100.0), -30000L, 30000L);
		m.u.device_vel.vy_100ums = (int16_t)std::clamp(std::lround(v_um_s[1] / 100.0), -30000L, 30000L);
		m.u.device_vel.vz_100ums = (int16_t)std::clamp(std::lround(v_um_s[2] / 100.0), -30000L, 30000L);
		m.u.device_vel.seq = seq++;
		swell_ctl_rx(&c, SWELL_LINK_DEVICE, &m);
	}
	/* Held at x with velocity v for the 20 ticks autorun takes to start: the loop must be RUNNING. */
	void start(const int32_t x_um[3], const int32_t v_um_s[3])
	{
		for (int n = 0; n < 20; n++) {
			sample(x_um, v_um_s);
			tick();
		}
		REQUIRE(c.state == SWELL_CTL_RUNNING);
	}
	/* The tick's FORCE_CMD (enable 0 when none). */
	swell_msg_force_cmd tick()
	{
		swell_msg out[SWELL_CTL_QUEUE];
		swell_msg_force_cmd f{};
		swell_ctl_tick(&c);
		const size_t n = swell_ctl_tx(&c, SWELL_LINK_DEVICE, out, SWELL_CTL_QUEUE);
		for (size_t k = 0; k < n; k++)
			if (out[k].type == SWELL_MSG_FORCE_CMD)
				f = out[k].u.force_cmd;
		swell_ctl_tx(&c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
		return f;
	}
	void command(int32_t cmd)
	{
		const swell_msg m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_PARAM_COMMAND, cmd, seq);
		swell_ctl_rx(&c, SWELL_LINK_HOST, &m);
	}
	swell_energy_account energy() const
	{
		swell_energy_account e{};
		REQUIRE(swell_ctl_energy(&c, &e) == SWELL_OK);
		return e;
	}
};

/* The core against the HapticMaster model in lockstep: each tick the device steps with the hand and
 * the force it holds, reports, the controller ticks, and its FORCE_CMD reaches the device delay_ticks
 * ticks later (0: on the next tick). */
struct Loop {
	Ctl ctl;
	hm_params p{};
	hm_state s{};
	hm_hand hand{};
	std::deque<swell_msg_force_cmd> line;
	unsigned delay;
	double t = 0, f_max_seen_N = 0, df_max_seen_N = 0, f_last_N = 0;
	/* the device port's work as the device applied it: the cN it held times the wire's 10 um steps */
	int64_t port_work_pJ = 0;
	int32_t held_cN[3] = {0, 0, 0}, wire_um[3] = {0, 0, 0};
	Loop(const swell_ctl_config &cfg, const char *hand_spec, unsigned delay_ticks = 0) : ctl(cfg), delay(delay_ticks)
	{
		char why[160];
		double x0[3];
		hm_params_default(&p);
		REQUIRE(hm_hand_parse(hand_spec, &hand, why, sizeof(why)) == SWELL_OK);
		hm_hand_start(&hand, x0);
		hm_init(&s, x0);
	}
	void run(double seconds)
	{
		const double dt = 1.0 / p.rate_hz;
		for (long n = std::lround(seconds * p.rate_hz); n > 0; n--) {
			double fu[3] = {0, 0, 0};
			int32_t x[3], v[3];
			hm_hand_force(&hand, t, s.x, s.v, fu);
			hm_step(&p, &s, fu);
			t += dt;
			for (int k = 0; k < 3; k++) {
				x[k] = (int32_t)std::lround(s.x[k] * 1e6);
				v[k] = (int32_t)std::lround(s.v[k] * 1e6);
				const int32_t w = (int32_t)std::lround(x[k] / 10.0) * 10; // as Ctl::sample sends it
				port_work_pJ -= (int64_t)held_cN[k] * 10000 * (w - wire_um[k]);
				wire_um[k] = w;
			}
			ctl.sample(x, v);
			line.push_back(ctl.tick());
			const swell_msg_force_cmd f = line.front();
			if (line.size() > delay) {
				const double fN[3] = {f.fx_cN * 0.01, f.fy_cN * 0.01, f.fz_cN * 0.01};
				hm_command(&s, fN, f.enable);
				held_cN[0] = f.enable ? f.fx_cN : 0;
				held_cN[1] = f.enable ? f.fy_cN : 0;
				held_cN[2] = f.enable ? f.fz_cN : 0;
				line.pop_front();
				f_max_seen_N = std::max(f_max_seen_N, std::fabs(fN[2]));
				df_max_seen_N = std::max(df_max_seen_N, std::fabs(fN[2] - f_last_N));
				f_last_N = fN[2];
			}
		}
	}
};

} // namespace

TEST_CASE("energy: W is the analytic work of a constant force over a known displacement", "[energy]")
{
	// the object held still above the water: the force law gives -m g (0.981 N) on z; the device then
	// moves down 30 mm at a steady pace, 10 um a tick: W = -F dz = -(-0.98 N)(-30 mm) = -29.4 mJ on the
	// wire's 0.98 N, and S (m g z alone, clear of the water) falls by as much: D stays 0
	swell_ctl_config cfg = pool();
	Ctl c(cfg);
	int32_t x[3] = {0, 0, 100000}, v[3] = {0, 0, 0};
	c.start(x, v);
	for (int n = 0; n < 400; n++) { // the rate limit has the force at m g by now
		c.sample(x, v);
		c.tick();
	}
	const swell_energy_account e0 = c.energy();
	v[2] = -25000; // 10 um a tick at 2500 Hz
	for (int n = 0; n < 3000; n++) {
		x[2] -= 10;
		c.sample(x, v);
		REQUIRE(c.tick().fz_cN == -98);
	}
	const swell_energy_account e = c.energy();
	CHECK(e.work_uJ - e0.work_uJ == -29400); // 0.98 N x 30 mm, exact
	CHECK(e.stored_uJ - e0.stored_uJ == -29430); // m g dz with g 9.81: 0.981 N x 30 mm
	CHECK(e.balance_uJ - e0.balance_uJ == 30); // the wire's whole cN: 0.001 N x 30 mm
	CHECK(e.created_uJ == 0);
}

TEST_CASE("energy: the buoyancy springs' and the weight's fixed point energy against double arithmetic "
	  "on a known spring-mass trajectory",
	  "[energy]")
{
	// the object follows z(t) = z0 + A sin(w t) through the surface of a still pool with the
	// water's share left out (energy_water 0): S(n) - S(0) in the core against m g z + 1/2 k s^2 in
	// double at every 50th tick, within 2 uJ (the uJ rounding and the uN of k s)
	swell_ctl_config cfg = pool();
	cfg.energy_water = 0;
	Ctl c(cfg);
	const double k = 1000.0 * 9.81 * 0.05 * 0.05; // rho g a b, N/m
	const double m = 0.1, g = 9.81, h = 0.05;
	auto spring = [&](double sub) { // sub: submersion below the surface the force law read, m
		sub = std::max(sub, 0.0);
		return sub <= h ? 0.5 * k * sub * sub : 0.5 * k * h * h + k * h * (sub - h);
	};
	int32_t x[3] = {0, 0, 20000}, v[3] = {0, 0, 0};
	c.start(x, v);
	const double z0 = 0.020, A = 0.045, w = 2 * M_PI * 0.5;
	double worst = 0;
	for (int n = 1; n <= 5000; n++) {
		const double tt = n / 2500.0;
		x[2] = (int32_t)std::lround((z0 + A * std::sin(w * tt)) * 1e5) * 10; // the wire's 10 um
		c.sample(x, v);
		c.tick();
		// the object's own terms at the surface the force law read (its springs are what it renders)
		const swell_energy_account e = c.energy();
		const double z = x[2] * 1e-6, surface = c.c.out.surface_lsb / 65536.0 * 1e-3;
		const double expect = m * g * (z - z0) + (c.c.out.skipped ? 0.0 : spring(surface - z));
		if (n % 50 == 0)
			worst = std::max(worst, std::fabs(e.stored_uJ - e.water_uJ - expect * 1e6));
	}
	WARN("worst |S - S_double| on the trajectory: " << worst << " uJ");
	CHECK(worst <= 2.0);
}

TEST_CASE("energy: the water's share is the solver's invariant times rho g dx^2 / (2 e_eff): for a standing "
	  "mode at rest |S| times its potential energy 1/2 rho g sum h^2 dx^2",
	  "[energy][water]")
{
	// L9 h = S h for the mode cos(a (i + 1/2)) cos(b (j + 1/2)), S = -8 + 2 (1 + cos a)(1 + cos b): at
	// rest the invariant is e_eff |S| sum h^2, so the scale gives |S| 1/2 rho g sum h^2 dx^2, the
	// potential energy itself for waves with |S| = 1 (about nine cells long)
	const int nx = 64, ny = 64;
	const uint32_t dx_um = 6250;
	for (const auto &mode : std::vector<std::pair<int, int>>{{1, 0}, {4, 0}, {7, 3}, {12, 12}}) {
		swell_wave_params wp{};
		wp.e = SWELL_PARAM_DEF_WAVE_E;
		wp.damping = 0;
		wp.stencil = SWELL_STENCIL_PAPER;
		std::vector<int32_t> st(SWELL_WAVE_WORDS(nx, ny));
		swell_wave w{};
		REQUIRE(swell_wave_init(&w, nx, ny, st.data(), st.size(), &wp) == SWELL_OK);
		const double a = mode.first * M_PI / nx, b = mode.second * M_PI / ny;
		double sum2 = 0;
		for (int j = 0; j < ny; j++)
			for (int i = 0; i < nx; i++) {
				const int32_t hv = (int32_t)std::lround(2.0 * 65536 * std::cos(a * (i + 0.5)) *
									std::cos(b * (j + 0.5))); // 2 mm
				swell_wave_add(&w, i, j, hv);
				sum2 += (double)hv * hv;
			}
		swell_wave_rest(&w);
		const double S = 8 - 2 * (1 + std::cos(a)) * (1 + std::cos(b));
		const double pot_J = 0.5 * 1000 * 9.81 * std::pow(dx_um * 1e-6, 2) * sum2 * std::pow(1e-3 / 65536, 2);
		const double got_J = swell_ctl_water_pJ(&w, dx_um, 1000, 9810) * 1e-12;
		INFO("mode " << mode.first << "," << mode.second << ": |S| " << S << ", potential " << pot_J * 1e3
			     << " mJ, scaled invariant " << got_J * 1e3 << " mJ");
		// the heights are rounded to the LSB: a relative error below 1e-4 for these amplitudes
		CHECK(got_J == Approx(S * pot_J).epsilon(1e-4));
	}
}

TEST_CASE("energy: the reference drop in lockstep with the HapticMaster model creates at most 1 mJ, with the "
	  "controller off and on",
	  "[energy][loop]")
{
	for (int pc = 0; pc <= 1; pc++) {
		swell_ctl_config cfg = pool();
		cfg.passivity = (uint8_t)pc;
		cfg.energy_water = 1;
		Loop l(cfg, "drop:z=20,hold=0.5");
		l.run(10.0);
		const swell_energy_account e = l.ctl.energy();
		WARN("drop, passivity " << pc << ": W " << e.work_uJ << " uJ, S " << e.stored_uJ << " uJ (water " << e.water_uJ
					<< "), D " << e.balance_uJ << " uJ, created " << e.created_uJ << " uJ, damped "
					<< e.damped_uJ << " uJ on " << e.controller_ticks << " ticks, z " << l.s.x[2] * 1e3
					<< " mm");
		CHECK(e.created_uJ <= 1000);
		CHECK(e.ticks > 20000);
	}
}

TEST_CASE("energy: a stiff buoyancy spring behind 10 ms of link delay bounces and the account shows energy "
	  "created, and the controller's force stays within the safety limits",
	  "[energy][loop][passivity]")
{
	// a 200 x 200 mm box (buoyancy k = rho g a b = 392 N/m) without its damper, dropped onto the
	// water; its force reaches the device 25 ticks (10 ms) late, which outweighs the device's own
	// damping: the bounce grows until the force limit holds it. Under the reference rate limit
	// (500 N/s) the controller's force cannot follow the bounce: less energy created, not within 1 mJ.
	int64_t created[2] = {0, 0};
	for (int pc = 0; pc <= 1; pc++) {
		swell_ctl_config cfg = pool();
		cfg.passivity = (uint8_t)pc;
		cfg.body.a_um = cfg.body.b_um = 200000;
		cfg.body.damper_uN_per_mm_s = 0;
		cfg.energy_water = 1;
		Loop l(cfg, "drop:z=2,hold=0.5", 25);
		l.run(6.0);
		const swell_energy_account e = l.ctl.energy();
		WARN("delayed box, passivity " << pc << ": W " << e.work_uJ << " uJ, S " << e.stored_uJ << " uJ, D "
					       << e.balance_uJ << " uJ, created " << e.created_uJ << " uJ, damped " << e.damped_uJ
					       << " uJ on " << e.controller_ticks << " ticks; |F| max " << l.f_max_seen_N
					       << " N, |dF| max " << l.df_max_seen_N << " N a tick");
		created[pc] = e.created_uJ;
		CHECK(l.f_max_seen_N <= cfg.safety.f_max_uN * 1e-6 + 1e-9);
		CHECK(l.df_max_seen_N <= (double)(cfg.safety.rate_uN_per_s / cfg.tick_hz) * 1e-6 + 0.01 + 1e-9);
	}
	CHECK(created[0] > 1000);
}

TEST_CASE("passivity: a stiff buoyancy spring behind 4 ticks of link delay creates more than 1 mJ without the "
	  "controller and at most 1 mJ with it, within the safety limits",
	  "[energy][loop][passivity]")
{
	// the 200 mm box without its damper, its force 4 ticks (1.6 ms) late, force.rate at the top of its
	// range (2000 N/s, 0.8 N a tick): the bounce the delay feeds shows in the account as the force law's
	// coupling to the water it stirs, and the controller damps it as it grows (measured: 7.7 mJ
	// without, 0.54 mJ with; from 10 ticks of delay on, more than 1 mJ with it too)
	int64_t created[2] = {0, 0};
	for (int pc = 0; pc <= 1; pc++) {
		swell_ctl_config cfg = pool();
		cfg.passivity = (uint8_t)pc;
		cfg.body.a_um = cfg.body.b_um = 200000;
		cfg.body.damper_uN_per_mm_s = 0;
		cfg.safety.rate_uN_per_s = 2000000000u;
		cfg.energy_water = 1;
		cfg.pc_delay = 4;
		Loop l(cfg, "drop:z=2,hold=0.5", 4);
		l.run(6.0);
		const swell_energy_account e = l.ctl.energy();
		WARN("4 ticks delayed box, passivity " << pc << ": created " << e.created_uJ << " uJ, D " << e.balance_uJ
						       << " uJ, damped " << e.damped_uJ << " uJ on " << e.controller_ticks
						       << " ticks; |F| max " << l.f_max_seen_N << " N, |dF| max "
						       << l.df_max_seen_N << " N a tick");
		created[pc] = e.created_uJ;
		CHECK(l.f_max_seen_N <= cfg.safety.f_max_uN * 1e-6 + 1e-9);
		CHECK(l.df_max_seen_N <= (double)(cfg.safety.rate_uN_per_s / cfg.tick_hz) * 1e-6 + 0.01 + 1e-9);
	}
	CHECK(created[0] > 1000);
	CHECK(created[1] <= 1000);
}

TEST_CASE("energy: pressed into the floor's contact on a prescribed path, the rate-limited stiff contact "
	  "creates energy, and the controller takes some out within the safety limits",
	  "[energy][passivity]")
{
	int64_t created[2] = {0, 0};
	for (int pc = 0; pc <= 1; pc++) {
		swell_ctl_config cfg = pool();
		cfg.passivity = (uint8_t)pc;
		cfg.energy_water = 0;
		cfg.autorun = 0;
		Ctl c(cfg);
		int32_t x[3] = {0, 0, -49000}, v[3] = {0, 0, 0};
		for (int n = 0; n < 5000; n++) { // ARMED: the water settles around the object; then the run
			if (n == 4990)
				c.command(SWELL_CMD_RUN);
			c.sample(x, v);
			c.tick();
		}
		REQUIRE(c.c.state == SWELL_CTL_RUNNING);
		double f_max = 0, df_max = 0, f_last = c.c.force_dev_uN[2];
		const double z0 = -49.0e-3, amp = 2.0e-3, w = 2 * M_PI * 4;
		for (int n = 0; n < 5000; n++) {
			const double tt = n / 2500.0;
			x[2] = (int32_t)std::lround((z0 - amp * std::sin(w * tt)) * 1e5) * 10;
			v[2] = (int32_t)std::lround(-amp * w * std::cos(w * tt) * 1e6);
			c.sample(x, v);
			const swell_msg_force_cmd f = c.tick();
			f_max = std::max(f_max, std::fabs(f.fz_cN * 1e4));
			df_max = std::max(df_max, std::fabs(c.c.force_dev_uN[2] - f_last));
			f_last = c.c.force_dev_uN[2];
		}
		const swell_energy_account e = c.energy();
		WARN("floor path, passivity " << pc << ": W " << e.work_uJ << " uJ, S " << e.stored_uJ << " uJ, D "
					      << e.balance_uJ << " uJ, created " << e.created_uJ << " uJ, damped " << e.damped_uJ
					      << " uJ on " << e.controller_ticks << " ticks");
		created[pc] = e.created_uJ;
		CHECK(f_max <= cfg.safety.f_max_uN);
		CHECK(df_max <= cfg.safety.rate_uN_per_s / cfg.tick_hz);
	}
	// the contact's rise outruns the rate limit: the rendered force lags the spring, and the controller,
	// inside the same limit, cannot add force fast enough to hold D at zero (docs/energy.md)
	CHECK(created[0] > 1000);
	CHECK(created[1] < created[0]);
}

TEST_CASE("passivity: the controller's force is -alpha v along the force law's axis, alpha = -D / (v^2 dt) to 15 "
	  "significant bits while below force.pc_damping, else force.pc_damping, asked for on the tick after D went "
	  "below zero",
	  "[energy][passivity]")
{
	// the device goes down through the water reporting its velocity upward: the damper then pushes
	// along the motion, D falls below zero and the controller acts on every tick after; -D grows until
	// alpha reaches the bound
	swell_ctl_config cfg = pool();
	cfg.passivity = 1;
	cfg.pc_damping_uN_per_mm_s = 200000; // 200 N s/m: 10 N at the 50 mm/s reported, below force.max
	Ctl c(cfg);
	int32_t x[3] = {0, 0, 10000}, v[3] = {0, 0, 0};
	c.start(x, v);
	int below = 0, bounded = 0;
	for (int n = 0; n < 2500 && x[2] > -30000; n++) {
		x[2] -= 20;
		v[2] = 50000; // wrong sign: 50 mm/s up while it goes down at 50 mm/s
		c.sample(x, v);
		const int64_t d = c.c.energy.balance_pJ; // D after the last tick: what this tick's force part sees
		swell_ctl_tick_force(&c.c);
		const int32_t pc = c.c.energy.pc_uN[2];
		const double alpha = -(double)d * cfg.tick_hz / ((double)v[2] * v[2]); // uN per um/s
		const double b_max = cfg.pc_damping_uN_per_mm_s / 1000.0;
		if (d < 0) {
			const double want = -std::min(alpha, b_max) * v[2];
			INFO("tick " << n << ": D " << d << " pJ, alpha " << alpha << ", controller " << pc << " uN, want "
				     << want);
			CHECK(std::fabs(pc - want) <= std::fabs(want) * std::ldexp(1.0, -13) + 1.0);
			(alpha < b_max ? below : bounded)++;
		} else {
			CHECK(pc == 0);
		}
		swell_ctl_tick_background(&c.c);
		swell_msg out[SWELL_CTL_QUEUE];
		swell_ctl_tx(&c.c, SWELL_LINK_DEVICE, out, SWELL_CTL_QUEUE);
		swell_ctl_tx(&c.c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
	}
	INFO("ticks with alpha below the bound " << below << ", at it " << bounded);
	CHECK(below >= 10);
	CHECK(bounded >= 10);
	CHECK(c.energy().controller_ticks > 100);
}

TEST_CASE("passivity: with D far below zero, the fastest speed the wire carries and a fast tick, the "
	  "controller asks for force.pc_damping times the speed against the motion (its bound's test does not wrap)",
	  "[energy][passivity]")
{
	// the bound's test multiplies -D by the tick rate and 1000: at 50 kHz a D of -0.369 J makes that
	// 2^64 and a little, which, wrapped, would pick the unbounded alpha (2000 N s/m here, force.max at
	// 3 m/s) instead of the bound's 100 N s/m (300 N)
	swell_ctl_config cfg = pool();
	cfg.tick_hz = cfg.safety.tick_hz = 50000;
	cfg.solver_hz = 250;
	cfg.pc_damping_uN_per_mm_s = 100000; // 100 N s/m
	cfg.safety.f_max_uN = 1000000000u; // 1000 N
	Ctl c(cfg);
	int32_t x[3] = {0, 0, 10000}, v[3] = {0, 0, 0};
	c.start(x, v);
	for (int32_t speed : {3000000, -3000000, 100, -100}) {
		v[2] = speed;
		c.sample(x, v);
		c.c.energy.balance_pJ = -368934881475; // ceil(2^64 / (50000 x 1000)) pJ
		swell_ctl_tick_force(&c.c);
		const double want = -100.0 * speed; // -b_max v: uN per um/s times um/s
		INFO("v " << speed << " um/s: controller " << c.c.energy.pc_uN[2] << " uN, want " << want);
		CHECK(std::fabs(c.c.energy.pc_uN[2] - want) <= std::fabs(want) * 1e-4 + 1.0);
		swell_ctl_tick_background(&c.c);
		swell_msg out[SWELL_CTL_QUEUE];
		swell_ctl_tx(&c.c, SWELL_LINK_DEVICE, out, SWELL_CTL_QUEUE);
		swell_ctl_tx(&c.c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
	}
}

TEST_CASE("energy: with force.pc_delay set to the link's delay, W is the work of the force the device applied "
	  "over its motion, to the picojoule, and with 0 behind the same delay it is not",
	  "[energy][loop]")
{
	// the 200 mm box without its damper behind 6 ticks: its force changes on most ticks, so that a
	// force paired with the wrong tick's motion shows. The test sums what the device held (the cN it
	// was sent, 6 ticks late) times the wire's position steps, from 1 s into the run to 3 s
	for (int told = 0; told <= 1; told++) {
		swell_ctl_config cfg = pool();
		cfg.body.a_um = cfg.body.b_um = 200000;
		cfg.body.damper_uN_per_mm_s = 0;
		cfg.safety.rate_uN_per_s = 2000000000u;
		cfg.pc_delay = (uint8_t)(told ? 6 : 0);
		Loop l(cfg, "drop:z=2,hold=0.5", 6);
		l.run(1.0);
		REQUIRE(l.ctl.c.state == SWELL_CTL_RUNNING);
		const int64_t w0 = l.ctl.c.energy.work_pJ, p0 = l.port_work_pJ;
		l.run(2.0);
		const int64_t w = l.ctl.c.energy.work_pJ - w0, port = l.port_work_pJ - p0;
		INFO("force.pc_delay " << (int)cfg.pc_delay << ": W " << w << " pJ, the device's port " << port << " pJ");
		REQUIRE(port != 0);
		if (told)
			CHECK(w == port);
		else
			CHECK(std::llabs(w - port) > 1000000); // more than a microjoule apart
	}
}

TEST_CASE("passivity: on random device traffic every FORCE_CMD stays within force.max and moves by at most "
	  "force.rate a tick, and the controller's force within force.pc_damping times the speed, with the controller "
	  "acting",
	  "[energy][passivity][safety]")
{
	std::mt19937 rng(7);
	for (int run = 0; run < 4; run++) {
		swell_ctl_config cfg = pool();
		cfg.passivity = 1;
		cfg.safety.f_max_uN = run % 2 ? 2000000u : 10000000u;
		cfg.safety.rate_uN_per_s = run < 2 ? 500000000u : 50000000u;
		Ctl c(cfg);
		const int32_t step = (int32_t)(cfg.safety.rate_uN_per_s / cfg.tick_hz), lim = (int32_t)cfg.safety.f_max_uN;
		int32_t x[3] = {0, 0, 5000}, v[3] = {0, 0, 0}, f_last = 0;
		std::uniform_int_distribution<int32_t> dz(-60, 40), dxy(-50, 50), gain(-3, 1);
		int violations = 0, over_bound = 0;
		for (int n = 0; n < 20000; n++) {
			const int32_t step_z = dz(rng);
			x[0] += dxy(rng);
			x[1] += dxy(rng);
			x[2] = std::clamp(x[2] + step_z, -80000, 40000);
			// mostly against the motion: the damper pushes along it and the account sees energy created
			v[2] = step_z * 2500 * gain(rng);
			c.sample(x, v);
			const swell_msg_force_cmd f = c.tick();
			const int32_t uN = f.fz_cN * 10000;
			violations += std::abs(uN) > lim || (n > 20 && std::abs(uN - f_last) > step + 5000);
			// the controller's own force: never more than force.pc_damping times the speed reported
			over_bound += std::fabs((double)c.c.energy.pc_uN[2]) >
				cfg.pc_damping_uN_per_mm_s / 1000.0 * std::fabs((double)v[2]) + 1.0;
			f_last = uN;
		}
		const swell_energy_account e = c.energy();
		INFO("run " << run << ": the controller acted on " << e.controller_ticks << " ticks");
		CHECK(e.controller_ticks > 100);
		CHECK(violations == 0);
		CHECK(over_bound == 0);
	}
}

TEST_CASE("passivity: in effect mode the controller stays out (the device renders the effect set itself) while "
	  "the account goes on",
	  "[energy][passivity][effect]")
{
	// the same wrong-signed velocity that makes the controller act on every tick in stream mode
	swell_ctl_config cfg = pool();
	cfg.passivity = 1;
	cfg.force_mode = SWELL_FORCE_EFFECT;
	Ctl c(cfg);
	int32_t x[3] = {0, 0, 10000}, v[3] = {0, 0, 0};
	c.start(x, v);
	for (int n = 0; n < 2000 && x[2] > -30000; n++) {
		x[2] -= 20;
		v[2] = 50000;
		c.sample(x, v);
		c.tick();
		CHECK(c.c.energy.pc_uN[2] == 0);
	}
	const swell_energy_account e = c.energy();
	CHECK(e.controller_ticks == 0);
	CHECK(e.ticks > 1500);
	CHECK(e.created_uJ > 0); // the damper pushed along the motion: the account saw it
}
