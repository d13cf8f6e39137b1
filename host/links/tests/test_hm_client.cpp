// The controller's HapticMaster client (hm_client.c) against a device scripted in this test over
// loopback TCP: the decimal parser without floating point, the start-up request, the text of a tick,
// answers into DEVICE_POS / DEVICE_VEL, stale answers dropped, a stopped device reported and started
// again, garbage and resets answered by a reconnection, and the zero force confirmed on exit.
#include "swell_test.hpp"

#include <poll.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>

extern "C" {
#include "hm_client.h"
#include "hm_fx.h"
}

#include <random>

namespace {

// expected: v in units of 10^-7, rounded half away from zero to units of 10^-5 and saturated
int32_t round_100(long v, int32_t limit)
{
	const long a = v < 0 ? -v : v, q = (a + 50) / 100;
	const long s = q > limit ? limit : q;
	return (int32_t)(v < 0 ? -s : s);
}

std::string decimal7(long v)
{
	const long a = v < 0 ? -v : v;
	char b[40];
	std::snprintf(b, sizeof b, "%s%ld.%07ld", v < 0 ? "-" : "", a / 10000000, a % 10000000);
	return b;
}

struct Device {
	int lfd = -1, fd = -1, port = 0;
	Device() { lfd = swell_test::loopback_socket(SOCK_STREAM, &port); }
	~Device()
	{
		if (fd >= 0)
			close(fd);
		close(lfd);
	}
	bool accept_one(hm_client &c, int ms)
	{
		for (int k = 0; k < ms; k++) {
			swell_msg m[8];
			hm_client_poll(&c, m, 8, 0);
			pollfd p = {lfd, POLLIN, 0};
			if (poll(&p, 1, 1) > 0) {
				if (fd >= 0)
					close(fd);
				fd = accept(lfd, nullptr, nullptr);
				return fd >= 0;
			}
		}
		return false;
	}
	// one request's text, driving the client meanwhile
	std::string request(hm_client &c, int ms = 2000)
	{
		std::string got;
		for (int k = 0; k < ms; k++) {
			swell_msg m[8];
			hm_client_poll(&c, m, 8, 0);
			pollfd p = {fd, POLLIN, 0};
			if (poll(&p, 1, 1) <= 0)
				continue;
			char b[4096];
			const ssize_t n = recv(fd, b, got.size() < 8 ? 8 - got.size() : 8 + len(got) - got.size(), 0);
			if (n <= 0)
				return "<closed>";
			got.append(b, (size_t)n);
			if (got.size() >= 8 && got.size() == 8 + len(got))
				return got.substr(8);
		}
		return "<none>";
	}
	static size_t len(const std::string &h)
	{
		return (size_t)(uint8_t)h[0] << 24 | (size_t)(uint8_t)h[1] << 16 | (size_t)(uint8_t)h[2] << 8 | (uint8_t)h[3];
	}
	void answer(const std::string &t, bool bad_header = false) const
	{
		const uint32_t n = (uint32_t)t.size();
		std::string f = {char(n >> 24), char(n >> 16), char(n >> 8), char(n), 0, 0, 0, char(bad_header ? 1 : 0)};
		f += t;
		REQUIRE(send(fd, f.data(), f.size(), MSG_NOSIGNAL) == (ssize_t)f.size());
	}
};

// poll the client until it gives messages (or ms pass)
size_t collect(hm_client &c, swell_msg *m, size_t cap, int ms = 1000)
{
	for (int k = 0; k < ms; k++) {
		const size_t n = hm_client_poll(&c, m, cap, 3);
		if (n)
			return n;
		std::this_thread::sleep_for(std::chrono::milliseconds(1));
	}
	return 0;
}

// the start-up's three requests and a device's good answers to them
const std::string remove_all = "remove swell_bias;remove swell_pull;remove swell_push;remove swell_damp;remove swell_weight";
const std::string probe = "get emergencybuttonpushed;get state";
const std::string probe_ok = "false;off";
const std::string init = remove_all + ";set state init;get position_calibrated;get force_calibrated";
const std::string init_ok = "--- ERROR: unknown effect 'swell_bias';--- ERROR: unknown effect 'swell_pull';--- ERROR: "
			    "unknown effect 'swell_push';--- ERROR: unknown effect 'swell_damp';--- ERROR: unknown "
			    "effect 'swell_weight';state set to 'init';true;true";
const std::string start = "set state force;create biasforce swell_bias;set swell_bias force [0,0,0];set swell_bias enable";
const std::string start_ok =
	"state set to 'force';Effect biasforce with name swell_bias created;Bias force's force set;Effect swell_bias enabled";

// the whole start-up, answered well
void start_up(Device &dev, hm_client &c, int ms = 2000)
{
	REQUIRE(dev.request(c, ms) == probe);
	dev.answer(probe_ok);
	REQUIRE(dev.request(c) == init);
	dev.answer(init_ok);
	REQUIRE(dev.request(c) == start);
	dev.answer(start_ok);
}

// a client connected to the scripted device, past its start-up; closed at the end
struct Started {
	Device dev;
	hm_client c;
	Started()
	{
		char err[160];
		REQUIRE(hm_client_open(&c, ("127.0.0.1:" + std::to_string(dev.port)).c_str(), 2, err, sizeof err) == 0);
		REQUIRE(dev.accept_one(c, 2000));
		start_up(dev, c);
	}
	~Started() { hm_client_close(&c); }
};

} // namespace

TEST_CASE("hm_client: decimal text to fixed point without floats, rounded half away from zero, saturated")
{
	int wrong = 0;
	std::string first;
	for (long v = -40000000; v <= 40000000; v += 997) { // 1e-7 m steps across +-4 m, past the +-0.3 m limit
		for (long frac : {0L, 49L, 50L, 51L}) {
			const long x = v + (v < 0 ? -frac : frac);
			const std::string t = decimal7(x);
			const char *p = t.c_str();
			int32_t got = 0;
			if (hm_client_parse_fixed(&p, 5, 30000, &got) != 0 || *p || got != round_100(x, 30000)) {
				if (!wrong++)
					first = t + " -> " + std::to_string(got) + ", want " +
						std::to_string(round_100(x, 30000));
			}
		}
	}
	INFO(first);
	CHECK(wrong == 0);
	struct {
		const char *text;
		int scale;
		int32_t want;
		size_t used;
	} cases[] = {
		{"1.5e-05", 5, 2, 7},
		{"-2.5e-05", 5, -3, 8},
		{"1.2e-07", 5, 0, 7},
		{"2", 4, 20000, 1},
		{"0.00038]", 4, 4, 7},
		{"-0", 5, 0, 2},
		{"1e-30", 5, 0, 5},
		{"3E+2", 0, 300, 4},
		{"1e", 5, 30000, 1},
		{"+7.", 1, 70, 3},
		{"123456789012345678901234", 0, 30000, 24},
		{"0.000000000000000000000123456789e22", 0, 1, 35},
		{"0.0000012345678e6", 3, 1235, 17},
	};
	for (const auto &c : cases) {
		const char *p = c.text;
		int32_t got = -1;
		INFO(c.text);
		REQUIRE(hm_client_parse_fixed(&p, c.scale, 30000, &got) == 0);
		CHECK(got == c.want);
		CHECK((size_t)(p - c.text) == c.used);
	}
	for (const char *bad : {"", "abc", ".", "-", "-.e5", "[1]"}) {
		const char *p = bad;
		int32_t got = 7;
		INFO(bad);
		CHECK(hm_client_parse_fixed(&p, 5, 30000, &got) == -1);
		CHECK(p == bad);
		CHECK(got == 7);
	}
}

TEST_CASE("hm_client: start-up to force, then one request a tick, answers become DEVICE_VEL and DEVICE_POS")
{
	Started st;
	Device &dev = st.dev;
	hm_client &c = st.c;
	// running: a first sample is asked for at once (a device-clocked controller ticks on it)
	CHECK(dev.request(c) == "set swell_bias force [0.00,0.00,0.00];get measpos;get modelvel;get state");
	const int16_t f[3] = {123, -5, 0};
	CHECK(c.phase == HMC_RUNNING);
	dev.answer("Bias force's force set;[0.01,-0.002,-0.0393912];[0,0,0.00038];force");
	swell_msg m[8];
	REQUIRE(collect(c, m, 8) == 2);
	CHECK(m[0].type == SWELL_MSG_DEVICE_VEL);
	CHECK(m[0].node == 3);
	CHECK(m[0].u.device_vel.vz_100ums == 4);
	CHECK(m[1].type == SWELL_MSG_DEVICE_POS);
	CHECK(m[1].u.device_pos.x_10um == 1000);
	CHECK(m[1].u.device_pos.y_10um == -200);
	CHECK(m[1].u.device_pos.z_10um == -3939);
	CHECK(m[1].u.device_pos.status == 3); // powered, force rendered
	hm_client_force(&c, f, 1);
	CHECK(dev.request(c) == "set swell_bias force [1.23,-0.05,0.00];get measpos;get modelvel;get state");
	hm_client_force(&c, f, 0); // enable 0: zero force
	CHECK(dev.request(c) == "set swell_bias force [0.00,0.00,0.00];get measpos;get modelvel;get state");
	CHECK(c.st.requests == 3);
}

TEST_CASE("hm_client: an answer older than 2 ticks is dropped, the pipeline is not deepened past it, a stopped device is "
	  "reported and started again")
{
	Started st;
	Device &dev = st.dev;
	hm_client &c = st.c;
	REQUIRE(dev.request(c).rfind("set swell_bias force", 0) == 0);
	const std::string ok = "Bias force's force set;[0,0,0.01];[0,0,0];force";
	dev.answer(ok);
	swell_msg m[8];
	REQUIRE(collect(c, m, 8) == 2);
	const int16_t f[3] = {0, 0, 100};
	for (int k = 0; k < 3; k++) { // three ticks sent, answered only after a fourth
		hm_client_force(&c, f, 1);
		REQUIRE(dev.request(c).rfind("set swell_bias force [0.00,0.00,1.00]", 0) == 0);
	}
	// three unanswered: a fourth answer would be stale on arrival, so the tick sends nothing...
	hm_client_force(&c, f, 1);
	CHECK(c.st.skipped == 1);
	CHECK(c.ring_n == 3);
	// ...except a change to zero force, which always goes
	hm_client_force(&c, f, 0);
	CHECK(dev.request(c) == "set swell_bias force [0.00,0.00,0.00];get measpos;get modelvel;get state");
	hm_client_force(&c, f, 0); // zero again: the pipeline is deep, nothing new to say
	CHECK(c.st.skipped == 2);
	for (int k = 0; k < 4; k++)
		dev.answer(ok);
	size_t got = 0;
	for (int k = 0; k < 200 && c.st.answers < 6; k++)
		got += collect(c, m + got, 8 - got, 5);
	CHECK(c.st.answers == 8); // start-up (three), the first sample, four ticks
	CHECK(c.st.late == 3); // read 5, 4 and 3 ticks after they were asked for (6 ticks have passed)
	CHECK(got == 2); // the zero's answer, 1 tick old, is a sample
	// another client stopped the device: not rendering (bit 2), and a new start-up after the pause
	hm_client_force(&c, f, 1);
	REQUIRE(dev.request(c).rfind("set swell_bias force", 0) == 0);
	dev.answer("Bias force's force set;[0,0,0.01];[0,0,0];stop");
	REQUIRE(collect(c, m, 8) == 2);
	CHECK(m[1].u.device_pos.status == 5);
	CHECK(c.phase == HMC_HOLDOFF);
	CHECK(c.st.not_force == 1);
	const auto t0 = std::chrono::steady_clock::now();
	CHECK(dev.request(c, 3000) == probe);
	const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
	CHECK(waited >= HMC_RETRY_MS * 1e-3 * 0.9);
	// refused (e-stop still pushed): nothing more is asked, it holds off and probes again
	dev.answer("true;stop");
	CHECK(dev.request(c, 3000) == probe);
	CHECK(c.st.startup_failures == 1);
	CHECK(std::string(c.refusal).find("e-stop is pushed") != std::string::npos);
	dev.answer(probe_ok); // released: the start-up goes on, and the reason is cleared once running
	REQUIRE(dev.request(c) == init);
	dev.answer(init_ok);
	REQUIRE(dev.request(c) == start);
	dev.answer(start_ok);
	REQUIRE(dev.request(c).rfind("set swell_bias force", 0) == 0);
	CHECK(c.phase == HMC_RUNNING);
	CHECK(c.refusal[0] == '\0');
}

TEST_CASE("hm_client: a device that does not report itself calibrated after init, or refuses init, gets no force state "
	  "and no bias, and the reason is kept")
{
	Device dev;
	hm_client c;
	char err[160];
	REQUIRE(hm_client_open(&c, ("127.0.0.1:" + std::to_string(dev.port)).c_str(), 2, err, sizeof err) == 0);
	REQUIRE(dev.accept_one(c, 2000));
	struct {
		std::string init_answer, reason;
	} cases[] = {
		{init_ok.substr(0, init_ok.size() - 9) + "false;true", "position is not calibrated"},
		{init_ok.substr(0, init_ok.size() - 9) + "true;false", "force sensor is not calibrated"},
		{init_ok.substr(0, init_ok.size() - 9) + "\"true\";\"false\"", "force sensor is not calibrated"},
		{init_ok.substr(0, init_ok.size() - 29) + "--- ERROR: emergency button pushed: state 'init' refused;false;false",
		 "refused 'set state init'"},
	};
	uint32_t failures = 0, seq = 0;
	for (const auto &k : cases) {
		INFO(k.init_answer);
		REQUIRE(dev.request(c, 3000) == probe);
		dev.answer(probe_ok);
		REQUIRE(dev.request(c) == init);
		dev.answer(k.init_answer);
		// the next request is the probe again, after the pause: never the force state
		const auto t0 = std::chrono::steady_clock::now();
		REQUIRE(dev.request(c, 3000) == probe);
		CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >= HMC_RETRY_MS * 1e-3 * 0.9);
		CHECK(c.phase == HMC_STARTING);
		CHECK(c.st.startup_failures == ++failures);
		CHECK(std::string(c.refusal).find(k.reason) != std::string::npos);
		CHECK(c.refusal_seq >= seq);
		seq = c.refusal_seq;
		dev.answer("true;stop"); // and back to the top of the loop through an e-stop refusal
		failures++;
	}
	swell_msg m[8];
	for (int k = 0; k < 500 && c.st.startup_failures < failures; k++)
		collect(c, m, 8, 1);
	CHECK(c.st.startup_failures == failures);
	CHECK(c.st.samples == 0);
	hm_client_close(&c);
}

TEST_CASE("hm_client: a garbage answer or a reset closes the link, counts what was in flight as lost, and it reconnects")
{
	Started st;
	Device &dev = st.dev;
	hm_client &c = st.c;
	REQUIRE(dev.request(c).rfind("set swell_bias force", 0) == 0);
	dev.answer("junk", true); // bytes 4-7 not zero
	swell_msg m[8];
	for (int k = 0; k < 500 && c.phase != HMC_DOWN; k++)
		collect(c, m, 8, 1);
	CHECK(c.phase == HMC_DOWN);
	CHECK(c.st.garbage == 1);
	CHECK(c.st.resets == 1);
	CHECK(c.st.lost == 1);
	CHECK(hm_client_fd(&c) == -1);
	REQUIRE(dev.accept_one(c, 3000)); // a new connection after the retry period
	start_up(dev, c);
	CHECK(c.st.connects == 2);
	// a reset from the device's side
	REQUIRE(dev.request(c).rfind("set swell_bias force", 0) == 0);
	linger lg = {1, 0};
	setsockopt(dev.fd, SOL_SOCKET, SO_LINGER, &lg, sizeof lg);
	close(dev.fd);
	dev.fd = -1;
	for (int k = 0; k < 500 && c.phase != HMC_DOWN; k++)
		collect(c, m, 8, 1);
	CHECK(c.phase == HMC_DOWN);
	CHECK(c.st.resets == 2);
	CHECK(c.st.lost == 2);
}

TEST_CASE("hm_client: the exit path waits for the device to confirm the zero force, and reports failure when it does not")
{
	Started st;
	Device &dev = st.dev;
	hm_client &c = st.c;
	REQUIRE(dev.request(c).rfind("set swell_bias force", 0) == 0);
	// the device answers the tick late and the zero at once: both are waited for
	std::string seen;
	std::thread device([&] {
		std::this_thread::sleep_for(std::chrono::milliseconds(20));
		dev.answer("Bias force's force set;[0,0,0];[0,0,0];force");
		char b[256];
		pollfd p = {dev.fd, POLLIN, 0};
		if (poll(&p, 1, 2000) > 0) {
			const ssize_t n = recv(dev.fd, b, sizeof b, 0);
			seen.assign(b, n > 0 ? (size_t)n : 0);
		}
		dev.answer("Bias force's force set;Removed effect swell_bias;--- ERROR: unknown effect 'swell_pull';--- ERROR: "
			   "unknown effect 'swell_push';--- ERROR: unknown effect 'swell_damp';--- ERROR: unknown effect "
			   "'swell_weight'");
	});
	CHECK(hm_client_zero_wait(&c, 1000) == 0);
	device.join();
	CHECK(seen.substr(8) == "set swell_bias force [0,0,0];" + remove_all); // the zero first, then swell's effects
	// a device that never answers: -1 after the wait
	const auto t0 = std::chrono::steady_clock::now();
	CHECK(hm_client_zero_wait(&c, 50) == -1);
	CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 1.0);
}

TEST_CASE("hm_fx: an effect set as the device's commands: each value exact in SI units, signs and the deadband's offsets, "
	  "parsed back without floats to the set")
{
	swell_effect e{};
	e.surface_10um = -1234;
	e.h_10um = 5000;
	e.uw_100ums = -5;
	e.k_10mN_m = 2452;
	e.b_10mNs_m = 1201;
	e.bias_mN = -981;
	e.fmax_cN = 1000;
	char text[HMC_TEXT_MAX];
	REQUIRE(hm_fx_values(&e, text, sizeof text) > 0);
	CHECK(std::string(text) ==
	      "set swell_pull pos [0,0,0.98766];set swell_pull vel [0,0,-0.0005];set swell_pull stiffness 24.52;"
	      "set swell_pull maxforce 10.00;set swell_push pos [0,0,0.93766];set swell_push vel [0,0,-0.0005];"
	      "set swell_push stiffness -24.52;set swell_push maxforce 10.00;set swell_damp dampcoef [0,0,12.01];"
	      "set swell_damp vel [0,0,-0.0005];set swell_weight force [0,0,-0.981]");
	CHECK(hm_fx_values(&e, text, 100) == 0); // does not fit: nothing
	// random sets over the wire ranges: every number parses back to the set's integer
	std::mt19937 rng(17);
	auto in = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
	auto value = [](const char *t, const char *key, int nth) {
		const char *p = std::strstr(t, key);
		REQUIRE(p != nullptr);
		p += std::strlen(key);
		for (int k = 0; k < nth; k++)
			p = std::strchr(p, ',') + 1;
		return p;
	};
	for (int n = 0; n < 2000; n++) {
		e.surface_10um = in(-30000, 30000);
		e.h_10um = in(1, 65535);
		e.uw_100ums = in(-30000, 30000);
		e.k_10mN_m = (uint32_t)in(0, 65535);
		e.b_10mNs_m = (uint32_t)in(0, 65535);
		e.bias_mN = in(-8388607, 8388607);
		e.fmax_cN = (uint32_t)in(1, 25000);
		REQUIRE(hm_fx_values(&e, text, sizeof text) > 0);
		int32_t v = 0;
		const char *p = value(text, "swell_pull pos [", 2);
		REQUIRE(hm_client_parse_fixed(&p, 5, 1 << 30, &v) == 0);
		CHECK(v == e.surface_10um + HM_FX_DEADBAND_10UM);
		p = value(text, "swell_push pos [", 2);
		REQUIRE(hm_client_parse_fixed(&p, 5, 1 << 30, &v) == 0);
		CHECK(v == e.surface_10um - e.h_10um + HM_FX_DEADBAND_10UM);
		p = value(text, "swell_damp vel [", 2);
		REQUIRE(hm_client_parse_fixed(&p, 4, 1 << 30, &v) == 0);
		CHECK(v == e.uw_100ums);
		p = value(text, "swell_push stiffness ", 0);
		REQUIRE(hm_client_parse_fixed(&p, 2, 1 << 30, &v) == 0);
		CHECK(v == -(int32_t)e.k_10mN_m);
		p = value(text, "swell_damp dampcoef [", 2);
		REQUIRE(hm_client_parse_fixed(&p, 2, 1 << 30, &v) == 0);
		CHECK(v == (int32_t)e.b_10mNs_m);
		p = value(text, "swell_weight force [", 2);
		REQUIRE(hm_client_parse_fixed(&p, 3, 1 << 30, &v) == 0);
		CHECK(v == e.bias_mN);
		p = value(text, "swell_pull maxforce ", 0);
		REQUIRE(hm_client_parse_fixed(&p, 2, 1 << 30, &v) == 0);
		CHECK(v == (int32_t)e.fmax_cN);
	}
}

TEST_CASE("hm_client: with an inertia to set, init sets it after the calibrations, and a refusal of it stops the start-up")
{
	Device dev;
	hm_client c;
	char err[160];
	REQUIRE(hm_client_open(&c, ("127.0.0.1:" + std::to_string(dev.port)).c_str(), 2, err, sizeof err) == 0);
	c.inertia_g = 2500;
	REQUIRE(dev.accept_one(c, 2000));
	REQUIRE(dev.request(c) == probe);
	dev.answer(probe_ok);
	REQUIRE(dev.request(c) == init + ";set inertia 2.500");
	dev.answer(init_ok + ";--- ERROR: inertia 2.5 refused");
	REQUIRE(dev.request(c, 3000) == probe); // refused: no force state, the probe again after the pause
	CHECK(std::string(c.refusal).find("set inertia") != std::string::npos);
	dev.answer(probe_ok);
	REQUIRE(dev.request(c) == init + ";set inertia 2.500");
	dev.answer(init_ok + ";Inertia set");
	REQUIRE(dev.request(c) == start);
	dev.answer(start_ok);
	REQUIRE(dev.request(c).rfind("set swell_bias force", 0) == 0);
	CHECK(c.phase == HMC_RUNNING);
	hm_client_close(&c);
}
