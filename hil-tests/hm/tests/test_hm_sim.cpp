// Closed loop over UDP loopback: swell-ctl --clock device --autorun against swell-hm --lockstep, for
// several seconds of simulated time. Each test binds its own free port, so tests run side by side.
#include <catch2/catch.hpp>

#include "swell_test.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace {

const std::string hm_bin = SWELL_HM_BIN;
const std::string ctl_bin = SWELL_CTL_BIN;
const std::string work_dir = SWELL_HM_TEST_DIR;

// The first number after "label" on the line that starts with two spaces and label.
double figure(const std::string &text, const std::string &label)
{
	const size_t at = text.find("\n  " + label);
	INFO("summary has no line '" << label << "':\n" << text);
	REQUIRE(at != std::string::npos);
	return std::strtod(text.c_str() + at + 3 + label.size(), nullptr);
}

struct closed_loop {
	std::string name, hm_out, ctl_out, csv;
	uint16_t port;
	swell_test::Proc ctl;

	explicit closed_loop(const std::string &n, const char *clock = "device", int silent_ticks = 200,
			     const std::vector<std::string> &ctl_extra = {})
	    : name(n), hm_out(work_dir + "/" + n + ".hm.txt"), ctl_out(work_dir + "/" + n + ".ctl.txt"),
	      csv(work_dir + "/" + n + ".csv"), port(swell_test::free_udp_port())
	{
		std::remove(csv.c_str()); // a log of an earlier run must not pass for this one
		std::remove(hm_out.c_str());
		// a silent device is a fault after 200 periods and then 200 of the controller's own ticks (one
		// a period with the device clock): a loaded CI machine must not fault the loop; link loss is
		// the kill test's
		std::vector<std::string> args = {
			ctl_bin,  "--clock", clock,     "--autorun", "--device",       "udp:" + std::to_string(port),
			"--host", "none",    "--no-rt", "--quiet",   "--silent-ticks", std::to_string(silent_ticks)};
		args.insert(args.end(), ctl_extra.begin(), ctl_extra.end());
		ctl.start(args, ctl_out);
		// until its device link is open (it says so once its links are): a sample sent before would be
		// lost, and the model's first lockstep wait would time out
		for (int k = 0; k < 6000 && swell_test::slurp(ctl_out).find(" pool, tick ") == std::string::npos; k++)
			std::this_thread::sleep_for(std::chrono::milliseconds(10));
	}
	std::vector<std::string> hm_args(const std::string &hand, double seconds) const
	{
		return {hm_bin,    "--lockstep", "--port",    std::to_string(port),
			"--hand",  hand,         "--seconds", std::to_string(seconds),
			"--quiet", "--log",      csv};
	}
	// Runs swell-hm to its end, then stops the controller; returns swell-hm's summary.
	std::string run(const std::vector<std::string> &args)
	{
		swell_test::Proc hm(args, hm_out);
		const int rc = hm.wait(300000);
		const int crc = ctl.stop(SIGTERM, 10000);
		const std::string text = swell_test::slurp(hm_out);
		INFO("swell-hm exit " << rc << ":\n"
				      << text << "\nswell-ctl exit " << crc << ":\n"
				      << swell_test::slurp(ctl_out));
		REQUIRE(rc == 0);
		REQUIRE(crc == 0);
		return text;
	}
};

using row = swell_test::HmLogRow;

// swell-ctl arguments for effect mode: a scene file that sets only force.mode (the reference scene
// otherwise).
std::vector<std::string> effect_mode()
{
	const std::string path = work_dir + "/effect-mode.scene";
	std::ofstream(path) << "force.mode = 1   # effect: springs, damper and gravity rendered by the device\n";
	return {"--scene", path};
}

// A drop from 20 mm floats on the 2 kg device: after the release (0.5 s) the box's bottom stays above
// the pool floor (z = -50 mm), the commanded force stays within 2 N, and from 2 s after the release z
// stays within 0.8 mm (2 % of m g / k) of where it rests (the mean of the last second).
void check_drop_floats(const std::vector<row> &rows)
{
	REQUIRE(rows.size() > 5000);
	const size_t release = 1250, settled = release + 5000, n = rows.size();
	double z_rest = 0;
	for (size_t k = n - 2500; k < n; k++)
		z_rest += rows[k].x[2] / 2500;
	double z_lo = 1e9, f_peak = 0, off_late = 0;
	size_t last_off = release;
	for (size_t k = release; k < n; k++) {
		z_lo = std::min(z_lo, rows[k].x[2]);
		f_peak = std::max(f_peak, std::fabs(rows[k].fcmd[2]));
		if (std::fabs(rows[k].x[2] - z_rest) > 0.8) {
			last_off = k;
			if (k >= settled)
				off_late = std::max(off_late, std::fabs(rows[k].x[2] - z_rest));
		}
	}
	const double t_settle = rows[last_off].t - rows[release].t;
	std::printf("drop: lowest z %.2f mm, peak |F_cmd| %.2f N after the release, within 0.8 mm of %.2f mm "
		    "%.2f s after it\n",
		    z_lo, f_peak, z_rest, t_settle);
	INFO("lowest z " << z_lo << " mm, peak |F_cmd| " << f_peak << " N, rests at " << z_rest << " mm, settled (within 0.8 mm) "
			 << t_settle << " s after the release, off by " << off_late << " mm later than 2 s");
	CHECK(z_lo > -50.0);
	CHECK(f_peak <= 2.0);
	CHECK(t_settle <= 2.0);
}

} // namespace

TEST_CASE("drop: the object falls from 20 mm, floats (never on the floor, at most 2 N), settles within 2 s at -m g/k "
	  "within 2% (level-corrected within 0.5%)")
{
	closed_loop cl("drop");
	const std::string s = cl.run(cl.hm_args("drop:z=20,hold=0.5", 10.0));
	const double z = figure(s, "equilibrium z"), z_expected = figure(s, "expected z"), z_level = figure(s, "with level rise");
	INFO(s);
	CHECK(z_expected == Approx(-40.0).margin(1e-9));
	CHECK(std::fabs(z - z_expected) <= 0.02 * std::fabs(z_expected));
	CHECK(std::fabs(z - z_level) <= 0.005 * std::fabs(z_level));
	// settled: the last second moves less than 0.5 mm
	const std::vector<row> rows = swell_test::read_hm_log(cl.csv);
	REQUIRE(rows.size() == 25000);
	double lo = 1e9, hi = -1e9;
	for (size_t k = rows.size() - 2500; k < rows.size(); k++) {
		lo = std::min(lo, rows[k].x[2]);
		hi = std::max(hi, rows[k].x[2]);
	}
	INFO("z over the last second in [" << lo << ", " << hi << "] mm");
	CHECK(hi - lo < 0.5);
	// while held above the water the controller commands the weight, -m g = -0.98 N (0.01 N steps)
	CHECK(rows[1000].fcmd[2] == Approx(-0.98).margin(0.011));
	CHECK(rows[1000].state == 3);
	CHECK(figure(s, "commands") >= 24900);
	check_drop_floats(rows);
}

// Messages of one type that swell-hm received (in) or sent (out), from its "frames" line.
unsigned frames(const std::string &summary, unsigned type, const char *dir)
{
	char key[32];
	std::snprintf(key, sizeof key, " 0x%02x in ", type);
	const size_t at = summary.find(key);
	if (at == std::string::npos)
		return 0;
	unsigned in = 0, out = 0;
	REQUIRE(std::sscanf(summary.c_str() + at, " 0x%*x in %u out %u", &in, &out) == 2);
	return std::string(dir) == "in" ? in : out;
}

TEST_CASE("effect mode: the device renders springs, damper and gravity from the controller's updates, reports once an "
	  "update (classic CAN at 2500 Hz within 30 % with the viewer's telemetry), and a drop from 20 mm floats (never "
	  "on the floor, at most 2 N) and settles within 2 s")
{
	closed_loop cl("effect-drop", "device", 200, effect_mode());
	std::vector<std::string> args = cl.hm_args("drop:z=20,hold=0.5", 6.0);
	args.insert(args.end(), {"--sample-every", "10"});
	const std::string s = cl.run(args);
	INFO(s);
	const std::vector<row> rows = swell_test::read_hm_log(cl.csv);
	REQUIRE(rows.size() == 15000);
	// a set every solver step (10 ticks) while running, none went stale, the device rendered them
	CHECK(figure(s, "effects") >= 1400);
	CHECK(s.find(" 0 went stale") != std::string::npos);
	// the device link's traffic as classic CAN frames (worst-case stuffing, docs/protocol.md): no
	// FORCE_CMD while running, a sample (DEVICE_POS + DEVICE_VEL) and a set an update; plus the
	// viewer's telemetry (HEARTBEAT 20/s, SCENE and CTL_INFO 1/s, OBJECT_POSE and OBJECT_FORCE 100/s)
	auto bits = [](unsigned n) { return 47.0 + 8 * n + (33 + 8 * n) / 4; };
	CHECK(frames(s, 0x01, "in") < 10);
	// a sample every 10 ticks once the sets come; before the first set, one every tick: a lockstep
	// wait that timed out there (a loaded machine's controller still starting) lets the device tick on
	// and sample again, one sample more for each such timeout (counted in the summary)
	const unsigned timeouts = (unsigned)figure(s, "timeouts");
	INFO(timeouts << " lockstep timeouts");
	CHECK(frames(s, 0x02, "out") <= 1510 + timeouts);
	CHECK(frames(s, 0x05, "in") == frames(s, 0x07, "in"));
	const double dev_bits = frames(s, 0x01, "in") * bits(8) + frames(s, 0x02, "out") * bits(8) +
		frames(s, 0x03, "out") * bits(7) + frames(s, 0x05, "in") * bits(7) + frames(s, 0x06, "in") * bits(8) +
		frames(s, 0x07, "in") * bits(5);
	const double load = (dev_bits / 6.0 + bits(8) * 222) / 1e6;
	std::printf("effect mode, classic CAN 1 Mbit/s at 2500 Hz with the viewer's telemetry: %.1f %%\n", load * 100);
	CHECK(load <= 0.30);
	// FORCE_CMD carries no force in effect mode: what is applied is the effects' (gravity while held)
	CHECK(rows[1000].fcmd[2] == Approx(-0.981).margin(0.002));
	CHECK(rows[1000].applied == 1);
	check_drop_floats(rows);
	const double z = figure(s, "equilibrium z"), z_level = figure(s, "with level rise");
	CHECK(std::fabs(z - z_level) <= 0.005 * 40.0);
}

TEST_CASE("shake: held and shaken vertically and sideways, the closed loop stays bounded and settles again")
{
	// released where the hand's target is at rest (a quarter period after whole cycles), at 4.1 s;
	// the vertical shake keeps the bottom (-40 mm at rest) clear of the pool floor at -50 mm: the
	// hand overshoots its 8 mm by about a quarter, and floor contact (up to 20 N) is not what this
	// test is about
	const struct {
		const char *name, *hand;
		double f_hz, amp_mm;
	} shakes[] = {
		{"shake-z", "shake:at=1,axis=z,f=2,amp=8,for=3.125,k=3000", 2.0, 8.0},
		{"shake-x", "shake:at=1,axis=x,f=3,amp=20,for=3.0833333,k=3000", 3.0, 20.0},
	};
	for (const auto &sh : shakes) {
		closed_loop cl(sh.name);
		std::vector<std::string> args = cl.hm_args(sh.hand, 8.0);
		args.insert(args.end(), {"--start", "0,0,-39.4"}); // floating at rest when the hand takes it
		const std::string s = cl.run(args);
		const std::vector<row> rows = swell_test::read_hm_log(cl.csv);
		REQUIRE(rows.size() == 20000);
		double x_abs = 0.0, v_abs = 0.0, f_abs = 0.0;
		for (const row &r : rows)
			for (int k = 0; k < 2; k++) {
				x_abs = std::max(x_abs, std::fabs(r.x[k]));
				v_abs = std::max(v_abs, std::fabs(r.v[k]));
			}
		double z_lo = 1e9, z_hi = -1e9;
		for (const row &r : rows) {
			z_lo = std::min(z_lo, r.x[2]);
			z_hi = std::max(z_hi, r.x[2]);
			v_abs = std::max(v_abs, std::fabs(r.v[2]));
			for (int k = 0; k < 3; k++)
				f_abs = std::max(f_abs, std::fabs(r.fcmd[k]));
		}
		const double v_hand = 2.0 * M_PI * sh.f_hz * sh.amp_mm, z = figure(s, "equilibrium z");
		INFO(sh.hand << ": max |x|, |y| " << x_abs << " mm, z in [" << z_lo << ", " << z_hi << "] mm, max |v| " << v_abs
			     << " mm/s (hand " << v_hand << "), max |F_cmd| " << f_abs << " N, equilibrium z " << z << " mm\n"
			     << s);
		CHECK(std::isfinite(z));
		// inside the pool: the 50 mm footprint stays within the 400 mm pool, the box never flies off
		CHECK(x_abs < 175.0);
		CHECK(z_lo > -40.0 - sh.amp_mm * 2.0);
		CHECK(z_hi < -40.0 + sh.amp_mm * 2.0);
		CHECK(v_abs < v_hand * 1.5);
		CHECK(f_abs < 5.0); // weight, buoyancy and drag of a 50 mm cube: a few N at most
		CHECK(figure(s, "walls") == 0);
		// 4 s after the release it floats again within 5% of its depth
		CHECK(std::fabs(z + 40.0) < 2.0);
	}
}

TEST_CASE("press: held at depth the hand carries buoyancy minus weight (k delta - m g), released it floats again")
{
	closed_loop cl("press");
	std::vector<std::string> args = cl.hm_args("press:at=1,depth=45,ramp=0.5,hold=3", 9.0);
	args.insert(args.end(), {"--start", "0,0,-39.4"});
	const std::string s = cl.run(args);
	const std::vector<row> rows = swell_test::read_hm_log(cl.csv);
	REQUIRE(rows.size() == 22500);
	// the last 1.5 s of the hold: the device is at rest on average, so F_hand + F_cmd averages to 0
	double z = 0.0, f_cmd = 0.0, f_hand = 0.0;
	int n = 0;
	for (const row &r : rows)
		if (r.t >= 3.0 && r.t < 4.5) {
			z += r.x[2];
			f_cmd += r.fcmd[2];
			f_hand += r.fhand[2];
			n++;
		}
	REQUIRE(n == 3750);
	z /= n;
	f_cmd /= n;
	f_hand /= n;
	// what the 2 kg, 2 N s/m device did with the difference: m_v dv / T + b_v dz / T (the box rides
	// the slosh the press raised, so it is not quite at rest)
	const row &r0 = rows[7500], &r1 = rows[11250];
	const double f_move = (2.0 * (r1.v[2] - r0.v[2]) + 2.0 * (r1.x[2] - r0.x[2])) * 1e-3 / 1.5;
	// the water the box displaces raises the mean level S = delta a b / A: delta = -z / (1 - a b / A)
	const double k = 1000.0 * 9.81 * 0.05 * 0.05, mg = 0.1 * 9.81;
	const double delta = -z * 1e-3 / (1.0 - 0.05 * 0.05 / (0.4 * 0.4));
	const double f_expected = k * delta - mg;
	INFO("held at z " << z << " mm (delta " << delta * 1e3 << " mm): mean F_cmd " << f_cmd << " N, k delta - m g "
			  << f_expected << " N, mean hand force " << f_hand << " N, m_v dv / T + b_v dz / T " << f_move << " N\n"
			  << s);
	CHECK(std::fabs(z + 45.0) < 0.5);
	CHECK(std::fabs(f_cmd - f_expected) < 0.05); // 0.05 N is 2 mm of water under the box
	CHECK(std::fabs(f_cmd + f_hand - f_move) < 0.01);
	CHECK(f_cmd > 0.1); // pushed under, the water pushes back up
	// 4.5 s after the release: within 2 % of the floating depth, level rise included (the box rides
	// the pool's slosh with the damper of a 2 kg device, docs/force-law.md)
	const double z_end = figure(s, "equilibrium z"), z_level = figure(s, "with level rise");
	CHECK(std::fabs(z_end - z_level) <= 0.02 * 40.0);
}

TEST_CASE("e-stop: while pressed the device applies no force, the controller faults and comes back by itself")
{
	closed_loop cl("estop");
	std::vector<std::string> args = cl.hm_args("drop:z=20,hold=100", 4.0);
	args.insert(args.end(), {"--estop", "2,3"});
	const std::string s = cl.run(args);
	const std::vector<row> rows = swell_test::read_hm_log(cl.csv);
	REQUIRE(rows.size() == 10000);
	int applied_in = 0, fault_seen = 0;
	double t_back = -1.0;
	for (const row &r : rows) {
		if (r.t >= 2.0 && r.t < 3.0) {
			applied_in += r.applied;
			fault_seen |= r.state == 4;
		}
		if (r.t >= 3.0 && t_back < 0.0 && r.applied && std::fabs(r.fcmd[2] + 0.98) < 0.011)
			t_back = r.t;
	}
	INFO("ticks with force applied during the e-stop " << applied_in << ", fault seen " << fault_seen
							   << ", weight back at t = " << t_back << " s\n"
							   << s);
	CHECK(rows[2000].fcmd[2] == Approx(-0.98).margin(0.011)); // held, the weight is commanded
	CHECK(applied_in == 0);
	CHECK(fault_seen == 1);
	CHECK(t_back >= 3.0);
	CHECK(t_back < 3.5);
	CHECK(rows.back().state == 3);
}

TEST_CASE("controller killed mid-run: swell-hm applies zero force within its watchdog (2 ticks), in stream mode, and "
	  "in effect mode at the sets' freshness limit")
{
	const int effect = GENERATE(0, 1);
	INFO((effect ? "effect mode" : "stream mode"));
	closed_loop cl(effect ? "kill-effect" : "kill", "device", 200, effect ? effect_mode() : std::vector<std::string>{});
	// held above the water: the controller commands the weight, -0.98 N, all along
	std::vector<std::string> args = cl.hm_args("drop:z=20,hold=100000", 100000.0);
	if (effect)
		args.insert(args.end(), {"--sample-every", "10"}); // a sample an update, as on classic CAN
	swell_test::Proc hm(args, cl.hm_out);
	// mid-run: once the log holds about 2000 ticks (it is written in blocks), however slow the machine
	struct stat st {};
	for (int k = 0; k < 6000 && (stat(cl.csv.c_str(), &st) != 0 || st.st_size < 200000); k++)
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
	INFO("log size when the controller is killed: " << st.st_size << " bytes");
	REQUIRE(st.st_size >= 200000);
	REQUIRE(cl.ctl.stop(SIGKILL, 10000) == 128 + SIGKILL);
	// the device ticks on without it (slowly while it waits for an answer, then fast once it counts
	// the controller lost): until the log has grown by 16 KB, at least 12 KB of it (over 100 rows)
	// written after the kill (one block, 4 KB, may have waited in the buffer)
	stat(cl.csv.c_str(), &st);
	const off_t at_kill = st.st_size;
	for (int k = 0; k < 6000 && (stat(cl.csv.c_str(), &st) != 0 || st.st_size < at_kill + 16384); k++)
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
	REQUIRE(hm.stop(SIGTERM, 20000) == 0);
	const std::string s = swell_test::slurp(cl.hm_out);
	const std::vector<row> rows = swell_test::read_hm_log(cl.csv);
	INFO(s);
	REQUIRE(rows.size() > 100);
	size_t last = rows.size();
	for (size_t k = 0; k < rows.size(); k++)
		if (rows[k].age == 0)
			last = k;
	REQUIRE(last < rows.size());
	const row &before = rows[last];
	INFO("last command at t = " << before.t << " s with F_cmd z " << before.fcmd[2] << " N; " << rows.size() - last - 1
				    << " ticks after it");
	CHECK(before.applied == 1);
	CHECK(before.fcmd[2] == Approx(-0.98).margin(0.011)); // the weight (effect mode: the bias, -0.981 N)
	REQUIRE(rows.size() - last > 10);
	int applied_after = 0;
	for (size_t k = last + 1; k < rows.size(); k++) {
		applied_after += rows[k].applied;
		if (!rows[k].applied)
			CHECK(rows[k].fcmd[2] == 0.0);
	}
	// stream: held for watchdog - 1 = 1 silent tick, zero from the second; effect: the set is the
	// command and its freshness limit (10 ms = 25 ticks) the watchdog: held 24 ticks, zero from the 25th
	const int held = effect ? 24 : 1;
	CHECK(applied_after == held);
	CHECK(rows[last + held].applied == 1);
	CHECK(rows[last + held + 1].applied == 0);
	// one trip for the kill; before it, one for each time the log shows an enabled command stop being
	// applied (lockstep waits that timed out on a loaded machine can outlast the freshness limit)
	int before_kill = 0;
	for (size_t k = 1; k <= last; k++)
		before_kill += rows[k - 1].applied && !rows[k].applied && rows[k].enable;
	INFO(before_kill << " trips before the kill in the log");
	CHECK(figure(s, "watchdog") == 1 + before_kill);
	CHECK(figure(s, "timeouts") >= 1);
}

TEST_CASE("real time: paced by its own absolute-deadline clock, never faster than wall time, commands applied")
{
	closed_loop cl("realtime", "internal");
	std::vector<std::string> args = cl.hm_args("drop:z=20,hold=100", 2.0);
	args.erase(args.begin() + 1); // no --lockstep: --rate 2500 (the default)
	const std::string s = cl.run(args);
	const size_t at = s.find("\n  ran");
	REQUIRE(at != std::string::npos);
	double sim_s = 0.0, wall_s = 0.0;
	REQUIRE(std::sscanf(s.c_str() + at, "\n  ran %lf s simulated, %*u ticks at %*g Hz, real time, %lf s wall", &sim_s,
			    &wall_s) == 2);
	const std::vector<row> rows = swell_test::read_hm_log(cl.csv);
	int weight = 0, n = 0;
	for (const row &r : rows)
		if (r.t >= 0.5) {
			n++;
			weight += r.applied && std::fabs(r.fcmd[2] + 0.98) < 0.011;
		}
	INFO("simulated " << sim_s << " s in " << wall_s << " s wall; weight applied in " << weight << " of " << n
			  << " ticks after 0.5 s\n"
			  << s);
	CHECK(sim_s == Approx(2.0).epsilon(1e-9));
	CHECK(wall_s >= sim_s);
	CHECK(s.find("\n  tick lateness   p50 ") != std::string::npos);
	CHECK(figure(s, "commands") >= 0.5 * 5000);
	CHECK(weight >= n / 2); // two free-running clocks on a loaded machine: most ticks, not all
}

TEST_CASE("bad parameter sets are refused with a one-line reason, exit 2, nothing sent, no log")
{
	std::string port;
	const int fd = swell_test::udp_loopback(&port);
	const std::string csv = work_dir + "/refused.csv", out = work_dir + "/refused.txt";
	const std::vector<std::vector<std::string>> bad = {
		{"--mass", "0"},
		{"--rate", "5"},
		{"--damping", "-1"},
		{"--mass", "0.01"}, // the 50 kN/m walls are not resolved on 10 g at 2500 Hz
		{"--hand", "wave"},
		{"--hand", "drop:z=999"},
		{"--hand", "shake:axis=w"},
		{"--mass", "0.5", "--hand", "press:k=1000000"}, // hand spring too stiff for 0.5 kg at 2500 Hz
		{"--watchdog", "0"},
		{"--watchdog", "1.5"},
		{"--fmax", "300"},
		{"--start", "0,0,250"},
		{"--start", "0,0"},
		{"--estop", "2,1"},
		{"--link", "tcp"},
		{"--host", "999.1.1.1"},
		{"--seconds", "-1"},
		{"--bogus", "1"},
		{"--pool", "10,10"}, // smaller than the 50 mm object
		{"--object", "100,60,60", "--pool", "400,50"},
		{"--hand", "drop:z=20,z=30"}, // a key given twice
		{"--hand", "shake:axis=x,axis=y"},
	};
	for (const auto &b : bad) {
		std::remove(csv.c_str());
		std::vector<std::string> args = {hm_bin, "--lockstep", "--port", port, "--log", csv, "--seconds", "1"};
		args.insert(args.end(), b.begin(), b.end());
		swell_test::Proc p(args, out);
		const int rc = p.wait(20000);
		const std::string text = swell_test::slurp(out);
		char buf[128];
		const ssize_t got = recv(fd, buf, sizeof buf, MSG_DONTWAIT);
		struct stat st;
		INFO(b[0] << " " << b.back() << ": exit " << rc << ", output '" << text << "'");
		CHECK(rc == 2);
		CHECK(text.rfind("swell-hm: ", 0) == 0);
		CHECK(std::count(text.begin(), text.end(), '\n') == 1);
		CHECK(got < 0);
		CHECK(stat(csv.c_str(), &st) != 0);
	}
	close(fd);
}

TEST_CASE("determinism: the same scripted hand in lockstep gives a bit-identical trace twice")
{
	std::string logs[2];
	for (int k = 0; k < 2; k++) {
		// neither side may act on a timeout, which a loaded machine would make happen at different
		// ticks: the controller ticks by itself only after 4 s of silence, the model waits 5 s
		closed_loop cl("determinism-" + std::to_string(k), "device", 10000);
		std::vector<std::string> args = cl.hm_args("shake:at=0.5,axis=z,f=2,amp=10,for=2", 3.0);
		args.insert(args.end(), {"--timeout-ms", "5000"});
		const std::string s = cl.run(args);
		INFO("run " << k << ":\n" << s);
		CHECK(figure(s, "timeouts") == 0);
		logs[k] = swell_test::slurp(cl.csv);
	}
	const size_t lines = (size_t)std::count(logs[0].begin(), logs[0].end(), '\n');
	INFO("trace of " << lines << " lines");
	CHECK(lines > 7000);
	CHECK(logs[0] == logs[1]);
}

TEST_CASE("runtime failures exit 1 with the reason: no controller ever answered, a log that cannot be written")
{
	const uint16_t port = swell_test::free_udp_port(); // nobody listens there
	const std::string out = work_dir + "/nobody.txt";
	struct {
		std::vector<std::string> extra;
		const char *why;
	} cases[] = {
		{{}, "swell-hm: no controller answered on"},
		{{"--log", "/dev/full"}, "swell-hm: writing /dev/full failed: No space left on device"},
		{{"--log", "/nonexistent/x.csv"}, "swell-hm: cannot write /nonexistent/x.csv: No such file or directory"},
	};
	for (const auto &c : cases) {
		std::vector<std::string> args = {hm_bin,      "--lockstep", "--timeout-ms", "1", "--port", std::to_string(port),
						 "--seconds", "0.1",        "--quiet"};
		args.insert(args.end(), c.extra.begin(), c.extra.end());
		swell_test::Proc p(args, out);
		const int rc = p.wait(20000);
		const std::string text = swell_test::slurp(out);
		INFO(c.why << ": exit " << rc << ", output '" << text << "'");
		CHECK(rc == 1);
		CHECK(text.find(c.why) != std::string::npos);
	}
}

TEST_CASE("energy: the drop creates at most 1 mJ at the controller's port and at the device's, and a link delay "
	  "shows at the device's port only")
{
	// docs/energy.md: the controller counts the force it sent against the positions it got; the
	// device the force it applied (held, delayed) against its own motion
	double device_mJ[2] = {0, 0}, ctl_mJ[2] = {0, 0};
	const char *delay[2] = {"0", "20"};
	for (int k = 0; k < 2; k++) {
		closed_loop cl(std::string("energy-delay-") + delay[k]);
		std::vector<std::string> args = cl.hm_args("drop:z=20,hold=0.5", 10.0);
		args.insert(args.end(), {"--link-delay", delay[k]});
		const std::string s = cl.run(args);
		const std::string ctl = swell_test::slurp(cl.ctl_out);
		INFO(s << "\n" << ctl);
		device_mJ[k] = figure(s, "energy          created");
		ctl_mJ[k] = figure(ctl, "energy          created");
		// the log's last column is the device's balance D: its least value is the energy created
		std::ifstream f(cl.csv);
		std::string line;
		double d_min = 0;
		std::getline(f, line);
		while (std::getline(f, line)) {
			const double d = std::strtod(line.c_str() + line.rfind(',') + 1, nullptr);
			d_min = std::min(d_min, d);
		}
		CHECK(-d_min == Approx(device_mJ[k]).margin(0.0015));
	}
	std::printf("energy created in the drop: controller %.3f / %.3f mJ, device %.3f / %.3f mJ (link delay 0 / 20 "
		    "ms)\n",
		    ctl_mJ[0], ctl_mJ[1], device_mJ[0], device_mJ[1]);
	CHECK(ctl_mJ[0] <= 1.0);
	CHECK(device_mJ[0] <= 1.0);
	CHECK(ctl_mJ[1] <= 1.0);
	CHECK(device_mJ[1] > device_mJ[0]);
}
