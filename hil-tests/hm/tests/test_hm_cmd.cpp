// The emulated HapticMaster's command language (hm_cmd.c): the spring law against its definition in
// docs/hapticmaster.md, the paper's buoyancy built from two deadband springs, the state machine, the
// replies clients look for, and refused commands that change nothing.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

extern "C" {
#include "hm_cmd.h"
}

namespace {

std::string run(hm_dev &d, const std::string &req, int client = 0)
{
	char reply[4096];
	size_t n = hm_dev_request(&d, client, req.data(), req.size(), reply, sizeof reply);
	REQUIRE(n == std::strlen(reply));
	return std::string(reply, n);
}

hm_dev fresh()
{
	hm_dev d;
	hm_dev_init(&d, 2500.0, 250.0);
	return d;
}

hm_dev in_force()
{
	hm_dev d = fresh();
	REQUIRE(run(d, "set state init;set state force") == "state set to 'init';state set to 'force'");
	return d;
}

hm_spring spring(double k, double D, double zeta = 0.0)
{
	hm_spring s{};
	s.k_N_m = k;
	s.deadband_m = D;
	s.dampfactor = zeta;
	s.maxforce_N = 250.0;
	return s;
}

} // namespace

TEST_CASE("spring law: along a direction, zero inside the deadband, -k (|s| - D) sign(s) u outside, nothing across it")
{
	hm_spring s = spring(100.0, 0.010);
	s.dir[2] = 1.0;
	const double pos[3] = {0.1, -0.2, 0.05}, vel[3] = {0, 0, 0}, v[3] = {0, 0, 0};
	int wrong = 0;
	std::string first;
	for (double sz = -0.05; sz <= 0.05; sz += 0.0025) {
		for (double across : {-0.3, 0.0, 0.2}) {
			const double x[3] = {pos[0] + across, pos[1] - across, pos[2] + sz};
			double f[3];
			hm_spring_force(&s, pos, vel, 2.0, x, v, f);
			const double want = std::fabs(sz) > 0.010 ? -100.0 * (std::fabs(sz) - 0.010) * (sz > 0 ? 1 : -1) : 0.0;
			if (std::fabs(f[2] - want) > 1e-9 || f[0] != 0.0 || f[1] != 0.0) {
				if (!wrong++)
					first = "s " + std::to_string(sz) + " m, across " + std::to_string(across) + ": F = [" +
						std::to_string(f[0]) + "," + std::to_string(f[1]) + "," + std::to_string(f[2]) +
						"] N, want [0,0," + std::to_string(want) + "]";
			}
		}
	}
	INFO(first);
	CHECK(wrong == 0);
}

TEST_CASE("spring law: without a direction it pulls along e/|e| by k (|e| - D), and a negative stiffness pushes")
{
	const double pos[3] = {0, 0, 0}, vel[3] = {0, 0, 0}, v[3] = {0, 0, 0}, x[3] = {0.03, 0.04, 0.0};
	double f[3];
	hm_spring s = spring(100.0, 0.010);
	hm_spring_force(&s, pos, vel, 2.0, x, v, f); // |e| = 0.05, stretch 0.04: 4 N toward the origin
	CHECK(f[0] == Approx(-2.4).margin(1e-12));
	CHECK(f[1] == Approx(-3.2).margin(1e-12));
	CHECK(f[2] == 0.0);
	s.k_N_m = -100.0;
	hm_spring_force(&s, pos, vel, 2.0, x, v, f);
	CHECK(f[0] == Approx(2.4).margin(1e-12));
	CHECK(f[1] == Approx(3.2).margin(1e-12));
	const double inside[3] = {0.005, 0.005, 0.0};
	hm_spring_force(&s, pos, vel, 2.0, inside, v, f);
	CHECK(f[0] == 0.0);
	CHECK(f[1] == 0.0);
}

TEST_CASE("spring law: damping c = dampfactor 2 sqrt(|k| m) on v - vel, inside the deadband only with dampglobal: maxforce "
	  "limits |F|")
{
	hm_spring s = spring(200.0, 0.020, 0.5);
	s.dir[2] = 1.0;
	const double pos[3] = {0, 0, 0}, vel[3] = {0, 0, 0.01}, x_in[3] = {0, 0, 0.01}, x_out[3] = {0, 0, 0.03},
		     v[3] = {0, 0, 0.11};
	const double c = 0.5 * 2.0 * std::sqrt(200.0 * 2.0); // 20 N s/m
	double f[3];
	hm_spring_force(&s, pos, vel, 2.0, x_in, v, f);
	CHECK(f[2] == 0.0); // inside, not global: no damping
	s.dampglobal = 1;
	hm_spring_force(&s, pos, vel, 2.0, x_in, v, f);
	CHECK(f[2] == Approx(-c * 0.10).epsilon(1e-12));
	s.dampglobal = 0;
	hm_spring_force(&s, pos, vel, 2.0, x_out, v, f);
	CHECK(f[2] == Approx(-200.0 * 0.010 - c * 0.10).epsilon(1e-12)); // -2 - 2 = -4 N
	s.maxforce_N = 1.5;
	hm_spring_force(&s, pos, vel, 2.0, x_out, v, f);
	CHECK(f[2] == Approx(-1.5).epsilon(1e-12));
}

TEST_CASE("the paper's buoyancy: two springs of k and -k, deadband beyond the workspace, origins H apart, give k clamp(w - z, 0, "
	  "H)")
{
	// the pulling spring's origin D above the surface w, the pushing one H below it (paper section 3.3)
	hm_dev d = in_force();
	const double k = 24.5, H = 0.04, D = 0.5, w = 0.002; // deadband 0.5 m: beyond the +-0.2 m workspace
	char buf[512];
	std::snprintf(buf, sizeof buf,
		      "create spring up;set up stiffness %g;set up deadband %g;set up direction [0,0,1];set up pos [0,0,%g];"
		      "set up enable;create spring down;set down stiffness %g;set down deadband %g;"
		      "set down direction [0,0,1];set down pos [0,0,%g];set down enable",
		      k, D, w + D, -k, D, w + D - H);
	const std::string r = run(d, buf);
	REQUIRE(r.find("ERROR") == std::string::npos);
	int wrong = 0;
	std::string first;
	for (double z = -0.19; z <= 0.19; z += 0.001) {
		const double x[3] = {0.01, -0.02, z}, v[3] = {0, 0, 0};
		double f[3];
		hm_dev_tick(&d, x, v, f);
		const double depth = w - z, want = k * (depth < 0 ? 0 : depth > H ? H : depth);
		if (std::fabs(f[2] - want) > 1e-9 || f[0] != 0.0 || f[1] != 0.0) {
			if (!wrong++)
				first = "z " + std::to_string(z) + " m: F_z " + std::to_string(f[2]) + " N, want " +
					std::to_string(want) + " N";
		}
	}
	INFO(first);
	CHECK(wrong == 0);
}

TEST_CASE("effects: origins move with vel every tick, damper opposes v - vel, bias adds, nothing rendered outside force")
{
	hm_dev d = in_force();
	REQUIRE(run(d,
		    "create damper dm;set dm dampcoef [1,2,3];set dm enable;create biasforce b;set b force [0.5,0,-1];"
		    "set b enable;create spring s;set s vel [0,0,0.025];set s stiffness 10") ==
		"Effect damper with name dm created;Damper's damp coefficient set;Effect dm enabled;"
		"Effect biasforce with name b created;Bias force's force set;Effect b enabled;"
		"Effect spring with name s created;Effect's velocity set;Spring's stiffness set");
	const double x[3] = {0, 0, 0}, v[3] = {0.1, 0.1, 0.1};
	double f[3];
	hm_dev_tick(&d, x, v, f);
	CHECK(f[0] == Approx(0.5 - 0.1).epsilon(1e-12));
	CHECK(f[1] == Approx(-0.2).epsilon(1e-12));
	CHECK(f[2] == Approx(-1.0 - 0.3).epsilon(1e-12));
	for (int n = 1; n < 100; n++)
		hm_dev_tick(&d, x, v, f);
	CHECK(run(d, "get s pos") == "[0,0,0.001]"); // 100 ticks of 0.025 m/s at 2500 Hz
	REQUIRE(run(d, "set state position") == "state set to 'position'");
	hm_dev_tick(&d, x, v, f);
	CHECK((f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0));
}

TEST_CASE("states: no force state before init, stop and the e-stop drop every effect force and need init again")
{
	hm_dev d = fresh();
	CHECK(run(d, "get state") == "off");
	CHECK(run(d, "set state force") == "--- ERROR: state 'force' needs 'init' first (device is in 'off')");
	CHECK(run(d, "set state position").rfind("--- ERROR:", 0) == 0);
	CHECK(run(d, "set state home").rfind("--- ERROR:", 0) == 0);
	CHECK(run(d, "get state") == "off");
	CHECK(run(d, "set state init;get position_calibrated") == "state set to 'init';true");
	CHECK(run(d, "set state home;set state position;set state force;get state") ==
	      "state set to 'home';state set to 'position';state set to 'force';force");
	REQUIRE(run(d, "create biasforce b;set b force [0,0,3];set b enable").find("ERROR") == std::string::npos);
	const double x[3] = {0, 0, 0}, v[3] = {0, 0, 0};
	double f[3];
	hm_dev_tick(&d, x, v, f);
	CHECK(f[2] == 3.0);
	CHECK(run(d, "set state stop") == "state set to 'stop'");
	hm_dev_tick(&d, x, v, f);
	CHECK(f[2] == 0.0);
	CHECK(run(d, "set state force").rfind("--- ERROR: state 'force' needs 'init' first", 0) == 0);
	CHECK(run(d, "set state init;set state force;get b force") == "state set to 'init';state set to 'force';[0,0,0]");
	// e-stop: stop at once, nothing but stop/off while pushed, init again after the release
	REQUIRE(run(d, "set b force [0,0,2]") == "Bias force's force set");
	hm_dev_set_estop(&d, 1);
	hm_dev_tick(&d, x, v, f);
	CHECK(f[2] == 0.0);
	CHECK(run(d, "get state;get emergencybuttonpushed") == "stop;true");
	CHECK(run(d, "set state init") == "--- ERROR: emergency button pushed: state 'init' refused");
	hm_dev_set_estop(&d, 0);
	CHECK(run(d, "get state;get emergencybuttonpushed;set state init;set state force") ==
	      "stop;false;state set to 'init';state set to 'force'");
	hm_dev_tick(&d, x, v, f);
	CHECK(f[2] == 0.0); // the bias was forgotten by the stop
}

TEST_CASE("replies: semicolon-joined answers in order, a trailing semicolon adds none, bare values for get, client texts for set")
{
	hm_dev d = in_force();
	CHECK(run(d, "set inertia 3.5;get inertia;set coulombfriction 0.25;get coulombfriction;") ==
	      "Inertia set;3.5;Coulomb friction set;0.25");
	CHECK(run(d, "create spring s") == "Effect spring with name s created");
	CHECK(run(d, " set s pos [0.1, 0.0 ,0.25] ; set s vel [0,0,0.5];set s att [0,0,0,2];get s att") ==
	      "Effect's position set;Effect's velocity set;Effect's attitude set;[0,0,0,1]");
	CHECK(run(d,
		  "set s stiffness 500;set s dampfactor 0.7;set s deadband 0.002;set s direction [0,3,4];"
		  "set s maxforce 12;set s dampglobal true") ==
	      "Spring's stiffness set;Spring's damp factor set;Spring's deadband set;Spring's direction set;"
	      "Spring's maximum force set;Spring's damping global set");
	CHECK(run(d,
		  "get s pos;get s stiffness;get s dampfactor;get s deadband;get s direction;get s maxforce;"
		  "get s dampglobal;get s enabled") == "[0.1,0,0.25];500;0.7;0.002;[0,0.6,0.8];12;true;false");
	CHECK(run(d, "set s enable;get s enabled;set s disable;get s enabled") ==
	      "Effect s enabled;true;Effect s disabled;false");
	CHECK(run(d, "calibrateforcesensor;get force_calibrated") == "Force sensor calibrated;true");
	CHECK(run(d, "remove s;get s enabled") == "Removed effect s;--- ERROR: unknown effect 's'");
	CHECK(run(d, "create damper a;create biasforce b;remove all;get a enabled") ==
	      "Effect damper with name a created;Effect biasforce with name b created;Removed all effects;"
	      "--- ERROR: unknown effect 'a'");
	CHECK(run(d, "get measpos;get modelvel;get modelacc;get measforce;get emergencybuttonpushed") ==
	      "[0,0,0];[0,0,0];[0,0,0];[0,0,0];false");
}

TEST_CASE("refused commands: answered '--- ERROR:', counted, and the device is byte for byte what it was")
{
	hm_dev d = in_force();
	REQUIRE(run(d, "create spring s;create damper dm;create biasforce b;set b force [0,0,1]").find("ERROR") ==
		std::string::npos);
	const std::vector<std::string> bad = {
		"fly away",
		"get",
		"get nothing",
		"set nothing 1",
		"set state flying",
		"set state",
		"set inertia 0.5",
		"set inertia abc",
		"set inertia 2 3",
		"set coulombfriction -1",
		"create spring s",
		"create wave w",
		"create spring 9lives",
		"create spring state",
		"create spring a b",
		"set s stiffness 1e9",
		"set s stiffness 10x",
		"set s stiffness nan",
		"set s dampfactor -1",
		"set s deadband -0.1",
		"set s direction [0,0]",
		"set s direction 0,0,1",
		"set s maxforce 0",
		"set s maxforce 300",
		"set s dampglobal maybe",
		"set s dampcoef [1,1,1]",
		"set s force [0,0,1]",
		"set s pos [0,0,inf]",
		"set s pos [0,0,0",
		"set s pos [0,0,0]x",
		"set s att [0,0,0,0]",
		"set s enable now",
		"set dm dampcoef [-1,0,0]",
		"set dm dampcoef [1e6,0,0]",
		"set b force [0,0,251]",
		"set b force [0,0]",
		"get s nothing",
		"get s",
		"get s pos extra",
		"remove nothing",
		"remove",
		"remove s s",
		"calibrateforcesensor now",
		std::string(300, 'x'),
	};
	int not_error = 0, changed = 0;
	std::string first;
	for (const auto &cmd : bad) {
		hm_dev before;
		std::memcpy(&before, &d, sizeof d);
		const std::string r = run(d, cmd);
		before.commands = d.commands; // the counters move, nothing else
		before.errors = d.errors;
		before.client_heard[0] = d.client_heard[0];
		if (r.rfind("--- ERROR: ", 0) != 0 && !not_error++)
			first = "'" + cmd + "' answered '" + r + "'";
		if (std::memcmp(&before, &d, sizeof d) != 0 && !changed++)
			first += " / '" + cmd + "' changed the device";
	}
	INFO(first);
	CHECK(not_error == 0);
	CHECK(changed == 0);
	CHECK(d.errors == bad.size());
	// a bad command in the middle: the others still run, in order
	CHECK(run(d, "set s stiffness 5;set s stiffness x;get s stiffness") ==
	      "Spring's stiffness set;--- ERROR: stiffness 'x' refused (|k| <= 100000 N/m, resolved at 2500 Hz on 2 kg);5");
	CHECK(run(d, " ; ;") == "--- ERROR: empty request");
}

TEST_CASE("effect table: 16 effects, the 17th refused: a reply that does not fit ends in an error")
{
	hm_dev d = in_force();
	for (int k = 0; k < HM_EFFECTS_MAX; k++)
		REQUIRE(run(d, "create damper d" + std::to_string(k)).find("created") != std::string::npos);
	CHECK(run(d, "create damper one_more") == "--- ERROR: no room for another effect (16 in use)");
	std::string many;
	for (int k = 0; k < 40; k++)
		many += "get d1 dampcoef;";
	char small[64];
	const size_t n = hm_dev_request(&d, 0, many.data(), many.size(), small, sizeof small);
	CHECK(n < sizeof small);
	CHECK(std::string(small).find("--- ERROR: reply too long") != std::string::npos);
}

TEST_CASE("watchdog: a client silent for N ticks loses its bias force and its springs and dampers on the Nth tick, not "
	  "before: one that leaves loses them at once")
{
	hm_dev d = in_force();
	d.watchdog_ticks = 25;
	REQUIRE(run(d, "create biasforce a;set a force [0,0,1];set a enable", 0).find("ERROR") == std::string::npos);
	REQUIRE(run(d, "create biasforce b;set b force [0,0,2];set b enable", 1).find("ERROR") == std::string::npos);
	// client 0's spring pulls +1 N at the origin (k 10 N/m, 0.1 m above), client 1's damper +1 N (vel 0.1 m/s)
	REQUIRE(run(d, "create spring s;set s stiffness 10;set s pos [0,0,0.1];set s direction [0,0,1];set s enable", 0)
			.find("ERROR") == std::string::npos);
	REQUIRE(run(d, "create damper p;set p dampcoef [0,0,10];set p vel [0,0,0.1];set p enable", 1).find("ERROR") ==
		std::string::npos);
	const double x[3] = {0, 0, 0}, v[3] = {0, 0, 0};
	double f[3];
	int first_drop = -1;
	for (int n = 0; n < 40; n++) {
		run(d, "get state", 1); // client 1 keeps talking
		hm_dev_tick(&d, x, v, f);
		if (n < 25)
			CHECK(f[2] == Approx(5.0));
		if (first_drop < 0 && f[2] == Approx(3.0))
			first_drop = n;
	}
	CHECK(first_drop == 25); // ticks 0..24 carry client 0's 1 N bias and 1 N spring, tick 25 drops both
	CHECK(d.watchdog_trips == 2);
	CHECK(run(d, "get s enabled", 1) == "false");
	CHECK(run(d, "get p enabled", 1) == "true");
	hm_dev_client_gone(&d, 1);
	hm_dev_tick(&d, x, v, f);
	CHECK(f[2] == 0.0);
	CHECK(d.vanished_zeroed == 2);
	CHECK(run(d, "get p enabled", 0) == "false");
}

TEST_CASE("owners: a bias force answers to the client that set its force, not to one that moved or enabled it, a "
	  "spring to the client that last set anything on it")
{
	hm_dev d = in_force();
	REQUIRE(run(d, "create biasforce a;set a force [0,0,1]", 0).find("ERROR") == std::string::npos);
	REQUIRE(run(d, "set a pos [0,0,0.1];set a vel [0,0,0];set a att [0,0,0,1];set a enable", 1).find("ERROR") ==
		std::string::npos);
	REQUIRE(run(d, "create spring s;set s stiffness 10", 0).find("ERROR") == std::string::npos);
	REQUIRE(run(d, "set s enable", 1).find("ERROR") == std::string::npos);
	hm_dev_client_gone(&d, 1); // client 1's spring stops, client 0's bias force stays
	CHECK(run(d, "get s enabled;get a enabled;get a force", 0) == "false;true;[0,0,1]");
	CHECK(d.vanished_zeroed == 1);
	hm_dev_client_gone(&d, 0);
	CHECK(run(d, "get a force", 2) == "[0,0,0]");
	CHECK(d.vanished_zeroed == 2);
}
