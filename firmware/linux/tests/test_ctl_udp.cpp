/* swell-ctl as a process, over its UDP host link: parameter sets from a viewer are validated, refused
 * ones answered with a NACK and without effect, good ones acknowledged with the value in force. */
#include "swell_msg_udp.hpp"
#include "swell_test.hpp"

#include <cstring>

extern "C" {
#include "swell/ctl.h"
#include "swell/link.h"
}

namespace {

/* The viewer: telemetry comes in, requests go back to the controller's host link (its last sender). */
struct Viewer : swell_test::MsgUdp {
	swell_msg param(uint8_t type, uint16_t id, int32_t value)
	{
		const swell_msg m = swell_test::param_msg(type, id, value, seq);
		REQUIRE(send(0, &m) == 0);
		return wait_for(SWELL_MSG_PARAM_ACK, 2000, SWELL_MSG_PARAM_NACK); /* among telemetry */
	}
};

/* The device's UDP link on a free port (mine), sending to the controller's device port, the next one. */
swell_link *device_link(uint16_t &mine, uint16_t &ctl_port)
{
	swell_link *dev = nullptr;
	REQUIRE(swell_link_open_udp(&dev, "127.0.0.1", 0, "127.0.0.1", 0) == 0);
	mine = swell_link_udp_port(dev);
	swell_link_close(dev);
	dev = nullptr;
	ctl_port = (uint16_t)(mine + 1);
	REQUIRE(swell_link_open_udp(&dev, "127.0.0.1", mine, "127.0.0.1", ctl_port) == 0);
	return dev;
}

} // namespace

TEST_CASE("swell-ctl over UDP: bad parameter sets are refused with a reason and change nothing", "[ctl][udp]")
{
	Viewer v;
	const std::string host = "udp:" + std::to_string(v.port);
	const std::string dev = "udp:" + std::to_string(v.port + 1);
	std::vector<std::string> args = {SWELL_CTL_BIN, "--device", dev, "--host", host, "--no-rt", "--quiet", "--seconds", "30"};
	pid_t pid = swell_test::spawn(args);

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

	CHECK(swell_test::stop(pid) == 0);
}

TEST_CASE("swell-ctl --clock device: a silent device is ticked on every period, not every millisecond", "[ctl][udp]")
{
	const int tick_hz = 2500;
	uint16_t mine, ctl_port;
	swell_link *dev = device_link(mine, ctl_port);
	std::vector<std::string> args = {
		SWELL_CTL_BIN, "--device",  "udp:" + std::to_string(ctl_port), "--host",  "none",    "--clock",
		"device",      "--tick-hz", std::to_string(tick_hz),           "--no-rt", "--quiet", "--seconds",
		"30"};
	pid_t pid = swell_test::spawn(args);

	/* samples until the controller answers with forces (one tick per sample) */
	uint8_t seq = 0, pseq = 0;
	int answered = 0;
	for (int k = 0; k < 3000 && answered < 20; k++) {
		const swell_msg m = swell_test::device_pos_msg(seq++, 0);
		swell_frame f{};
		size_t used = 0;
		REQUIRE(swell_link_encode(SWELL_CARRIER_PKT, 0, pseq++, &m, 1, &f, &used) == SWELL_OK);
		swell_link_send(dev, &f);
		swell_frame in{};
		while (swell_link_recv(dev, &in, 1) == 0)
			answered++;
	}
	REQUIRE(answered >= 20);

	/* Then silence: after silent_ticks periods the loop ticks on its own, a FORCE_CMD each tick.
	 * Judged by the kernel's arrival times of those packets (SO_TIMESTAMPNS on loopback: when
	 * swell-ctl sent them), not by this test's own reading of them, so that a loaded machine which
	 * delays either process cannot make a false gap: the defect (a poll in whole milliseconds)
	 * never sends two ticks less than 1 ms apart, a period-long wait does so whenever the controller
	 * gets the CPU. The socket takes over the port the link used. */
	swell_link_close(dev);
	dev = nullptr;
	const int fd = socket(AF_INET, SOCK_DGRAM, 0);
	REQUIRE(fd >= 0);
	const int on = 1;
	REQUIRE(setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) == 0);
	sockaddr_in a{};
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	a.sin_port = htons(mine);
	REQUIRE(bind(fd, reinterpret_cast<sockaddr *>(&a), sizeof a) == 0);
	const timeval rcv_timeout{0, 20000};
	REQUIRE(setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &rcv_timeout, sizeof rcv_timeout) == 0);

	const uint64_t t_end = swell_link_now_ns() + 3000000000u, short_gap_ns = 900000u;
	int forces = 0, short_gaps = 0;
	uint64_t first_ns = 0, last_ns = 0;
	while (swell_link_now_ns() < t_end && short_gaps < 200) {
		swell_frame f{};
		iovec iov{f.data, sizeof f.data};
		alignas(cmsghdr) char ctrl[CMSG_SPACE(sizeof(timespec))];
		msghdr mh{};
		mh.msg_iov = &iov;
		mh.msg_iovlen = 1;
		mh.msg_control = ctrl;
		mh.msg_controllen = sizeof ctrl;
		const ssize_t r = recvmsg(fd, &mh, 0);
		if (r <= 0)
			continue;
		uint64_t at_ns = 0;
		for (cmsghdr *c = CMSG_FIRSTHDR(&mh); c; c = CMSG_NXTHDR(&mh, c))
			if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
				timespec ts;
				std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
				at_ns = (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
			}
		REQUIRE(at_ns != 0);
		f.len = (uint16_t)r;
		swell_msg m[SWELL_PKT_MSGS_MAX];
		size_t n = 0;
		if (swell_link_decode(SWELL_CARRIER_PKT, &f, m, SWELL_PKT_MSGS_MAX, &n, nullptr, nullptr) != SWELL_OK)
			continue;
		for (size_t k = 0; k < n; k++) {
			if (m[k].type != SWELL_MSG_FORCE_CMD)
				continue;
			if (forces++ == 0)
				first_ns = at_ns;
			else
				short_gaps += at_ns - last_ns < short_gap_ns;
			last_ns = at_ns;
		}
	}
	close(fd);
	const int rc = swell_test::stop(pid);
	const double rate = forces > 1 ? (forces - 1) / ((last_ns - first_ns) / 1e9) : 0.0;
	INFO("ticks of a silent device: " << forces << " FORCE_CMD, " << short_gaps
					  << " of them less than 0.9 ms after the one before, " << rate
					  << " a second on average (tick rate " << tick_hz << " Hz)");
	CHECK(short_gaps >= 100);
	CHECK(rate < 1.2 * tick_hz); /* never faster than the period */
	CHECK((rc >= 0 && rc < 128)); /* it exited, not killed */
}

TEST_CASE("swell-ctl without real-time scheduling says so and uses a 20 ms silence limit, and a run that "
	  "faulted says FAULTED in its report",
	  "[ctl][udp]")
{
	uint16_t mine, ctl_port;
	swell_link *dev = device_link(mine, ctl_port);
	const std::string base = "/tmp/swell-ctl-rt-" + std::to_string(getpid());
	std::vector<std::string> args = {
		SWELL_CTL_BIN, "--device", "udp:" + std::to_string(ctl_port), "--host", "none", "--autorun", "--no-rt", "--quiet",
		"--seconds",   "30"};
	pid_t pid = swell_test::spawn(args, base + ".out", base + ".err");

	/* the device talks until the loop runs (an enabled FORCE_CMD), then falls silent */
	uint8_t seq = 0, pseq = 0;
	bool running = false;
	const uint64_t until = swell_link_now_ns() + 10000000000u;
	while (!running && swell_link_now_ns() < until) {
		const swell_msg m = swell_test::device_pos_msg(seq++, 10000);
		swell_frame f{};
		size_t used = 0;
		REQUIRE(swell_link_encode(SWELL_CARRIER_PKT, 0, pseq++, &m, 1, &f, &used) == SWELL_OK);
		swell_link_send(dev, &f);
		swell_frame in{};
		swell_msg got[SWELL_PKT_MSGS_MAX];
		size_t n = 0;
		while (!running && swell_link_recv(dev, &in, 1) == 0)
			if (swell_link_decode(SWELL_CARRIER_PKT, &in, got, SWELL_PKT_MSGS_MAX, &n, nullptr, nullptr) == SWELL_OK)
				for (size_t k = 0; k < n; k++)
					running = running || (got[k].type == SWELL_MSG_FORCE_CMD && got[k].u.force_cmd.enable);
	}
	const timespec silence{0, 300000000}; /* 15 times the 20 ms limit */
	nanosleep(&silence, nullptr);
	swell_link_close(dev);
	const int rc = swell_test::stop(pid);
	const std::string out = swell_test::slurp(base + ".out"), err = swell_test::slurp(base + ".err");
	std::remove((base + ".out").c_str());
	std::remove((base + ".err").c_str());
	INFO("stderr:\n" << err << "stdout:\n" << out);
	CHECK(running);
	CHECK(err.find("no real-time scheduling (--no-rt): device silence limit 50 ticks (20.0 ms) instead of 2") !=
	      std::string::npos);
	CHECK(out.find("FAULTED         1 times in this run") != std::string::npos);
	CHECK(out.find("last error: link silent") != std::string::npos);
	CHECK(rc == 0);
}

TEST_CASE("swell-ctl: every bad argument and conflicting pair exits 2 with one line naming it, a link the "
	  "system refuses exits 1",
	  "[ctl][args]")
{
	struct {
		std::vector<std::string> args;
		int code;
		const char *says;
	} cases[] = {
		{{"--bogus"}, 2, "unknown option '--bogus' (see --help)"},
		{{"--bogus", "1"}, 2, "unknown option '--bogus' (see --help)"},
		{{"--tick-hz"}, 2, "--tick-hz needs a value (see --help)"},
		{{"stray"}, 2, "unexpected argument 'stray' (see --help)"},
		{{"--tick-hz", "abc"}, 2, "--tick-hz 'abc' is not a whole number"},
		{{"--tick-hz", "5"}, 2, "--tick-hz '5' is not a whole number in [10, 100000]"},
		{{"--solver-hz", "333"}, 2, "configuration refused"},
		{{"--silent-ticks", "0"}, 2, "--silent-ticks '0'"},
		{{"--silent-ticks", "-3"}, 2, "--silent-ticks '-3'"},
		{{"--node", "16"}, 2, "--node '16'"},
		{{"--host-budget", "0"}, 2, "--host-budget '0'"},
		{{"--clock", "wall"}, 2, "--clock 'wall' is not internal or device"},
		{{"--seconds", "-1"}, 2, "--seconds '-1' is not a number in (0, 10000000] s"},
		{{"--seconds", "nan"}, 2, "--seconds 'nan' is not a number"},
		{{"--fw-version", "1.2"}, 2, "--fw-version must be X.Y.Z"},
		{{"--device", "tcp:1"},
		 2,
		 "device link: 'tcp:1': not a link: udp[:PORT], can:IFACE, usb:FFS_DIR, hm:HOST[:PORT]"},
		{{"--device", "udp:99999"}, 2, "device link: 'udp:99999': UDP port not in 1..65535"},
		{{"--device", "udp:47990,peer=x"}, 2, "is not peer=ADDR:PORT"},
		{{"--device", "udp:47990,listen=47991"}, 2, "is not peer=ADDR:PORT"},
		{{"--device", "can:"}, 2, "device link: 'can:': give the CAN interface"},
		{{"--device", "usb:"}, 2, "device link: 'usb:': give the FunctionFS mount"},
		{{"--device", "udp:47990", "--host", "udp:47991,listen=1.2.3.4.5:1"}, 2, "host link: 'udp:47991,listen="},
		{{"--device", "udp:47990", "--host", "udp:47990"}, 2, "the telemetry would go to the device link's own port"},
		{{"--device", "udp:47801", "--host", "udp"}, 2, "the telemetry would go to the device link's own port"},
		{{"--device", "usb:/x", "--host", "usb:/x"}, 2, "are one FunctionFS mount (usb:/x)"},
		{{"--device", "usb:/nonexistent-ffs", "--host", "none"}, 1, "FunctionFS open failed: No such file or directory"},
		/* no such interface; on a machine without CAN the socket is refused first */
		{{"--device", "can:nosuchcan0", "--host", "none"}, 1, "can:nosuchcan0: "},
	};
	for (auto &c : cases) {
		std::vector<std::string> args = {SWELL_CTL_BIN, "--no-rt"};
		args.insert(args.end(), c.args.begin(), c.args.end());
		const swell_test::Run r = swell_test::run(args);
		const std::string &out = r.out, &err = r.err;
		/* the start-up line about real time is not an error line: count the others */
		size_t errors = 0, at = 0;
		while ((at = err.find("swell-ctl: ", at)) != std::string::npos) {
			errors += err.compare(at, 30, "swell-ctl: no real-time schedu") != 0;
			at++;
		}
		std::string joined;
		for (auto &a : c.args)
			joined += a + " ";
		INFO(joined << "-> exit " << r.code << ", stderr '" << err << "', stdout '" << out << "'");
		CHECK(r.code >= 0);
		CHECK(r.code == c.code);
		CHECK(err.find(c.says) != std::string::npos);
		CHECK(errors == 1);
		CHECK(out.empty());
	}
}
