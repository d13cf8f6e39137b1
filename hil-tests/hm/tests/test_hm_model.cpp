// The HapticMaster model's maths: integration, damping, watchdog, limits, walls, hands, refusals.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>

extern "C" {
#include "hm_hand.h"
#include "hm_model.h"
}

namespace {

hm_params params()
{
	hm_params p;
	hm_params_default(&p);
	return p;
}

const double origin[3] = {0.0, 0.0, 0.0};
const double no_force[3] = {0.0, 0.0, 0.0};

} // namespace

TEST_CASE("a free mass under a constant force follows x = F t^2 / 2m (semi-implicit Euler, O(dt) term known)")
{
	hm_params p = params();
	p.damping_Ns_m = 0.0;
	p.mass_kg = 2.5;
	p.limit_m[0] = p.limit_m[1] = p.limit_m[2] = 0.3; // stays clear of the walls
	const double f[3] = {0.8, 0.0, -0.4};
	const double dt = 1.0 / p.rate_hz;
	hm_state s;
	hm_init(&s, origin);
	const int n = 2500; // 1 s
	for (int i = 0; i < n; i++)
		hm_step(&p, &s, f);
	const double t = n * dt;
	for (int k : {0, 2}) {
		const double a = f[k] / p.mass_kg;
		// discrete: v_n = n a dt, x_n = a dt^2 n (n + 1) / 2 = a t^2 / 2 + a t dt / 2
		const double x_discrete = a * dt * dt * n * (n + 1) / 2.0;
		const double x_cont = a * t * t / 2.0;
		INFO("axis " << k << ": x " << s.x[k] << " m, discrete " << x_discrete << " m, continuous " << x_cont << " m, v "
			     << s.v[k] << " m/s vs " << a * t);
		CHECK(std::fabs(s.x[k] - x_discrete) <= 1e-12 * std::fabs(x_discrete));
		CHECK(std::fabs(s.v[k] - a * t) <= 1e-12 * std::fabs(a * t));
		CHECK(std::fabs(s.x[k] - x_cont) <= std::fabs(a) * t * dt / 2.0 * (1.0 + 1e-9));
		CHECK(std::fabs(s.x[k] - x_cont) / std::fabs(x_cont) < 1e-3);
	}
	CHECK(s.x[1] == 0.0);
	CHECK(s.v[1] == 0.0);
}

TEST_CASE("virtual damping decays the velocity as exp(-b t / m) and the coasting distance is v0 m / b")
{
	hm_params p = params();
	p.damping_Ns_m = 4.0;
	const double dt = 1.0 / p.rate_hz, v0 = 0.1;
	hm_state s;
	hm_init(&s, origin);
	s.v[0] = v0;
	const int n = 2500;
	for (int i = 0; i < n; i++)
		hm_step(&p, &s, no_force);
	const double r = p.damping_Ns_m * dt / p.mass_kg;
	const double v_discrete = v0 * std::pow(1.0 - r, n);
	const double v_cont = v0 * std::exp(-p.damping_Ns_m * n * dt / p.mass_kg);
	INFO("v " << s.v[0] << " m/s, discrete " << v_discrete << ", exp " << v_cont);
	CHECK(std::fabs(s.v[0] - v_discrete) <= 1e-12 * v_discrete);
	// (1 - r)^n = exp(-n r - n r^2 / 2 - ...): relative difference about n r^2 / 2
	CHECK(std::fabs(s.v[0] - v_cont) / v_cont <= n * r * r / 2.0 * 1.01);
	CHECK(std::fabs(s.v[0] - v_cont) / v_cont < 1e-3);
	for (int i = 0; i < 20 * n; i++)
		hm_step(&p, &s, no_force);
	const double coast = v0 * p.mass_kg / p.damping_Ns_m;
	INFO("coasted " << s.x[0] << " m, expected " << coast << " m");
	CHECK(std::fabs(s.x[0] - coast) / coast < 1e-3);
}

TEST_CASE("the watchdog holds a command at most watchdog-1 silent ticks, then applies zero force")
{
	for (uint32_t wd : {1u, 2u, 5u}) {
		hm_params p = params();
		p.watchdog_ticks = wd;
		hm_state s;
		hm_init(&s, origin);
		const double f[3] = {1.0, -2.0, 3.0};
		hm_command(&s, f, 1);
		uint32_t applied = 0;
		for (int i = 0; i < 20; i++) {
			hm_step(&p, &s, no_force);
			if (s.applying) {
				applied++;
				CHECK(s.f_cmd_N[1] == -2.0);
			} else {
				CHECK(s.f_cmd_N[0] == 0.0);
				CHECK(s.f_cmd_N[1] == 0.0);
				CHECK(s.f_cmd_N[2] == 0.0);
			}
		}
		INFO("watchdog " << wd << " ticks: command applied in " << applied << " ticks, trips " << s.watchdog_trips);
		CHECK(applied == wd);
		CHECK(s.watchdog_trips == 1);
		// a fresh command is applied again at once
		hm_command(&s, f, 1);
		hm_step(&p, &s, no_force);
		CHECK(s.applying == 1);
		CHECK(s.f_cmd_N[2] == 3.0);
	}
}

TEST_CASE("a command with enable 0 or during an e-stop applies no force and is no watchdog trip")
{
	hm_params p = params();
	hm_state s;
	hm_init(&s, origin);
	const double f[3] = {5.0, 5.0, 5.0};
	hm_command(&s, f, 0);
	hm_step(&p, &s, no_force);
	CHECK(s.applying == 0);
	CHECK(s.f_cmd_N[0] == 0.0);
	CHECK(s.v[0] == 0.0);
	hm_command(&s, f, 1);
	s.estop = 1;
	hm_step(&p, &s, no_force);
	CHECK(s.applying == 0);
	CHECK(s.v[2] == 0.0);
	CHECK(s.watchdog_trips == 0);
	s.estop = 0;
	hm_command(&s, f, 1);
	hm_step(&p, &s, no_force);
	CHECK(s.applying == 1);
	CHECK(s.v[2] > 0.0);
}

TEST_CASE("the commanded force is limited to f_max per axis, sign kept")
{
	hm_params p = params();
	p.f_max_N = 40.0;
	hm_state s;
	hm_init(&s, origin);
	const double f[3] = {100.0, -100.0, 12.5};
	hm_command(&s, f, 1);
	hm_step(&p, &s, no_force);
	CHECK(s.f_cmd_N[0] == 40.0);
	CHECK(s.f_cmd_N[1] == -40.0);
	CHECK(s.f_cmd_N[2] == 12.5);
}

TEST_CASE("a workspace wall stops a device pushed into it at limit + F / k_wall and never pulls")
{
	hm_params p = params();
	const double push[3] = {50.0, 0.0, -50.0};
	hm_state s;
	hm_init(&s, origin);
	for (int i = 0; i < 5 * 2500; i++)
		hm_step(&p, &s, push);
	const double pen = 50.0 / p.wall_k_N_m;
	INFO("x " << s.x[0] * 1e3 << " mm, z " << s.x[2] * 1e3 << " mm, expected +-" << (p.limit_m[0] + pen) * 1e3 << " mm");
	CHECK(std::fabs(s.x[0] - (p.limit_m[0] + pen)) < 1e-3 * pen);
	CHECK(std::fabs(s.x[2] + (p.limit_m[2] + pen)) < 1e-3 * pen);
	CHECK(s.wall_ticks > 0);
	// leaving the wall fast: the wall's damper must not hold it back
	hm_init(&s, origin);
	s.x[0] = p.limit_m[0] + 0.001;
	s.v[0] = -1.0;
	hm_step(&p, &s, no_force);
	CHECK(s.f_wall_N[0] <= 0.0);
}

TEST_CASE("device parameters outside their range or the stability limit are refused with a reason")
{
	char why[160];
	hm_params p = params();
	CHECK(hm_params_check(&p, 2000.0, 60.0, why, sizeof why) == SWELL_OK);

	struct bad {
		const char *what;
		void (*set)(hm_params *);
		double hand_k;
		swell_err want;
	};
	const bad cases[] = {
		{"rate 0", [](hm_params *q) { q->rate_hz = 0.0; }, 0.0, SWELL_ERANGE},
		{"mass 0", [](hm_params *q) { q->mass_kg = 0.0; }, 0.0, SWELL_ERANGE},
		{"mass NaN", [](hm_params *q) { q->mass_kg = NAN; }, 0.0, SWELL_ERANGE},
		{"negative damping", [](hm_params *q) { q->damping_Ns_m = -1.0; }, 0.0, SWELL_ERANGE},
		{"limit 400 mm", [](hm_params *q) { q->limit_m[1] = 0.4; }, 0.0, SWELL_ERANGE},
		{"f_max 300 N", [](hm_params *q) { q->f_max_N = 300.0; }, 0.0, SWELL_ERANGE},
		{"watchdog 0", [](hm_params *q) { q->watchdog_ticks = 0; }, 0.0, SWELL_ERANGE},
		{"hand 1e7 N/m", [](hm_params *) {}, 1e7, SWELL_EUNSTABLE},
		{"wall 1e8 N/m", [](hm_params *q) { q->wall_k_N_m = 1e8; }, 0.0, SWELL_EUNSTABLE},
		{"damping 5000 N s/m on 2 kg", [](hm_params *q) { q->damping_Ns_m = 5000.0; }, 0.0, SWELL_EUNSTABLE},
	};
	for (const bad &c : cases) {
		hm_params q = params();
		c.set(&q);
		why[0] = '\0';
		const swell_err e = hm_params_check(&q, c.hand_k, 0.0, why, sizeof why);
		INFO(c.what << ": " << swell_err_str(e) << " (" << why << ")");
		CHECK(e == c.want);
		CHECK(std::strlen(why) > 10);
	}
}

TEST_CASE("hand scripts parse with units and refuse unknown names, keys and values without effect")
{
	char why[160];
	hm_hand h;
	REQUIRE(hm_hand_parse("press:at=1.5,depth=30,ramp=0.25,hold=1,k=3000", &h, why, sizeof why) == SWELL_OK);
	CHECK(h.kind == HM_HAND_PRESS);
	CHECK(h.at_s == 1.5);
	CHECK(h.depth_m == Approx(0.030));
	CHECK(h.ramp_s == 0.25);
	CHECK(h.k_N_m == 3000.0);
	REQUIRE(hm_hand_parse("shake:axis=x,f=2,amp=5,for=0", &h, why, sizeof why) == SWELL_OK);
	CHECK(h.axis == 0);
	CHECK(h.amp_m == Approx(0.005));

	const hm_hand before = h;
	const struct {
		const char *spec;
		swell_err want;
	} cases[] = {
		{"wave", SWELL_EUNKNOWN},       {"drop:depth=3", SWELL_EUNKNOWN}, {"drop:z=abc", SWELL_ERANGE},
		{"drop:z=500", SWELL_ERANGE},   {"shake:axis=w", SWELL_ERANGE},   {"shake:f=0", SWELL_ERANGE},
		{"press:ramp=0", SWELL_ERANGE}, {"idle:k=-1", SWELL_ERANGE},      {"drop:z", SWELL_ERANGE},
		{"release:at=1,", SWELL_OK},
	};
	for (const auto &c : cases) {
		hm_hand g = before;
		why[0] = '\0';
		const swell_err e = hm_hand_parse(c.spec, &g, why, sizeof why);
		INFO(c.spec << ": " << swell_err_str(e) << " (" << why << ")");
		CHECK(e == c.want);
		if (c.want != SWELL_OK) {
			CHECK(std::memcmp(&g, &before, sizeof g) == 0);
			CHECK(std::strlen(why) > 10);
		}
	}
}

namespace {

// Runs the device with a hand and no controller; returns the z range (mm) over [t0, t1).
struct trace {
	double z_min = 1e9, z_max = -1e9, x_min = 1e9, x_max = -1e9;
	int held_ticks = 0;
	double f_after_release = 0.0;
	double z_end = 0.0;
};

// cmd_z: a fresh enabled FORCE_CMD every tick (as the controller's gravity would be), in N.
trace run_hand(const char *spec, double seconds, double t0, double t1, double cmd_z = 0.0)
{
	hm_params p = params();
	hm_hand h;
	REQUIRE(hm_hand_parse(spec, &h, nullptr, 0) == SWELL_OK);
	REQUIRE(hm_params_check(&p, h.k_N_m, h.b_Ns_m, nullptr, 0) == SWELL_OK);
	double x0[3];
	hm_hand_start(&h, x0);
	hm_state s;
	hm_init(&s, x0);
	trace tr;
	const int n = (int)std::lround(seconds * p.rate_hz);
	for (int i = 0; i < n; i++) {
		const double t = i / p.rate_hz;
		double f[3];
		const int holding = hm_hand_force(&h, t, s.x, s.v, f);
		tr.held_ticks += holding;
		if (!holding)
			tr.f_after_release = std::max(tr.f_after_release, std::fabs(f[0]) + std::fabs(f[1]) + std::fabs(f[2]));
		const double cmd[3] = {0.0, 0.0, cmd_z};
		hm_command(&s, cmd, 1);
		hm_step(&p, &s, f);
		if (t >= t0 && t < t1) {
			tr.z_min = std::min(tr.z_min, s.x[2] * 1e3);
			tr.z_max = std::max(tr.z_max, s.x[2] * 1e3);
			tr.x_min = std::min(tr.x_min, s.x[0] * 1e3);
			tr.x_max = std::max(tr.x_max, s.x[0] * 1e3);
		}
	}
	tr.z_end = s.x[2] * 1e3;
	return tr;
}

} // namespace

TEST_CASE("drop holds the device at its height against the weight (sag F/k), then exerts exactly no force")
{
	// the controller's gravity -0.981 N on the hand spring of 2000 N/m: it sags 0.49 mm, then falls
	const trace tr = run_hand("drop:z=20,hold=0.5", 1.0, 0.4, 0.5, -0.981);
	const double held = 20.0 - 0.981 / 2000.0 * 1e3;
	INFO("z held in [" << tr.z_min << ", " << tr.z_max << "] mm (expected " << held << "), held " << tr.held_ticks
			   << " ticks, z at 1 s " << tr.z_end << " mm");
	CHECK(std::fabs(tr.z_min - held) < 0.01);
	CHECK(std::fabs(tr.z_max - held) < 0.01);
	CHECK(tr.held_ticks == 1250);
	CHECK(tr.f_after_release == 0.0);
	// 0.5 s falling at 0.49 m/s^2 (less the 2 N s/m damping): about 50 mm lower
	CHECK(tr.z_end < held - 40.0);
}

TEST_CASE("press pushes the device to its depth within 2% of it, then lets go")
{
	const trace tr = run_hand("press:at=0.2,depth=45,ramp=0.3,hold=1", 2.0, 0.8, 1.5);
	INFO("z during the hold in [" << tr.z_min << ", " << tr.z_max << "] mm, held " << tr.held_ticks << " ticks");
	CHECK(tr.z_min > -45.0 * 1.02);
	CHECK(tr.z_max < -45.0 * 0.98);
	CHECK(tr.held_ticks == 3250);
	CHECK(tr.f_after_release == 0.0);
}

TEST_CASE("shake moves the device through the hand spring with the script's amplitude within 10%")
{
	// k = 2000 N/m on 2 kg: natural 5 Hz, so at 1 Hz the device follows the target to a few %
	const trace tr = run_hand("shake:at=0,axis=x,f=1,amp=10,for=0", 3.0, 1.0, 3.0);
	const double amp = (tr.x_max - tr.x_min) / 2.0;
	INFO("x in [" << tr.x_min << ", " << tr.x_max << "] mm: amplitude " << amp << " mm for 10 mm");
	CHECK(std::fabs(amp - 10.0) < 1.0);
	CHECK(std::fabs(tr.z_max) < 1e-9);
}
