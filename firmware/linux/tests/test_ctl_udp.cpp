/* swell-ctl as a process, over its UDP host link: parameter sets from a viewer are validated, refused
 * ones answered with a NACK and without effect, good ones acknowledged with the value in force. */
#include <catch2/catch.hpp>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

extern "C" {
#include "swell/ctl.h"
#include "swell/link.h"
}

extern char **environ;

namespace {

struct Viewer {
	swell_link *l = nullptr;
	uint8_t seq = 0;
	~Viewer()
	{
		if (l)
			swell_link_close(l);
	}
	void send(const swell_msg &m)
	{
		swell_frame f{};
		size_t used = 0;
		REQUIRE(swell_link_encode(SWELL_CARRIER_PKT, 0, seq++, &m, 1, &f, &used) == SWELL_OK);
		REQUIRE(swell_link_send(l, &f) == 0);
	}
	/* The first message of type a (or b) within timeout_ms, or type 0. */
	swell_msg wait_for(uint8_t type, int timeout_ms, uint8_t or_type = 0)
	{
		const uint64_t until = swell_link_now_ns() + (uint64_t)timeout_ms * 1000000u;
		while (swell_link_now_ns() < until) {
			swell_frame f{};
			swell_msg m[SWELL_PKT_MSGS_MAX];
			size_t n = 0;
			if (swell_link_recv(l, &f, 50) != 0)
				continue;
			if (swell_link_decode(SWELL_CARRIER_PKT, &f, m, SWELL_PKT_MSGS_MAX, &n, nullptr, nullptr) != SWELL_OK)
				continue;
			for (size_t k = 0; k < n; k++)
				if (m[k].type == type || (or_type && m[k].type == or_type))
					return m[k];
		}
		return swell_msg{};
	}
	swell_msg param(uint8_t type, uint16_t id, int32_t value)
	{
		swell_msg m{};
		m.type = type;
		if (type == SWELL_MSG_PARAM_SET) {
			m.u.param_set.id = id;
			m.u.param_set.value = value;
			m.u.param_set.seq = seq;
		} else {
			m.u.param_get.id = id;
			m.u.param_get.seq = seq;
		}
		send(m);
		return wait_for(SWELL_MSG_PARAM_ACK, 2000, SWELL_MSG_PARAM_NACK); /* among telemetry */
	}
};

} // namespace

TEST_CASE("swell-ctl over UDP: bad parameter sets are refused with a reason and change nothing", "[ctl][udp]")
{
	Viewer v;
	REQUIRE(swell_link_open_udp(&v.l, "127.0.0.1", 0, nullptr, 0) == 0);
	const std::string host = "udp:" + std::to_string(swell_link_udp_port(v.l));
	const std::string dev = "udp:" + std::to_string(swell_link_udp_port(v.l) + 1);
	std::vector<std::string> args = {SWELL_CTL_BIN, "--device", dev, "--host", host, "--no-rt", "--quiet",
					 "--seconds", "30"};
	std::vector<char *> argv;
	for (auto &a : args)
		argv.push_back(&a[0]);
	argv.push_back(nullptr);
	pid_t pid;
	REQUIRE(posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) == 0);

	/* the controller is alive: its heartbeat reaches the viewer port */
	swell_msg hb = v.wait_for(SWELL_MSG_HEARTBEAT, 3000);
	REQUIRE(hb.type == SWELL_MSG_HEARTBEAT);
	CHECK(hb.u.heartbeat.version == SWELL_PROTO_VERSION);

	swell_msg before = v.param(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_E, 0);
	REQUIRE(before.type == SWELL_MSG_PARAM_ACK);

	struct {
		uint16_t id;
		int32_t value;
		swell_err why;
	} bad[] = {{SWELL_PARAM_WAVE_E, (int32_t)(0.6 * (1 << 30)), SWELL_EUNSTABLE},
		   {SWELL_PARAM_FORCE_MAX_UN, 0, SWELL_ERANGE},
		   {SWELL_PARAM_BODY_MASS_G, -1, SWELL_ERANGE},
		   {777, 1, SWELL_EUNKNOWN}};
	for (auto &b : bad) {
		swell_msg a = v.param(SWELL_MSG_PARAM_SET, b.id, b.value);
		INFO("param " << b.id << " = " << b.value);
		REQUIRE(a.type == SWELL_MSG_PARAM_NACK);
		CHECK(a.u.param_nack.id == b.id);
		CHECK(a.u.param_nack.err == b.why);
	}
	swell_msg after = v.param(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_E, 0);
	REQUIRE(after.type == SWELL_MSG_PARAM_ACK);
	CHECK(after.u.param_ack.value == before.u.param_ack.value);

	/* a good one takes effect and is read back */
	swell_msg ok = v.param(SWELL_MSG_PARAM_SET, SWELL_PARAM_WAVE_DAMPING, 1 << 20);
	REQUIRE(ok.type == SWELL_MSG_PARAM_ACK);
	CHECK(ok.u.param_ack.value == (1 << 20));
	swell_msg now = v.param(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_DAMPING, 0);
	CHECK(now.u.param_ack.value == (1 << 20));

	kill(pid, SIGTERM);
	int st = 0;
	waitpid(pid, &st, 0);
	CHECK(WIFEXITED(st));
	CHECK(WEXITSTATUS(st) == 0);
}
