// swell-hm's side of the wire against a scripted controller in this test (no swell-ctl): what one
// tick sends, how a FORCE_CMD is applied, and what is refused. Deterministic: the script answers at
// once, so the device's motion is known to the last 0.01 mm.
#include "swell_test.hpp"

#include <poll.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

extern "C" {
#include "swell/proto.h"
}

namespace {

const std::string hm_bin = SWELL_HM_BIN;
const std::string work_dir = SWELL_HM_TEST_DIR;

/* Waits for swell-hm to end and closes the script's socket: its wait status in *st, what it wrote. */
std::string reap(pid_t pid, int fd, const std::string &out, int *st)
{
	waitpid(pid, st, 0);
	close(fd);
	return swell_test::slurp(out);
}

} // namespace

TEST_CASE("wire: a FORCE_CMD sequence jump beyond the window is one resync in the summary, a short gap is lost")
{
	std::string port;
	const int fd = swell_test::udp_loopback(&port);
	const std::string out = work_dir + "/resync.txt";
	const pid_t pid = swell_test::spawn({hm_bin, "--lockstep", "--port", port, "--seconds", "0.08", "--hand", "idle"}, out);
	// 200 ticks answered: seq n up to 99, then n + 100 (a controller that counts from elsewhere), and
	// 3 numbers skipped at 150
	int answered = 0;
	for (int n = 0; n < 200; n++) {
		pollfd p = {fd, POLLIN, 0};
		if (poll(&p, 1, 5000) <= 0)
			break;
		uint8_t buf[128];
		sockaddr_in from{};
		socklen_t fl = sizeof from;
		if (recvfrom(fd, buf, sizeof buf, 0, reinterpret_cast<sockaddr *>(&from), &fl) <= 0)
			break;
		swell_msg c{};
		c.type = SWELL_MSG_FORCE_CMD;
		c.u.force_cmd.enable = 1;
		c.u.force_cmd.seq = (uint8_t)(n < 100 ? n : n < 150 ? n + 100 : n + 103);
		uint8_t pkt[SWELL_PKT_MAX];
		size_t plen = 0, used = 0;
		REQUIRE(swell_pkt_encode(0, (uint8_t)n, &c, 1, pkt, sizeof pkt, &plen, &used) == SWELL_OK);
		sendto(fd, pkt, plen, 0, reinterpret_cast<sockaddr *>(&from), fl);
		answered++;
	}
	int st = 0;
	const std::string text = reap(pid, fd, out, &st);
	INFO("answered " << answered << "\n" << text);
	REQUIRE(WIFEXITED(st));
	CHECK(answered == 200);
	CHECK(text.find("\n  commands        200 received, 3 lost, 0 repeated, 0 bad frames") != std::string::npos);
	CHECK(text.find(" other messages ignored, 1 resyncs\n") != std::string::npos);
}

TEST_CASE("wire: a tick sends VEL, FORCE, POS with seq n mod 256, FORCE_CMD moves it exactly, bad frames and enable 0 do nothing")
{
	std::string port;
	const int fd = swell_test::udp_loopback(&port);
	const std::string out = work_dir + "/wire.txt", csv = work_dir + "/wire.csv";

	// 600 ticks; damping 0 so that a constant force gives x_n = a dt^2 n (n + 1) / 2 exactly
	std::vector<std::string> args = {hm_bin, "--lockstep", "--port", port,      "--seconds", "0.24", "--damping",
					 "0",    "--hand",     "idle",   "--quiet", "--log",     csv};
	const pid_t pid = swell_test::spawn(args, out);

	const double dt = 1.0 / 2500.0, acc = 1.0 / 2.0; // FORCE_CMD +1.00 N on the 2 kg default
	int samples = 0, wrong_layout = 0, wrong_seq = 0, wrong_status = 0, wrong_pos = 0, first_wrong = -1;
	std::string why;
	for (int n = 0; n < 600; n++) {
		pollfd p = {fd, POLLIN, 0};
		if (poll(&p, 1, 5000) <= 0)
			break;
		uint8_t buf[128];
		sockaddr_in from{};
		socklen_t fl = sizeof from;
		const ssize_t len = recvfrom(fd, buf, sizeof buf, 0, reinterpret_cast<sockaddr *>(&from), &fl);
		swell_msg m[SWELL_PKT_MSGS_MAX];
		size_t k = 0;
		uint8_t pseq = 0;
		REQUIRE(swell_pkt_decode(buf, (size_t)len, m, SWELL_PKT_MSGS_MAX, &k, &pseq, nullptr) == SWELL_OK);
		samples++;
		if (k != 3 || m[0].type != SWELL_MSG_DEVICE_VEL || m[1].type != SWELL_MSG_DEVICE_FORCE ||
		    m[2].type != SWELL_MSG_DEVICE_POS)
			wrong_layout++;
		const uint8_t seq = (uint8_t)n;
		if (pseq != seq || m[0].u.device_vel.seq != seq || m[1].u.device_force.seq != seq || m[2].u.device_pos.seq != seq)
			wrong_seq++;
		if (m[2].u.device_pos.status != 3) // powered, force output enabled
			wrong_status++;
		// the position after n ticks of +1 N (the answer to sample k acts from k to k + 1); tick 300
		// gets enable 0, so compare up to it
		if (n <= 300) {
			const double x = acc * dt * dt * n * (n + 1) / 2.0;
			const long want = std::lround(std::floor(x * 1e5 + 0.5));
			if (m[2].u.device_pos.z_10um != want || m[2].u.device_pos.x_10um != 0) {
				if (first_wrong < 0) {
					first_wrong = n;
					why = "z " + std::to_string(m[2].u.device_pos.z_10um) + " want " + std::to_string(want);
				}
				wrong_pos++;
			}
		}
		if (n >= 500)
			continue; // the controller goes silent
		swell_msg c{};
		c.type = SWELL_MSG_FORCE_CMD;
		c.u.force_cmd.fz_cN = n == 300 ? 500 : 100;
		c.u.force_cmd.enable = n == 300 ? 0 : 1;
		c.u.force_cmd.seq = seq;
		uint8_t pkt[SWELL_PKT_MAX];
		size_t plen = 0, used = 0;
		REQUIRE(swell_pkt_encode(0, seq, &c, 1, pkt, sizeof pkt, &plen, &used) == SWELL_OK);
		if (n == 200) { // first a copy with a broken CRC and a +50 N command: counted, never acted on
			uint8_t bad[SWELL_PKT_MAX];
			swell_msg big = c;
			big.u.force_cmd.fz_cN = 5000;
			size_t blen = 0;
			REQUIRE(swell_pkt_encode(0, seq, &big, 1, bad, sizeof bad, &blen, &used) == SWELL_OK);
			bad[blen - 1] ^= 0x5a;
			sendto(fd, bad, blen, 0, reinterpret_cast<sockaddr *>(&from), fl);
		}
		sendto(fd, pkt, plen, 0, reinterpret_cast<sockaddr *>(&from), fl);
	}
	int st = 0;
	const std::string text = reap(pid, fd, out, &st);
	INFO("samples " << samples << ", wrong layout " << wrong_layout << ", wrong seq " << wrong_seq << ", wrong status "
			<< wrong_status << ", wrong positions " << wrong_pos << " (first at tick " << first_wrong << ": " << why
			<< ")\n"
			<< text);
	REQUIRE(WIFEXITED(st));
	CHECK(WEXITSTATUS(st) == 0);
	CHECK(samples == 600);
	CHECK(wrong_layout == 0);
	CHECK(wrong_seq == 0);
	CHECK(wrong_status == 0);
	CHECK(wrong_pos == 0);
	CHECK(text.find("\n  commands        500 received, 0 lost, 0 repeated, 1 bad frames") != std::string::npos);

	// the log: tick 300 (enable 0) applied nothing; silent from 500: applied at 500, zero from 501
	std::ifstream f(csv);
	std::string line;
	std::getline(f, line);
	std::vector<std::vector<double>> rows;
	while (std::getline(f, line)) {
		std::vector<double> r;
		std::stringstream ls(line);
		std::string cell;
		while (std::getline(ls, cell, ','))
			r.push_back(std::stod(cell));
		rows.push_back(r);
	}
	REQUIRE(rows.size() == 600);
	const int fz = 9, applied = 15;
	CHECK(rows[299][fz] == 1.0);
	CHECK(rows[300][applied] == 0.0);
	CHECK(rows[300][fz] == 0.0);
	CHECK(rows[301][fz] == 1.0);
	CHECK(rows[200][fz] == 1.0); // not the 50 N of the broken frame
	CHECK(rows[499][applied] == 1.0);
	CHECK(rows[500][applied] == 1.0); // held one silent tick (watchdog 2)
	CHECK(rows[501][applied] == 0.0);
	CHECK(rows[599][applied] == 0.0);
}

TEST_CASE("wire: a controller that faulted is named in the summary (NOT A CLEAN RUN, FAULTED), and real time "
	  "without SCHED_FIFO says which watchdog it uses")
{
	std::string port;
	const int fd = swell_test::udp_loopback(&port);
	const std::string out = work_dir + "/faulted.txt";

	// real time (no --rt): 1.5 s, every sample answered; the heartbeats say RUNNING, then FAULT for a
	// while (samples 1000..1499), then RUNNING again
	std::vector<std::string> args = {hm_bin, "--port", port, "--seconds", "1.5", "--hand", "idle", "--quiet"};
	const pid_t pid = swell_test::spawn(args, out);

	int samples = 0;
	for (;;) {
		pollfd p = {fd, POLLIN, 0};
		if (poll(&p, 1, samples ? 500 : 3000) <= 0) /* swell-hm has ended */
			break;
		uint8_t buf[128];
		sockaddr_in from{};
		socklen_t fl = sizeof from;
		if (recvfrom(fd, buf, sizeof buf, 0, reinterpret_cast<sockaddr *>(&from), &fl) <= 0)
			break;
		swell_msg c[2]{};
		c[0].type = SWELL_MSG_FORCE_CMD;
		c[0].u.force_cmd.seq = (uint8_t)samples;
		c[1].type = SWELL_MSG_HEARTBEAT;
		c[1].u.heartbeat.version = SWELL_PROTO_VERSION;
		c[1].u.heartbeat.seq = (uint8_t)samples;
		c[1].u.heartbeat.state = samples >= 1000 && samples < 1500 ? 4 : 3;
		c[1].u.heartbeat.err = samples >= 1000 && samples < 1500 ? SWELL_ETIMEOUT : SWELL_OK;
		uint8_t pkt[SWELL_PKT_MAX];
		size_t plen = 0, used = 0;
		REQUIRE(swell_pkt_encode(0, (uint8_t)samples, c, 2, pkt, sizeof pkt, &plen, &used) == SWELL_OK);
		sendto(fd, pkt, plen, 0, reinterpret_cast<sockaddr *>(&from), fl);
		samples++;
	}
	int st = 0;
	const std::string text = reap(pid, fd, out, &st);
	INFO("samples answered " << samples << "\n" << text);
	REQUIRE(samples > 1500);
	CHECK(text.find("without real-time scheduling (no --rt): watchdog 50 ticks (20.0 ms) instead of 2") != std::string::npos);
	CHECK(text.find("FAULTED         the controller faulted 1 times (500 heartbeats in FAULT, last error: link "
			"silent)") != std::string::npos);
	CHECK(text.find("NOT A CLEAN RUN the controller faulted 1 times") != std::string::npos);
	REQUIRE(WIFEXITED(st));
	CHECK(WEXITSTATUS(st) == 0);
}
