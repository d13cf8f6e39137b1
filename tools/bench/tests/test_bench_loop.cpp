/* swell-bench loop: the coupled loop's classification, energy and theory, and the map's
 * determinism. */
#include "swell_test.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

extern "C" {
#include "loop.h"
#include "swell/param_table.h"
}

namespace {

loop_point point(int mode, double k_mult, int delay)
{
	loop_point p{};
	p.mode = mode;
	p.rate_hz = 1000;
	p.k_mult = k_mult;
	p.damper_Ns_m = 0;
	p.mass_kg = 2;
	p.damping_Ns_m = 2;
	p.delay = delay;
	p.seconds = 3;
	return p;
}

/* what the spring holds at the release: 1/2 k A^2 for the swing A */
double release_energy_J(const loop_result &r)
{
	const double a = (r.z_release_mm - r.z_eq_mm) * 1e-3;
	return 0.5 * r.k_N_m * a * a;
}

} // namespace

TEST_CASE("loop: a soft, strongly damped point settles, creates no energy at the device port and none in the "
	  "controller's account, in both modes",
	  "[bench][loop]")
{
	for (int mode = 0; mode < 2; mode++) {
		loop_point p = point(mode, 0.25, 0);
		p.mass_kg = 0.5;
		p.damping_Ns_m = 20;
		p.damper_Ns_m = 15;
		loop_result r{};
		loop_run(&p, &r);
		const double e0 = release_energy_J(r);
		INFO("mode " << mode << ": " << loop_class_name(r.cls) << " " << r.why << ", swing " << r.p2p_first_mm << " -> "
			     << r.p2p_last_mm << " mm, created " << r.e_created_J << " J (most " << r.e_created_max_J
			     << "), controller " << r.ctl_created_J << " J, release energy " << e0);
		CHECK(r.cls == LOOP_STABLE);
		REQUIRE(e0 > 0);
		CHECK(std::fabs(r.z_release_mm - r.z_eq_mm - -LOOP_SWING_MM) < 1.0); /* the hand held where asked */
		CHECK(r.e_created_J < 0); /* what the release had, partly dissipated */
		CHECK(r.e_created_max_J < 0.05 * e0);
		CHECK(r.have_ctl_energy == 1);
		CHECK(r.ctl_created_J < 0.05 * e0 + 1e-6); /* the account's figure is whole microjoules */
	}
}

TEST_CASE("loop: a stiff point with 4 ticks of delay and no passivity controller is active: it creates many "
	  "times the release's energy, at the port and in the controller's account",
	  "[bench][loop]")
{
	loop_point p = point(0, 64, 4);
	loop_result r{};
	loop_run(&p, &r);
	const double e0 = release_energy_J(r);
	INFO(loop_class_name(r.cls) << ": swing " << r.p2p_first_mm << " -> " << r.p2p_last_mm << " mm, peak " << r.peak_dev_mm
				    << " mm, created " << r.e_created_max_J << " J, controller " << r.ctl_created_J
				    << " J, release energy " << e0);
	CHECK((r.cls == LOOP_DIVERGENT || r.cls == LOOP_LIMIT_CYCLE));
	CHECK(r.e_created_max_J > 10 * e0);
	CHECK(r.ctl_created_J > 10 * e0);
	CHECK(r.ctl_damped_J == 0); /* no controller, nothing it took out */
	CHECK(r.ctl_passivity == 0);

	/* with it (force.passivity 1 through the host link), the controller takes energy out */
	p.passivity = 1;
	loop_run(&p, &r);
	CHECK(r.ctl_passivity == 1);
	CHECK(r.ctl_damped_J > 0);
}

TEST_CASE("loop: with the passivity controller at its own bound the stiffest point behind 4 ticks settles and "
	  "creates at most 1 mJ at the device port and in the controller's account, and with force.pc_damping at "
	  "1000 N s/m, beyond what a damping behind the delay keeps stable on the device, it diverges",
	  "[bench][loop][passivity]")
{
	loop_point p = point(0, 64, 4);
	p.passivity = 1;
	loop_result r{};
	loop_run(&p, &r);
	INFO("default bound: " << loop_class_name(r.cls) << ", created " << r.e_created_max_J * 1e3 << " mJ, controller "
			       << r.ctl_created_J * 1e3 << " mJ, damped " << r.ctl_damped_J * 1e3 << " mJ");
	CHECK(r.cls == LOOP_STABLE);
	CHECK(r.e_created_max_J <= 1e-3);
	CHECK(r.ctl_created_J <= 1e-3);
	CHECK(r.ctl_damped_J > 0);

	p.pc_damping_Ns_m = 1000;
	loop_run(&p, &r);
	INFO("1000 N s/m: " << loop_class_name(r.cls) << ", created " << r.e_created_max_J * 1e3 << " mJ");
	CHECK(r.cls == LOOP_DIVERGENT);
	CHECK(r.e_created_max_J > 1e-3);
}

TEST_CASE("swell-bench loop: the quick map's stream points with the passivity controller all create at most 1 mJ "
	  "(the summary's ratio 1.000), while without it the active region shows (divergent points)",
	  "[bench][loop][passivity]")
{
	char t[] = "/tmp/swell-bench-loop-XXXXXX";
	REQUIRE(mkdtemp(t) != nullptr);
	const std::string dir = t;
	const swell_test::Run r = swell_test::run(
		{SWELL_BENCH_BIN, "loop", "--quick", "--modes", "stream", "--no-plots", "--no-bisect", "--out", dir});
	INFO(r.out << r.err);
	REQUIRE(r.code == 0);
	int without[4] = {0, 0, 0, 0}, within = -1, of = -1;
	const size_t a = r.out.find("without the passivity controller: ");
	const size_t b = r.out.find("passive with the controller: ");
	REQUIRE(a != std::string::npos);
	REQUIRE(b != std::string::npos);
	REQUIRE(std::sscanf(r.out.c_str() + a, "without the passivity controller: %d / %d / %d / %d", &without[0], &without[1],
			    &without[2], &without[3]) == 4);
	REQUIRE(std::sscanf(r.out.c_str() + b, "passive with the controller: %d of %d", &within, &of) == 2);
	CHECK(of == 25);
	CHECK(within == of);
	CHECK(r.out.find("(ratio 1.000)") != std::string::npos);
	CHECK(without[2] > 0);
	CHECK(std::system(("rm -rf '" + dir + "'").c_str()) == 0);
}

TEST_CASE("loop: effect mode refuses a spring stiffer than EFFECT_SPRING carries instead of rendering a softer one",
	  "[bench][loop]")
{
	loop_point p = point(1, 32, 0); /* 785 N/m > 655.35 */
	loop_result r{};
	loop_run(&p, &r);
	CHECK(r.cls == LOOP_BEYOND_EFFECT);
	CHECK(std::string(r.why).find("EFFECT_SPRING") != std::string::npos);
	p.k_mult = 16; /* 392 N/m: carried */
	loop_run(&p, &r);
	CHECK(r.cls != LOOP_BEYOND_EFFECT);
}

TEST_CASE("loop theory: Schur-Cohn counts roots against the unit circle, and the delayed spring's critical "
	  "stiffness falls with the delay as b / (d T) for small w T (the device's semi-implicit Euler takes back "
	  "the zero-order hold's half tick)",
	  "[bench][loop][theory]")
{
	const double in[] = {-0.25, 0, 1}; /* (z - 0.5)(z + 0.5) */
	const double on[] = {-1, 0, 1}; /* roots at +-1: not inside */
	const double out[] = {-1.1, 1}; /* z = 1.1 */
	const double mixed[] = {0.55, -1.6, 1}; /* roots 0.5 and 1.1 */
	CHECK(loop_schur_stable(in, 2) == 1);
	CHECK(loop_schur_stable(on, 2) == 0);
	CHECK(loop_schur_stable(out, 1) == 0);
	CHECK(loop_schur_stable(mixed, 2) == 0);

	for (double rate : {1000.0, 2500.0}) {
		const double T = 1.0 / rate, m = 2, b = 2;
		/* no delay: the device's semi-implicit Euler keeps a sampled spring stable up to w T = 2 */
		CHECK(loop_theory_stable(m, b, 0.9 * 4 * m / (T * T), 0, 0, T) == 1);
		CHECK(loop_theory_stable(m, b, 1.1 * 4 * m / (T * T), 0, 0, T) == 0);
		double last = INFINITY;
		for (int d = 1; d <= 4; d++) {
			const double kc = loop_theory_k_crit(m, b, 0, d, T, 1e6), approx = b / (d * T);
			INFO(rate << " Hz, d " << d << ": k_crit " << kc << " N/m, b / (d T) " << approx);
			CHECK(kc < last);
			CHECK(std::fabs(kc / approx - 1) < 0.1);
			/* the force law's damper moves it up */
			CHECK(loop_theory_k_crit(m, b, 5, d, T, 1e6) > kc);
			last = kc;
		}
	}
}

TEST_CASE("loop theory: a damping behind d ticks on the device is stable up to 2 m / T - b without delay and "
	  "about pi m / (2 (d + 1/2) T) with it, and force.pc_damping's default is below a third of that for the lightest "
	  "device (0.5 kg) up to 4 ticks at 1000 Hz",
	  "[bench][loop][theory][passivity]")
{
	for (double rate : {1000.0, 2500.0})
		for (double m : {0.5, 2.0, 4.0}) {
			const double T = 1.0 / rate, b = 0.5;
			CHECK(loop_theory_b_crit(m, b, 0, T, 1e6) == Approx(2 * m / T - b).epsilon(1e-6));
			double last = INFINITY;
			for (int d = 1; d <= 8; d++) {
				const double bc = loop_theory_b_crit(m, b, d, T, 1e6), approx = M_PI * m / (2 * (d + 0.5) * T);
				INFO(rate << " Hz, " << m << " kg, d " << d << ": B_crit " << bc
					  << " N s/m, pi m / (2 (d + 1/2) T) " << approx);
				CHECK(bc < last);
				CHECK(std::fabs(bc / approx - 1) < 0.06);
				last = bc;
			}
		}
	CHECK(3 * SWELL_PARAM_DEF_FORCE_PC_DAMPING / 1000.0 < loop_theory_b_crit(0.5, 0.5, 4, 1e-3, 1e6));
}

TEST_CASE("swell-bench loop: the same map twice (two threads) gives the same loop.csv, byte for byte", "[bench][loop]")
{
	char t[] = "/tmp/swell-bench-loop-XXXXXX";
	REQUIRE(mkdtemp(t) != nullptr);
	const std::string dir = t;
	std::string csv[2];
	for (int k = 0; k < 2; k++) {
		const std::string out = dir + "/run" + std::to_string(k);
		const swell_test::Run r = swell_test::run(
			{SWELL_BENCH_BIN, "loop",        "--k",     "8,32,64", "--mass",      "0.5",  "--delays", "0,4",
			 "--seconds",     "1",           "--modes", "both",    "--passivity", "both", "--jobs",   "2",
			 "--no-plots",    "--no-bisect", "--out",   out});
		INFO(r.out << r.err);
		REQUIRE(r.code == 0);
		csv[k] = swell_test::slurp(out + "/loop.csv");
	}
	CHECK(csv[0].size() > 1000);
	CHECK(std::count(csv[0].begin(), csv[0].end(), '\n') == 1 + 3 * 2 * 2 * 2);
	CHECK(csv[0] == csv[1]);
	CHECK(std::system(("rm -rf '" + dir + "'").c_str()) == 0);
}

TEST_CASE("swell-bench loop: bad arguments exit 2 with one line before any run", "[bench][loop][args]")
{
	const std::vector<swell_test::BadArgs> cases = {
		{{"loop", "--k", "100"}, "--k '100' is not 1 to 16 comma-separated numbers in [0.25, 64]", 2},
		{{"loop", "--delays", "5"}, "--delays '5' is not 1 to 16 comma-separated numbers in [0, 4] ticks", 2},
		{{"loop", "--delays", "1.5"}, "--delays '1.5' is not whole numbers", 2},
		{{"loop", "--rates", "2000"}, "--rates '2000' is not 1000 and/or 2500 Hz", 2},
		{{"loop", "--mass", "8"}, "--mass '8' is not 1 to 16 comma-separated numbers in [0.5, 4] kg", 2},
		{{"loop", "--modes", "both,stream"}, "--modes 'both,stream' is not stream, effect or both", 2},
		{{"loop", "--bogus"}, "unknown option '--bogus'", 2},
	};
	swell_test::check_bad_args(SWELL_BENCH_BIN, cases);
}
