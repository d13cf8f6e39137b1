/* swell-tool check against the real programs on loopback (swell-ctl, and swell-hm serving the
 * HapticMaster's TCP interface or speaking swell's device protocol): all pass on a good chain, and each
 * fault it names is found, on its own line, with exit 7. */
#include <catch2/catch.hpp>

#include "swell_test.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

using swell_test::free_udp_port;
using swell_test::slurp;
using swell_test::spawn;

bool has(const std::string &s, const std::string &what) { return s.find(what) != std::string::npos; }

struct Result {
	int status;
	std::string out;
};

/* a free TCP port on loopback (bound, then released) */
int free_tcp_port()
{
	int port = 0;
	const int fd = swell_test::loopback_socket(SOCK_STREAM, &port);
	close(fd);
	return port;
}

/* a client of the HapticMaster's TCP interface (8-byte header, big-endian length), kept open */
struct HmConn {
	int fd = -1;
	explicit HmConn(int port)
	{
		fd = socket(AF_INET, SOCK_STREAM, 0);
		sockaddr_in a{};
		a.sin_family = AF_INET;
		a.sin_port = htons((uint16_t)port);
		a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
		REQUIRE(connect(fd, (sockaddr *)&a, sizeof a) == 0);
		timeval tv = {2, 0};
		setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
	}
	~HmConn()
	{
		if (fd >= 0)
			close(fd);
	}
	std::string ask(const std::string &text) const
	{
		const uint32_t n = (uint32_t)text.size();
		std::string f = {char(n >> 24), char(n >> 16), char(n >> 8), char(n), 0, 0, 0, 0};
		f += text;
		REQUIRE(send(fd, f.data(), f.size(), 0) == (ssize_t)f.size());
		std::string got;
		char b[2048];
		while (got.size() < 8 || got.size() < 8 + ((size_t)(uint8_t)got[2] << 8 | (uint8_t)got[3])) {
			const ssize_t r = recv(fd, b, sizeof b, 0);
			if (r <= 0)
				break;
			got.append(b, (size_t)r);
		}
		return got.size() > 8 ? got.substr(8) : "";
	}
};

/* swell-hm (serving the HapticMaster interface unless udp) and swell-ctl on it, on free ports */
struct Chain {
	int hm_port = free_tcp_port(), host_port = free_udp_port(), client_port = free_udp_port(), dev_port = free_udp_port();
	pid_t ctl = -1, hm = -1;
	std::string dir;
	Chain(const std::string &name, const std::vector<std::string> &hm_more, const std::vector<std::string> &ctl_more,
	      bool udp = false, bool with_hm = true)
	{
		dir = std::string(SWELL_TOOL_TEST_DIR) + "/check-" + name;
		REQUIRE(system(("mkdir -p '" + dir + "'").c_str()) == 0);
		if (with_hm) {
			std::vector<std::string> h = {SWELL_HM_BIN, "--quiet", "--seconds", "60"};
			if (udp)
				h.insert(h.end(), {"--port", std::to_string(dev_port)});
			else
				h.insert(h.end(), {"--serve", "127.0.0.1:" + std::to_string(hm_port)});
			h.insert(h.end(), hm_more.begin(), hm_more.end());
			hm = spawn(h, dir + "/hm.log");
			std::this_thread::sleep_for(std::chrono::milliseconds(300));
		}
		std::vector<std::string> c = {SWELL_CTL_BIN,
					      "--device",
					      udp ? "udp:" + std::to_string(dev_port) : "hm:127.0.0.1:" + std::to_string(hm_port),
					      "--host",
					      "udp:" + std::to_string(host_port) + ",listen=" + std::to_string(client_port),
					      "--no-rt",
					      "--quiet",
					      "--silent-ticks",
					      "2500",
					      "--seconds",
					      "60"};
		c.insert(c.end(), ctl_more.begin(), ctl_more.end());
		ctl = spawn(c, dir + "/ctl.log");
	}
	~Chain()
	{
		swell_test::stop(hm, SIGTERM, 3000);
		swell_test::stop(ctl, SIGTERM, 3000);
	}
	Result tool(const std::string &args)
	{
		const std::string out = dir + "/tool.out";
		const std::string cmd = std::string(SWELL_TOOL_BIN) + " --link udp:" + std::to_string(client_port) +
			" --timeout-ms 2000 " + args + " >'" + out + "' 2>&1";
		const int st = system(cmd.c_str());
		Result r{WIFEXITED(st) ? WEXITSTATUS(st) : -1, slurp(out)};
		UNSCOPED_INFO("swell-tool " << args << " -> exit " << r.status << ":\n" << r.out);
		return r;
	}
	std::string hm_spec() const { return "127.0.0.1:" + std::to_string(hm_port); }
	/* until the controller reports a state in want (the two start slowly on a loaded machine) */
	void wait_state(const std::string &want)
	{
		for (int k = 0; k < 40; k++) {
			if (has(tool("status").out, "state " + want))
				return;
			std::this_thread::sleep_for(std::chrono::milliseconds(250));
		}
		FAIL("the controller never reached state " << want << "\n" << slurp(dir + "/ctl.log"));
	}
};

/* the line of check named name */
std::string line_of(const std::string &out, const std::string &name)
{
	size_t at = 0;
	while ((at = out.find(name, at)) != std::string::npos) {
		const size_t start = out.rfind('\n', at) == std::string::npos ? 0 : out.rfind('\n', at) + 1;
		if (at - start == 6) /* "ok    NAME", "FAIL  NAME", "skip  NAME" */
			return out.substr(start, out.find('\n', at) - start);
		at++;
	}
	return "";
}

} // namespace

TEST_CASE("swell-tool check: a good chain (swell-ctl on swell-hm --serve, first-run limits) passes every line, exit 0",
	  "[tool][check]")
{
	Chain c("good", {}, {});
	c.wait_state("armed");
	const Result r = c.tool("check --hm " + c.hm_spec());
	CHECK(r.status == 0);
	for (const char *name :
	     {"link", "controller", "device", "round trip", "frame", "force", "calibration", "e-stop", "effects"})
		CHECK(line_of(r.out, name).rfind("ok", 0) == 0);
	// the rate heard is wall clock (a loaded machine hears fewer samples); its ok is the check's own
	// bound, checked above: here that the line names the rate it heard, the tick rate and the status
	CHECK(has(line_of(r.out, "device"), " Hz (tick 2500 Hz), status 0x3 (powered, force on)"));
	CHECK(has(line_of(r.out, "force"), "force.max 2 N, force.rate 20 N/s"));
	CHECK(has(r.out, "check: 9 passed, 0 failed, 0 skipped"));
	// without --hm the device's own answers are skipped, not failed
	const Result q = c.tool("check");
	CHECK(q.status == 0);
	CHECK(line_of(q.out, "effects").rfind("skip", 0) == 0);
	CHECK(line_of(q.out, "e-stop").rfind("ok", 0) == 0);
}

TEST_CASE("swell-tool check: no controller on the link: FAIL link, the rest skipped, exit 7", "[tool][check]")
{
	Chain c("nolink", {}, {}, false, false);
	swell_test::stop(c.ctl, SIGTERM, 3000);
	c.ctl = -1;
	const Result r = c.tool("--timeout-ms 600 check");
	CHECK(r.status == 7);
	CHECK(line_of(r.out, "link").rfind("FAIL", 0) == 0);
	CHECK(has(line_of(r.out, "link"), "fix: start swell-ctl"));
	CHECK(has(r.out, "check: 0 passed, 1 failed, 7 skipped"));
}

TEST_CASE("swell-tool check: a device that never answers: FAIL device (not heard), exit 7", "[tool][check]")
{
	Chain c("nodevice", {}, {}, true, false);
	c.wait_state("idle");
	const Result r = c.tool("check");
	CHECK(r.status == 7);
	CHECK(line_of(r.out, "device").rfind("FAIL", 0) == 0);
	CHECK(has(line_of(r.out, "device"), "not heard (state idle)"));
	CHECK(line_of(r.out, "controller").rfind("ok", 0) == 0);
}

TEST_CASE("swell-tool check: a device heard at a fifth of the tick rate: FAIL device with both rates", "[tool][check]")
{
	Chain c("slow", {"--rate", "500"}, {}, true); /* a fifth of the ticks, in stream mode */
	c.wait_state("armed");
	const Result r = c.tool("check");
	CHECK(r.status == 7);
	const std::string d = line_of(r.out, "device");
	CHECK(d.rfind("FAIL", 0) == 0);
	CHECK(has(d, "the controller ticks at 2500 Hz"));
}

TEST_CASE("swell-tool check: the device's e-stop pushed: no start-up, FAIL e-stop with --hm and without", "[tool][check]")
{
	Chain c("estop", {"--estop", "0,1000"}, {});
	c.wait_state("armed"); /* heard (its answers carry positions), never started */
	const Result r = c.tool("check --hm " + c.hm_spec());
	CHECK(r.status == 7);
	CHECK(line_of(r.out, "e-stop").rfind("FAIL", 0) == 0);
	CHECK(has(line_of(r.out, "e-stop"), "emergency button is pushed"));
	const Result q = c.tool("check");
	CHECK(q.status == 7);
	CHECK(line_of(q.out, "e-stop").rfind("FAIL", 0) == 0);
	CHECK(has(slurp(c.dir + "/ctl.log"), "start-up stopped before any force: the device's e-stop is pushed"));
}

TEST_CASE("swell-tool check: a device that stays uncalibrated after init: FAIL calibration and device", "[tool][check]")
{
	Chain c("uncal", {"--uncalibrated"}, {});
	c.wait_state("armed");
	const Result r = c.tool("check --hm " + c.hm_spec());
	CHECK(r.status == 7);
	CHECK(line_of(r.out, "calibration").rfind("FAIL", 0) == 0);
	CHECK(line_of(r.out, "device").rfind("FAIL", 0) == 0);
	CHECK(has(slurp(c.dir + "/ctl.log"), "position is not calibrated"));
}

TEST_CASE("swell-tool check: the handle outside the pool's footprint: FAIL frame with where it is", "[tool][check]")
{
	/* 250 mm along x from the pool's centre (a workspace of +-300 mm): pool x 450 of 400 */
	Chain c("frame", {"--limit", "300", "--start", "250,0,0"}, {});
	c.wait_state("armed");
	const Result r = c.tool("check");
	CHECK(r.status == 7);
	const std::string f = line_of(r.out, "frame");
	CHECK(f.rfind("FAIL", 0) == 0);
	CHECK(has(f, "pool x 450.0"));
}

TEST_CASE("swell-tool check: force limits above the first-run ones fail unless accepted on purpose", "[tool][check]")
{
	Chain c("force", {}, {"--full-force"});
	c.wait_state("armed");
	const Result r = c.tool("check");
	CHECK(r.status == 7);
	CHECK(line_of(r.out, "force").rfind("FAIL", 0) == 0);
	CHECK(has(line_of(r.out, "force"), "force.max 10 N, force.rate 500 N/s"));
	const Result q = c.tool("check --max-force 10 --max-rate 500");
	CHECK(q.status == 0);
	CHECK(line_of(q.out, "force").rfind("ok", 0) == 0);
}

TEST_CASE("swell-tool check: springs of swell's left enabled on the device while the force law is off: FAIL effects",
	  "[tool][check]")
{
	/* the emulator's own watchdog off: a silent client keeps its effects, as a device may */
	Chain c("effects", {"--bias-watchdog", "0"}, {});
	c.wait_state("armed");
	{
		/* what an effect-mode run that lost its controller leaves: the springs on (its client still
		 * connected: the emulator drops a closed client's effects) */
		HmConn left(c.hm_port);
		REQUIRE(left.ask("create spring swell_pull;set swell_pull enable") ==
			"Effect spring with name swell_pull created;Effect swell_pull enabled");
		const Result r = c.tool("check --hm " + c.hm_spec());
		CHECK(r.status == 7);
		const std::string e = line_of(r.out, "effects");
		CHECK(e.rfind("FAIL", 0) == 0);
		CHECK(has(e, "swell_pull"));
		CHECK(left.ask("remove swell_pull") == "Removed effect swell_pull");
	}
	CHECK(c.tool("check --hm " + c.hm_spec()).status == 0);
}

TEST_CASE("swell-tool check: a round trip above the bound fails, and the controller in fault fails with its last error",
	  "[tool][check]")
{
	Chain c("rtt", {}, {"--autorun"});
	c.wait_state("running");
	const Result r = c.tool("check --max-rtt-ms 0.001");
	CHECK(r.status == 7);
	CHECK(line_of(r.out, "round trip").rfind("FAIL", 0) == 0);
	/* the device goes away while running: the controller faults (link lost) */
	swell_test::stop(c.hm, SIGKILL, 3000);
	c.hm = -1;
	c.wait_state("fault");
	const Result q = c.tool("check");
	CHECK(q.status == 7);
	const std::string l = line_of(q.out, "controller");
	CHECK(l.rfind("FAIL", 0) == 0);
	CHECK(has(l, "state fault"));
	CHECK(has(l, "swell-tool clear"));
}
