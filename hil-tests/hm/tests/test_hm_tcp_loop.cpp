// Closed loop on the HapticMaster's own interface: swell-ctl --device hm:127.0.0.1:PORT --clock device
// against swell-hm --serve --lockstep over loopback TCP. The drop settles at the level-corrected depth;
// the e-stop, a `set state stop` from a second client and the emulator's death each give zero force at
// once on the device, a controller fault, nothing over the force limit, and recovery where the cause
// goes away.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <cstdio>

#include "hm_tcp.hpp"
#include "swell_msg_udp.hpp"

using hmtcp::Client;
using hmtcp::Server;

namespace {

const std::string hm_bin = SWELL_HM_BIN;
const std::string ctl_bin = SWELL_CTL_BIN;
const std::string work_dir = SWELL_HM_TEST_DIR;
constexpr double f_limit_N = 10.0; // the controller's default F_max

using row = swell_test::HmLogRow;

double figure(const std::string &s, const std::string &key)
{
	const size_t at = s.find(key);
	return at == std::string::npos ? NAN : std::strtod(s.c_str() + at + key.size(), nullptr);
}

// swell-ctl on the hm: link, clocked by the device's answers; 200 silent periods (unless told) before a fault so
// that a loaded machine does not fault the loop (the faults here are the device's)
struct Ctl : swell_test::Proc {
	Ctl(int port, const std::string &name, const char *silent_ticks = "200")
	    : Ctl(port, name, std::vector<std::string>{}, silent_ticks)
	{
	}
	Ctl(int port, const std::string &name, const std::vector<std::string> &extra, const char *silent_ticks = "200")
	{
		std::vector<std::string> args = {ctl_bin,       "--clock",        "device",
						 "--autorun",   "--device",       "hm:127.0.0.1:" + std::to_string(port),
						 "--host",      "none",           "--no-rt",
						 "--quiet",     "--silent-ticks", silent_ticks,
						 "--full-force"};
		args.insert(args.end(), extra.begin(), extra.end());
		start(args, work_dir + "/" + name + ".ctl.txt");
	}
};

// simulated time of the last whole row logged so far (the log is written in blocks)
double logged_until(const std::string &csv)
{
	const std::vector<row> r = swell_test::read_hm_log(csv);
	return r.empty() ? 0.0 : r.back().t;
}

// waits (up to 60 s) until the log reaches simulated time t
void wait_logged(const std::string &csv, double t)
{
	for (int k = 0; k < 6000 && logged_until(csv) < t; k++)
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
}

// waits (up to 60 s) until the log's last row shows no request run for `ticks` device ticks: every
// request a stopped client had sent has been served; the row, or none
bool wait_requests_served(const std::string &csv, int ticks, row *last)
{
	for (int k = 0; k < 6000; k++) {
		const std::vector<row> r = swell_test::read_hm_log(csv);
		if (!r.empty() && r.back().req_age() >= ticks) {
			*last = r.back();
			return true;
		}
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
	}
	return false;
}

// waits (up to 60 s) until the log shows the device ticking with no client after simulated time t:
// the end of a killed client's connection is in the log before the next one may connect (in
// lockstep the device waits for a request before it ticks, and a client that connects within
// that wait would make the device's first tick alone one with a client); whether it came
bool wait_alone(const std::string &csv, double t)
{
	for (int k = 0; k < 6000; k++) {
		for (const row &r : swell_test::read_hm_log(csv))
			if (r.t > t && r.clients() == 0)
				return true;
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
	}
	return false;
}

// waits (up to 60 s) for a heartbeat of the controller in `state` with last error `err` on its
// telemetry port; whether one came
bool wait_heartbeat(swell_test::MsgUdp &tele, uint8_t state, uint8_t err)
{
	for (int k = 0; k < 600; k++) {
		const swell_msg m = tele.wait_for(SWELL_MSG_HEARTBEAT, 100);
		if (m.type == SWELL_MSG_HEARTBEAT && m.u.heartbeat.state == state && m.u.heartbeat.err == err)
			return true;
	}
	return false;
}

} // namespace

TEST_CASE("hm loop: a drop settles within 2% of the level-corrected depth: the e-stop zeroes the force at once, faults the "
	  "controller, and it floats again")
{
	const std::string csv = work_dir + "/hm-drop.csv";
	std::remove(csv.c_str());
	Server srv(hm_bin, work_dir + "/hm-drop.hm.txt",
		   {"--lockstep", "--hand", "drop:z=20,hold=0.5", "--seconds", "12", "--estop", "5,5.5", "--log", csv});
	REQUIRE(srv.port > 0);
	Ctl ctl(srv.port, "hm-drop");
	const int hm_rc = srv.wait(300000);
	const int ctl_rc = ctl.stop();
	const std::string sum = swell_test::slurp(srv.out), rep = swell_test::slurp(ctl.out);
	INFO(sum << "\n" << rep);
	REQUIRE(hm_rc == 0);
	CHECK(ctl_rc == 0);
	const double z = figure(sum, "equilibrium z"), z_level = figure(sum, "with level rise");
	CHECK(z_level == Approx(-39.375).margin(1e-9));
	CHECK(std::fabs(z - z_level) <= 0.02 * std::fabs(z_level));
	CHECK(std::fabs(z - z_level) <= 0.005 * std::fabs(z_level));
	const std::vector<row> rows = swell_test::read_hm_log(csv);
	REQUIRE(rows.size() == 30000);
	int over = 0, forced_in_estop = 0;
	double back_at = -1, peak = 0;
	for (const row &r : rows) {
		const double f = std::sqrt(r.fcmd[0] * r.fcmd[0] + r.fcmd[1] * r.fcmd[1] + r.fcmd[2] * r.fcmd[2]);
		peak = std::max(peak, f);
		over += f > f_limit_N * 1.0001;
		if (r.t >= 5.0 && r.t < 5.5)
			forced_in_estop += f != 0.0 || r.state != 5;
		if (r.t >= 5.5 && back_at < 0 && r.state == 3 && r.fcmd[2] != 0.0)
			back_at = r.t;
	}
	INFO("peak |F| " << peak << " N; force rendered again " << back_at - 5.5 << " s after the e-stop's release");
	CHECK(over == 0);
	CHECK(forced_in_estop == 0); // from the e-stop's first tick: no force
	CHECK(back_at > 5.5);
	CHECK(back_at < 8.0);
	CHECK(swell_test::count_before(rep, " times found not in") >= 1);
	CHECK(rep.find("faults 0") == std::string::npos);
	WARN("hm drop: equilibrium " << z << " mm against " << z_level << " mm level-corrected; force back " << back_at - 5.5
				     << " s after the e-stop's release");
}

TEST_CASE("hm loop: a second client's set state stop zeroes the force at once and the controller brings the device back: the "
	  "emulator killed faults the controller")
{
	const std::string csv = work_dir + "/hm-stop.csv";
	std::remove(csv.c_str());
	Server srv(hm_bin, work_dir + "/hm-stop.hm.txt",
		   {"--lockstep", "--hand", "drop:z=20,hold=0.5", "--seconds", "60", "--log", csv});
	REQUIRE(srv.port > 0);
	// the controller's telemetry comes here: its heartbeat tells when it has faulted
	swell_test::MsgUdp tele;
	Ctl ctl(srv.port, "hm-stop",
		{"--host", "udp:" + std::to_string(tele.port) + ",listen=" + std::to_string(swell_test::free_udp_port())});
	wait_logged(csv, 4.0);
	{
		Client other(srv.port);
		CHECK(other.ask("set state stop") == "state set to 'stop'");
		const double stop_t = logged_until(csv);
		wait_logged(csv, stop_t + 3.0);
	}
	const std::vector<row> rows = swell_test::read_hm_log(csv);
	REQUIRE(!rows.empty());
	size_t stop_at = 0;
	while (stop_at < rows.size() && rows[stop_at].state != 5)
		stop_at++;
	REQUIRE(stop_at < rows.size());
	int forced_while_stopped = 0, over = 0;
	double back_at = -1;
	for (size_t k = stop_at; k < rows.size(); k++) {
		const row &r = rows[k];
		if (r.state == 5)
			forced_while_stopped += r.fcmd[0] != 0.0 || r.fcmd[1] != 0.0 || r.fcmd[2] != 0.0;
		if (back_at < 0 && r.state == 3 && r.fcmd[2] != 0.0)
			back_at = r.t;
	}
	for (const row &r : rows)
		over += std::fabs(r.fcmd[2]) > f_limit_N * 1.0001;
	INFO("stopped at " << rows[stop_at].t << " s, force back at " << back_at << " s");
	CHECK(forced_while_stopped == 0);
	CHECK(over == 0);
	CHECK(back_at > rows[stop_at].t);
	CHECK(back_at < rows[stop_at].t + 3.0);
	// the emulator dies: the controller faults (link silent) and keeps trying to reconnect. Its
	// heartbeat says when (silent-ticks periods of wall time, then as many ticks of its own: on a
	// loaded machine that is not a fixed time)
	tele.drain();
	srv.stop(SIGKILL);
	const bool faulted = wait_heartbeat(tele, 4 /* fault */, SWELL_ETIMEOUT);
	const int ctl_rc = ctl.stop();
	const std::string rep = swell_test::slurp(ctl.out);
	INFO(rep);
	CHECK(faulted);
	CHECK(ctl_rc == 0);
	CHECK(rep.find("state           fault (last error: link silent)") != std::string::npos);
	CHECK(rep.find("1 connections, 1 resets") != std::string::npos);
	CHECK(swell_test::count_before(rep, " times found not in") >= 1);
	WARN("hm stop: force back " << back_at - rows[stop_at].t << " s after the stop");
}

TEST_CASE("hm loop: TCP faults (replies 5 ms and 50 ms late, garbage, a reset) each give zero force within 2 device ticks, a "
	  "fault, nothing over the limit, and recovery")
{
	const std::string csv = work_dir + "/hm-faults.csv";
	std::remove(csv.c_str());
	struct fault {
		double at, window;
		const char *what;
	} faults[] = {
		{3.0, 0.3, "replies 5 ms late"}, {5.0, 0.5, "replies 50 ms late"}, {7.0, 0.0, "garbage"}, {9.0, 0.0, "reset"}};
	// held above the water: the weight (-0.98 N) is commanded all along, so that a fault's zero and the
	// force's return are plain (an object floating at rest is commanded about 0.00 N)
	Server srv(hm_bin, work_dir + "/hm-faults.hm.txt",
		   {"--lockstep", "--hand", "drop:z=20,hold=1000", "--seconds", "12", "--log", csv, "--inject",
		    "delay:at=3,for=0.3,ms=5", "--inject", "delay:at=5,for=0.5,ms=50", "--inject", "garbage:at=7", "--inject",
		    "reset:at=9"});
	REQUIRE(srv.port > 0);
	// the controller's real-time silence limit (2 ticks) here, spelled out: without real-time
	// scheduling (--no-rt) its default is 20 ms, and the faults are the point
	Ctl ctl(srv.port, "hm-faults", "2");
	const int hm_rc = srv.wait(300000);
	const int ctl_rc = ctl.stop();
	const std::string sum = swell_test::slurp(srv.out), rep = swell_test::slurp(ctl.out);
	INFO(sum << "\n" << rep);
	REQUIRE(hm_rc == 0);
	CHECK(ctl_rc == 0);
	CHECK(sum.find("injected        1 connection resets, 1 garbage bursts") != std::string::npos);
	const std::vector<row> rows = swell_test::read_hm_log(csv);
	REQUIRE(rows.size() == 30000);
	int over = 0;
	for (const row &r : rows)
		over += std::fabs(r.fcmd[0]) > f_limit_N * 1.0001 || std::fabs(r.fcmd[1]) > f_limit_N * 1.0001 ||
			std::fabs(r.fcmd[2]) > f_limit_N * 1.0001;
	CHECK(over == 0);
	std::string figures;
	for (const fault &f : faults) {
		size_t i = 0;
		while (i < rows.size() && rows[i].t < f.at)
			i++;
		// zero force: the first tick of a run of 25 zero ticks (a fault's zero, not a crossing of 0)
		size_t z = i;
		auto zero_run = [&](size_t k) {
			for (size_t m = k; m < k + 25 && m < rows.size(); m++)
				if (rows[m].fcmd[2] != 0.0)
					return false;
			return true;
		};
		while (z < rows.size() && !zero_run(z))
			z++;
		size_t b = z;
		while (b < rows.size() && rows[b].fcmd[2] == 0.0)
			b++;
		INFO(f.what << " at " << f.at << " s: zero after " << z - i << " ticks, force back "
			    << (b < rows.size() ? rows[b].t - f.at : -1) << " s after the fault began");
		CHECK(z - i <= 2);
		REQUIRE(b < rows.size());
		// back within 3 s of simulated time: on a loaded machine without real-time scheduling the
		// controller may fault once more while it recovers (seen: 1.88 s after the garbage)
		CHECK(rows[b].t - f.at < f.window + 3.0);
		figures += std::string(f.what) + ": zero after " + std::to_string(z - i) + " ticks, back after " +
			std::to_string(rows[b].t - f.at) + " s; ";
	}
	// each fault faulted the controller, and it ends with the weight commanded again, or in a fault's
	// zero that began within the recovery allowed above (3 s): a loaded machine's own fault (the
	// controller's wall-clock silence limit, 2 ticks) may come late in the run, and the run ends
	// before it has recovered
	const size_t fat = rep.find("faults ");
	REQUIRE(fat != std::string::npos);
	CHECK(std::stol(rep.substr(fat + 7)) >= 4);
	size_t last_zero = rows.size();
	while (last_zero > 0 && rows[last_zero - 1].fcmd[2] == 0.0)
		last_zero--;
	if (last_zero == rows.size()) {
		CHECK(std::fabs(rows.back().fcmd[2] + 0.98) < 0.011);
	} else {
		INFO("zero force from t = " << rows[last_zero].t << " s to the end; faults: " << std::stol(rep.substr(fat + 7)));
		REQUIRE(last_zero < rows.size());
		CHECK(rows[last_zero].t > rows.back().t - 3.0);
		CHECK(std::stol(rep.substr(fat + 7)) >= 5); // the four injected and that one
	}
	WARN("hm TCP faults: " << figures);
}

TEST_CASE("hm loop: the controller killed mid-run: the device zeroes its bias force when the connection ends, a new controller "
	  "takes the device back")
{
	const std::string csv = work_dir + "/hm-restart.csv";
	std::remove(csv.c_str());
	Server srv(hm_bin, work_dir + "/hm-restart.hm.txt",
		   {"--lockstep", "--hand", "drop:z=20,hold=0.5", "--seconds", "60", "--log", csv});
	REQUIRE(srv.port > 0);
	double killed_at = 0;
	row before_kill{};
	{
		Ctl first(srv.port, "hm-restart-1");
		wait_logged(csv, 4.0);
		// killed between two device ticks: stopped first (SIGSTOP), so that the device has served
		// every request it had sent and renders the last force it set, then killed. A kill at any
		// moment could land between a set and the tick that renders it, and the log could not say
		// what the device held when the connection ended.
		kill(first.pid, SIGSTOP);
		REQUIRE(wait_requests_served(csv, 3, &before_kill));
		killed_at = logged_until(csv);
		first.stop(SIGKILL);
	}
	REQUIRE(wait_alone(csv, before_kill.t));
	Ctl second(srv.port, "hm-restart-2");
	wait_logged(csv, killed_at + 5.0);
	CHECK(second.stop() == 0);
	CHECK(srv.stop(SIGTERM, 10000) == 0);
	const std::string sum = swell_test::slurp(srv.out);
	INFO(sum);
	const std::vector<row> rows = swell_test::read_hm_log(csv);
	REQUIRE(rows.size() > 2500);
	// the server zeroed the first controller's bias force when its connection ended, before the next
	// step (a connection that ends is seen in the same poll that runs requests): counted when that
	// force was not zero (the last tick before the device was alone renders it: no request came
	// after it; a controller faulted by a loaded machine's silence before the stop had set zero)
	size_t alone = 1;
	while (alone < rows.size() && rows[alone].clients() == 0) /* before the first controller */
		alone++;
	while (alone < rows.size() && rows[alone].clients() != 0)
		alone++;
	REQUIRE(alone < rows.size());
	const row &held = rows[alone - 1];
	INFO("the device alone from t = " << rows[alone].t << " s; the force before: " << held.fcmd[0] << ", " << held.fcmd[1]
					  << ", " << held.fcmd[2] << " N; requests served " << before_kill.req_age()
					  << " ticks before the kill at t = " << before_kill.t << " s");
	const bool forced = held.fcmd[0] != 0.0 || held.fcmd[1] != 0.0 || held.fcmd[2] != 0.0;
	CHECK(held.t >= before_kill.t);
	CHECK(held.req_age() >= 3);
	CHECK(swell_test::count_before(sum, " by a vanished client") == (forced ? 1 : 0));
	CHECK(rows[alone].fcmd[2] == 0.0);
	int forced_alone = 0, over = 0, rendered_late = 0, late = 0;
	for (const row &r : rows) {
		forced_alone += r.clients() == 0 && r.fcmd[2] != 0.0;
		over += std::fabs(r.fcmd[2]) > f_limit_N * 1.0001;
		if (r.t > rows.back().t - 2.0) {
			late++;
			rendered_late += r.clients() == 1 && r.fcmd[2] != 0.0;
		}
	}
	CHECK(forced_alone == 0);
	CHECK(over == 0);
	CHECK(rendered_late > late / 2); // the second controller renders the force
	// floating again at the end: the last second of the log
	double zs = 0;
	int zn = 0;
	for (const row &r : rows)
		if (r.t > rows.back().t - 1.0) {
			zs += r.x[2];
			zn++;
		}
	// within 5 %: the new controller starts with the box under water, its whole volume goes in at
	// once, and the box rides the waves that raises (the pool's damping takes seconds; with the
	// damper of a 2 kg device, b_max 15 N s/m, the box follows the surface closely)
	CHECK(std::fabs(zs / zn - -39.375) <= 0.05 * 39.375);
	WARN("hm restart: " << rendered_late << " of the last " << late << " ticks rendered by the new controller, z " << zs / zn
			    << " mm");
}

TEST_CASE("hm loop, effect mode: the device's springs, damper and bias force float a drop within 2 % of the level-corrected "
	  "depth, read back they are the controller's set, with the controller killed they stop at once")
{
	const std::string csv = work_dir + "/hm-effect.csv", scene = work_dir + "/hm-effect.scene";
	std::remove(csv.c_str());
	std::ofstream(scene) << "force.mode = 1\n";
	Server srv(hm_bin, work_dir + "/hm-effect.hm.txt",
		   {"--lockstep", "--hand", "drop:z=20,hold=0.5", "--seconds", "60", "--log", csv});
	REQUIRE(srv.port > 0);
	Ctl ctl(srv.port, "hm-effect", {"--scene", scene});
	wait_logged(csv, 4.2);
	// a second client reads the effects back in one request (one device tick)
	Client other(srv.port);
	const std::vector<std::string> a = hmtcp::answers(
		other.ask("get swell_pull stiffness;get swell_push stiffness;get swell_pull deadband;get swell_push deadband;"
			  "get swell_pull direction;get swell_push direction;get swell_pull dampfactor;get swell_pull maxforce;"
			  "get swell_push maxforce;get swell_pull pos;get swell_push pos;get swell_pull vel;get swell_push vel;"
			  "get swell_damp vel;get swell_damp dampcoef;get swell_weight force;get measpos;get swell_pull enabled;"
			  "get swell_push enabled;get swell_damp enabled;get swell_weight enabled"));
	REQUIRE(a.size() == 21);
	INFO(other.ask("get state") << "; answers: " << a[0] << ";" << a[9] << ";" << a[10] << ";" << a[14] << ";" << a[15]);
	std::vector<std::vector<double>> v;
	for (const std::string &x : a)
		v.push_back(hmtcp::numbers(x));
	REQUIRE(v[0].size() == 1);
	CHECK(std::fabs(v[0][0] - 1000 * 9.81 * 0.05 * 0.05) <= 0.0051); // k = rho g a b, to 0.01 N/m
	CHECK(v[1] == std::vector<double>{-v[0][0]}); // the pushing spring
	CHECK(v[2] == std::vector<double>{1.0}); // deadbands beyond the workspace
	CHECK(v[3] == std::vector<double>{1.0});
	CHECK(v[4] == std::vector<double>{0, 0, 1});
	CHECK(v[5] == std::vector<double>{0, 0, 1});
	CHECK(v[6] == std::vector<double>{0});
	CHECK(v[7] == std::vector<double>{f_limit_N});
	CHECK(v[8] == std::vector<double>{f_limit_N});
	REQUIRE(v[9].size() == 3);
	REQUIRE(v[10].size() == 3);
	REQUIRE(v[16].size() == 3);
	const double w = v[9][2] - 1.0, z = v[16][2];
	CHECK(std::fabs(v[9][2] - v[10][2] - 0.05) < 1e-9); // origins H apart
	CHECK(std::fabs(w - 0.000625) < 0.001); // the surface at rest: the pool's mean level rise, a little wave
	CHECK(v[11] == v[12]); // the water's vertical velocity, on all three
	CHECK(v[11] == v[13]);
	REQUIRE(v[11].size() == 3);
	CHECK(std::fabs(v[11][2]) < 0.01);
	REQUIRE(v[14].size() == 3);
	CHECK(std::fabs(v[14][2] - 15.0 * (w - z) / 0.05) < 0.05); // b_max s, s = delta / H, at this tick's delta
	CHECK(v[15] == std::vector<double>{0, 0, -0.981}); // the weight
	for (int k = 17; k < 21; k++)
		CHECK(a[k] == "true");
	// the controller dies: the device stops what it set when its connection ends
	kill(ctl.pid, SIGKILL);
	waitpid(ctl.pid, nullptr, 0);
	ctl.pid = -1;
	std::string after;
	for (int k = 0; k < 50 && after != "false;false;false;[0,0,0]"; k++) {
		after = other.ask("get swell_pull enabled;get swell_push enabled;get swell_damp enabled;get swell_weight force");
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
	}
	CHECK(after == "false;false;false;[0,0,0]");
	// a new controller removes what the dead one left (its start-up), creates its own, and on SIGTERM
	// removes them before it closes the connection
	{
		Ctl next(srv.port, "hm-effect-2", {"--scene", scene});
		std::string on;
		for (int k = 0; k < 1000 && on != "true;true"; k++) {
			on = other.ask("get swell_pull enabled;get swell_damp enabled");
			std::this_thread::sleep_for(std::chrono::milliseconds(10));
		}
		CHECK(on == "true;true");
		CHECK(next.stop() == 0);
		const std::string rep = swell_test::slurp(next.out);
		INFO(rep);
		CHECK(rep.find("(1 created the effects)") != std::string::npos);
		CHECK(swell_test::count_before(rep, " removals") == 1);
		CHECK(swell_test::count_before(rep, " error answers") == 0);
	}
	CHECK(other.ask("get swell_pull enabled").find("--- ERROR: unknown effect") == 0);
	kill(srv.pid, SIGTERM);
	CHECK(srv.wait(10000) == 0);
	const std::string sum = swell_test::slurp(srv.out);
	INFO(sum);
	CHECK(swell_test::count_before(sum, " by a vanished client") == 4); // pull, push, damper, weight; none at the exit
	const std::vector<row> rows = swell_test::read_hm_log(csv);
	REQUIRE(rows.size() > 10000);
	int over = 0, forced_alone = 0, n = 0;
	double zs = 0;
	for (const row &r : rows) {
		over += std::fabs(r.fcmd[0]) > f_limit_N * 1.0001 || std::fabs(r.fcmd[1]) > f_limit_N * 1.0001 ||
			std::fabs(r.fcmd[2]) > f_limit_N * 1.0001;
		if (r.t >= 3.0 && r.t < 4.0) {
			zs += r.x[2];
			n++;
		}
	}
	// from the first tick with the second client, the kill is the first tick with one client again
	size_t kill_at = 0;
	while (kill_at < rows.size() && rows[kill_at].clients() != 2)
		kill_at++;
	while (kill_at < rows.size() && rows[kill_at].clients() == 2)
		kill_at++;
	size_t alone = 0;
	for (size_t k = kill_at; k < rows.size() && rows[k].clients() == 1; k++, alone++)
		forced_alone += rows[k].fcmd[0] != 0.0 || rows[k].fcmd[1] != 0.0 || rows[k].fcmd[2] != 0.0;
	CHECK(over == 0);
	REQUIRE(n > 2000);
	CHECK(std::fabs(zs / n - -39.375) <= 0.02 * 39.375);
	CHECK(alone > 0);
	CHECK(forced_alone == 0); // from the first tick without the controller
	WARN("hm effect mode: z " << zs / n << " mm over 3-4 s against -39.375 mm; b " << v[14][2] << " N s/m at delta "
				  << (w - z) * 1e3 << " mm; " << alone << " ticks after the kill, none forced");
}
