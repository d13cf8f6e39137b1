// swell-hmbridge between a controller scripted in this test (swell's protocol over UDP loopback) and
// swell-hm --serve (the HapticMaster's TCP interface): samples go up with the device's state, a
// FORCE_CMD becomes the device's bias force, the bridge's watchdog zeroes it when the controller
// falls silent, and a dead HapticMaster means no samples, so the controller would fault.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "hm_tcp.hpp"
#include "swell_msg_udp.hpp"

extern "C" {
#include "swell/effect.h"
#include "swell/proto.h"
#include "swell/transport.h"
}

using hmtcp::Server;

namespace {

const std::string hm_bin = SWELL_HM_BIN;
const std::string bridge_bin = SWELL_HMBRIDGE_BIN;
const std::string work_dir = SWELL_BRIDGE_TEST_DIR;

// The controller's side: the bridge's samples come in, FORCE_CMDs go back to their sender.
struct Ctl : swell_test::MsgUdp {
	// samples that arrive within ms: count, and the last DEVICE_POS
	int samples(int ms, swell_msg_device_pos *newest)
	{
		int n = 0;
		std::vector<swell_msg> got;
		const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
		while (std::chrono::steady_clock::now() < until)
			if (recv(got, 1))
				for (const swell_msg &m : got)
					if (m.type == SWELL_MSG_DEVICE_POS) {
						n++;
						if (newest)
							*newest = m.u.device_pos;
					}
		return n;
	}
	// a FORCE_CMD, after the effect set when one is given (effect mode), in one packet
	void force(int16_t fz_cN, int enable, const swell_effect *set = nullptr)
	{
		swell_msg m[4]{};
		size_t n = 0;
		if (set) {
			swell_effect_encode(set, 0, m);
			n = 3;
		}
		m[n].type = SWELL_MSG_FORCE_CMD;
		m[n].u.force_cmd.fz_cN = fz_cN;
		m[n].u.force_cmd.enable = (uint8_t)enable;
		m[n].u.force_cmd.seq = seq;
		send(0, m, n + 1); /* to the bridge, once it has sent */
	}
};

} // namespace

TEST_CASE(
	"bridge: samples go up, a FORCE_CMD becomes the bias force, silence is zero force, a dead HapticMaster stops the samples")
{
	const std::string csv = work_dir + "/bridge.csv";
	std::remove(csv.c_str());
	Server hm(hm_bin, work_dir + "/bridge.hm.txt", {"--seconds", "60", "--log", csv});
	REQUIRE(hm.port > 0);
	Ctl ctl;
	swell_test::Proc br(
		{bridge_bin, "--hm", "127.0.0.1:" + std::to_string(hm.port), "--port", std::to_string(ctl.port), "--quiet"},
		work_dir + "/bridge.txt");
	swell_msg_device_pos pos{};
	// the bridge starts the device and streams its samples, one a tick, whether or not commands come
	// (more than 100 of them and the force rendered within 10 s: a loaded machine streams slower)
	int n = ctl.samples(1000, &pos);
	for (int k = 0; k < 90 && (n <= 100 || !(pos.status & 2u)); k++)
		n += ctl.samples(100, &pos);
	CHECK(n > 100);
	CHECK(pos.status == 3); // powered, force rendered
	// a controller streaming +1.50 N for 0.5 s
	for (int k = 0; k < 1250; k++) {
		ctl.force(150, 1);
		ctl.samples(0, nullptr);
		std::this_thread::sleep_for(std::chrono::microseconds(400));
	}
	ctl.samples(300, &pos); // silent now: the bridge's watchdog zeroes the force
	hm.stop(SIGKILL); // the HapticMaster dies: the log holds what it rendered
	ctl.samples(200, nullptr);
	const int after_death = ctl.samples(300, nullptr);
	CHECK(after_death == 0);
	const int rc = br.stop();
	const std::string sum = swell_test::slurp(br.out);
	INFO(sum);
	CHECK(rc == 0);
	CHECK(swell_test::count_before(sum, " trips (2 ticks") >= 1);
	CHECK(sum.find("1 resets") != std::string::npos);
	const std::vector<swell_test::HmLogRow> rows = swell_test::read_hm_log(csv);
	REQUIRE(rows.size() > 100);
	int at_1_5 = 0, other = 0;
	size_t last_force = 0;
	for (size_t k = 0; k < rows.size(); k++) {
		if (std::fabs(rows[k].fcmd[2] - 1.5) < 1e-9) {
			at_1_5++;
			last_force = k;
		} else if (rows[k].fcmd[2] != 0.0) {
			other++;
		}
	}
	INFO(at_1_5 << " ticks at 1.5 N, " << other << " at another nonzero force");
	CHECK(at_1_5 > 500);
	CHECK(other == 0);
	CHECK(last_force + 1 < rows.size());
	CHECK(rows.back().fcmd[2] == 0.0);
}

TEST_CASE("bridge, effect mode: the effect sets become the HapticMaster's springs, damper and bias force with the same values, "
	  "removed when the sets go stale and when the controller falls silent")
{
	Server hm(hm_bin, work_dir + "/bridge-effect.hm.txt", {"--seconds", "60"});
	REQUIRE(hm.port > 0);
	Ctl ctl;
	// the bridge's watchdog at 25 ticks (10 ms): this test's scripted controller is not real time
	swell_test::Proc br({bridge_bin, "--hm", "127.0.0.1:" + std::to_string(hm.port), "--port", std::to_string(ctl.port),
			     "--quiet", "--watchdog", "25"},
			    work_dir + "/bridge-effect.txt");
	swell_msg_device_pos pos{};
	for (int k = 0; k < 50 && !(pos.status & 2u); k++)
		ctl.samples(100, &pos);
	REQUIRE(pos.status == 3);
	swell_effect set{};
	set.surface_10um = 1234; // 12.34 mm
	set.h_10um = 5000;
	set.uw_100ums = -56; // -5.6 mm/s
	set.k_10mN_m = 2452;
	set.b_10mNs_m = 1200;
	set.bias_mN = -981;
	set.fmax_cN = 1000;
	set.rate_100mN_s = 1000;
	hmtcp::Client other(hm.port);
	const std::string ask = "get swell_pull stiffness;get swell_push stiffness;get swell_pull deadband;get swell_push "
				"deadband;get swell_pull direction;get swell_pull dampfactor;get swell_pull maxforce;get "
				"swell_push maxforce;get swell_damp dampcoef;get swell_weight force;get swell_pull vel;get "
				"swell_push vel;get swell_damp vel;get swell_pull pos;get swell_push pos;get swell_pull enabled;"
				"get swell_push enabled;get swell_damp enabled;get swell_weight enabled";
	const std::string removed = "get swell_pull enabled;get swell_push enabled;get swell_damp enabled;get swell_weight "
				    "enabled";
	auto run = [&](int ticks, bool sets, int ask_every, const std::string &what) {
		int asked = 0;
		for (int k = 0; k < ticks; k++) {
			if (sets && k % 5 == 0)
				set.seq++;
			ctl.force(0, 1, sets && k % 5 == 0 ? &set : nullptr);
			ctl.samples(0, nullptr);
			if (ask_every && k % ask_every == ask_every - 1 && other.raw(hmtcp::frame(what)))
				asked++;
			std::this_thread::sleep_for(std::chrono::microseconds(400));
		}
		std::vector<std::string> replies;
		for (int k = 0; k < asked; k++)
			replies.push_back(other.reply(2000));
		return replies;
	};
	// a controller in effect mode: a set every 5 ticks, the read-back asked 12 times while it runs
	// (this scripted controller is not real time: on a loaded machine a pause of 10 ms trips the
	// bridge's watchdog and an answer may come while the effects are gone)
	const std::vector<std::string> live = run(1250, true, 100, ask);
	int whole = 0;
	for (const std::string &r : live) {
		INFO(r);
		if (r.find("ERROR") != std::string::npos)
			continue; // the bridge's watchdog tripped just then: the effects were gone
		whole++;
		const std::vector<std::string> a = hmtcp::answers(r);
		REQUIRE(a.size() == 19);
		CHECK(a[0] == "24.52");
		CHECK(a[1] == "-24.52");
		CHECK(a[2] == "1");
		CHECK(a[3] == "1");
		CHECK(a[4] == "[0,0,1]");
		CHECK(a[5] == "0");
		CHECK(a[6] == "10");
		CHECK(a[7] == "10");
		CHECK(a[8] == "[0,0,12]");
		CHECK(a[9] == "[0,0,-0.981]");
		for (int k = 10; k < 13; k++)
			CHECK(a[k] == "[0,0,-0.0056]");
		const std::vector<double> pull = hmtcp::numbers(a[13]), push = hmtcp::numbers(a[14]);
		REQUIRE(pull.size() == 3);
		REQUIRE(push.size() == 3);
		// set at w + 1 m and w - H + 1 m, then riding u_w for the ticks since the update (< 50 ms)
		CHECK(pull[2] <= 1.01234 + 1e-9);
		CHECK(pull[2] >= 1.01234 - 0.0056 * 0.05);
		CHECK(std::fabs(pull[2] - push[2] - 0.05) < 1e-9);
		for (int k = 15; k < 19; k++)
			CHECK(a[k] == "true");
	}
	CHECK(whole >= 1);
	// FORCE_CMD goes on, the sets stop: stale after 10 ms, the effects removed
	const std::vector<std::string> stale = run(500, false, 250, removed);
	REQUIRE(stale.size() == 2);
	CHECK(stale[1].find("--- ERROR") == 0);
	// sets again: the effects are back (asked 5 times: an answer that comes between a watchdog trip
	// and the next set finds them gone, as above)
	const std::vector<std::string> again = run(500, true, 100, removed);
	REQUIRE(again.size() == 5);
	CHECK(std::count(again.begin(), again.end(), "true;true;true;true") >= 1);
	// then the controller falls silent: the bridge's watchdog removes them (asked until it has, a
	// tick of the bridge at the earliest 10 ms after the last command)
	std::string silent;
	for (int k = 0; k < 500 && silent.find("--- ERROR") != 0; k++) {
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
		silent = other.ask(removed);
	}
	CHECK(silent.find("--- ERROR") == 0);
	CHECK(br.stop() == 0);
	const std::string sum = swell_test::slurp(br.out);
	INFO(sum);
	CHECK(swell_test::count_before(sum, " sets taken") >= 150);
	CHECK(swell_test::count_before(sum, " went stale") >= 1);
	CHECK(swell_test::count_before(sum, " created the effects)") >= 2);
	CHECK(swell_test::count_before(sum, " removals") >= 2);
}
