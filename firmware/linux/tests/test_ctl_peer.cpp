/* swell-ctl's UDP links against other senders on the same machine: the device link holds its device
 * (the first sender of this node's DEVICE_POS, or the one configured) and drops every other sender's
 * datagrams, whatever they hold; a silent device faults the loop even while others send valid
 * packets; the host link serves a bounded table of clients beside the configured viewer address. */
#include "swell_msg_udp.hpp"
#include "swell_test.hpp"

#include <poll.h>
#include <time.h>

#include <atomic>
#include <cctype>
#include <cstring>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern "C" {
#include "swell/transport.h"
#include "swell/ctl.h"
#include "swell/proto.h"
}

namespace {

using Udp = swell_test::MsgUdp;
using swell_test::device_pos_msg;
using swell_test::param_msg;

/* swell-ctl with args, its standard output into out_path. */
pid_t spawn_ctl(std::vector<std::string> args, const std::string &out_path)
{
	args.insert(args.begin(), SWELL_CTL_BIN);
	return swell_test::spawn(args, out_path, "");
}

/* The whole number just before marker on the first line of text that holds both key and marker, or -1. */
long long number(const std::string &text, const std::string &key, const std::string &marker)
{
	std::istringstream in(text);
	std::string line;
	while (std::getline(in, line)) {
		const size_t k = line.find(key), m = k == std::string::npos ? k : line.find(marker, k);
		if (m == std::string::npos)
			continue;
		size_t b = m;
		while (b > 0 && line[b - 1] == ' ')
			b--;
		size_t e = b;
		while (b > 0 && isdigit((unsigned char)line[b - 1]))
			b--;
		return b < e ? std::stoll(line.substr(b, e - b)) : -1;
	}
	return -1;
}

/* Valid packets of every message type (random valid field values, this node) from a socket of its
 * own, until stopped; it counts what it sent and everything that came back to it. */
struct Flood {
	Udp sock;
	std::atomic<bool> run{true};
	std::atomic<long> sent{0}, received{0};
	std::set<unsigned> types;
	std::thread th;
	explicit Flood(uint16_t to)
	{
		th = std::thread([this, to] {
			std::mt19937_64 rng(15);
			unsigned t = 0;
			while (run) {
				for (int burst = 0; burst < 40; burst++) {
					const swell_msg_desc &d = swell_msg_descs[t++ % swell_msg_desc_count];
					swell_msg m{};
					m.type = d.type;
					for (unsigned i = 0; i < d.nfields; i++) {
						std::uniform_int_distribution<int64_t> pick(d.fields[i].min, d.fields[i].max);
						swell_msg_field_set(&m, &d.fields[i], pick(rng));
					}
					if (sock.send(to, &m, 1) == 0) {
						sent++;
						types.insert(d.type);
					}
				}
				received += sock.drain();
				const timespec pause{0, 500000};
				nanosleep(&pause, nullptr);
			}
			received += sock.drain();
		});
	}
	void stop()
	{
		run = false;
		if (th.joinable())
			th.join();
	}
	~Flood() { stop(); }
};

std::string tmp_path(const char *name) { return "/tmp/swell-ctl-peer-" + std::to_string(getpid()) + "-" + name; }

} // namespace

TEST_CASE("swell-ctl UDP device link: a flood of valid packets of every type and spoofed positions from "
	  "another sender take nothing and the device gets every command",
	  "[ctl][udp][peer]")
{
	const int samples = 1500;
	const int16_t dev_z = 10000; /* 100 mm: the object held above the water */
	Udp dev, host;
	const uint16_t ctl_port = swell_test::free_udp_port();
	const std::string out = tmp_path("flood.out");
	pid_t pid =
		spawn_ctl({"--device", "udp:" + std::to_string(ctl_port), "--host", "udp:" + std::to_string(host.port), "--clock",
			   "device", "--autorun", "--silent-ticks", "2500", "--no-rt", "--quiet", "--seconds", "120"},
			  out);

	/* one tick per sample: the first answer says the controller holds this socket as its device */
	std::vector<swell_msg> got;
	std::vector<int> force_seq;
	long dev_datagrams = 0;
	uint8_t seq = 0;
	auto take = [&](const std::vector<swell_msg> &v) {
		dev_datagrams++;
		int forces = 0;
		for (const swell_msg &m : v)
			if (m.type == SWELL_MSG_FORCE_CMD) {
				force_seq.push_back(m.u.force_cmd.seq);
				forces++;
			}
		return forces;
	};
	const uint64_t t0 = swell_link_now_ns();
	while (force_seq.empty() && swell_link_now_ns() - t0 < 10000000000u) {
		swell_msg p = device_pos_msg(seq++, dev_z);
		REQUIRE(dev.send(ctl_port, &p, 1) == 0);
		if (dev.recv(got, 50))
			take(got);
	}
	REQUIRE(!force_seq.empty());

	/* the poses the controller reports to the viewer from now on: all from the device's position */
	std::atomic<bool> watching{true};
	std::set<int> pose_z;
	std::thread viewer([&] {
		std::vector<swell_msg> v;
		while (watching)
			if (host.recv(v, 20))
				for (const swell_msg &m : v)
					if (m.type == SWELL_MSG_OBJECT_POSE)
						pose_z.insert(m.u.object_pose.z_10um);
	});
	host.drain();

	Flood flood(ctl_port);
	/* lockstep, at least `samples` samples and until the flood has sent 20 000 datagrams */
	int unanswered = 0, n_samples = 0;
	const uint64_t flood_until = swell_link_now_ns() + 30000000000u;
	for (; n_samples < samples || (flood.sent < 20000 && swell_link_now_ns() < flood_until); n_samples++) {
		swell_msg p = device_pos_msg(seq++, dev_z);
		REQUIRE(dev.send(ctl_port, &p, 1) == 0);
		int forces = 0;
		const uint64_t until = swell_link_now_ns() + 2000000000u;
		while (forces == 0 && swell_link_now_ns() < until)
			if (dev.recv(got, 50))
				forces += take(got);
		unanswered += forces == 0;
	}
	flood.stop();
	watching = false;
	viewer.join();
	const int status = swell_test::stop(pid);
	while (dev.recv(got, 100))
		take(got);
	const std::string report = swell_test::slurp(out);
	std::remove(out.c_str());

	int gaps = 0;
	for (size_t k = 1; k < force_seq.size(); k++)
		gaps += (uint8_t)(force_seq[k] - force_seq[k - 1]) != 1;
	const long long ctl_out = number(report, "device link", " out,");
	const long long dropped = number(report, "device peer", "datagrams of other senders");
	const long long taken = number(report, "device taken", " times, let go");
	INFO("flood: " << flood.sent << " valid datagrams of " << flood.types.size() << " types sent, " << flood.received
		       << " came back to the flooder; device: " << n_samples << " samples, " << unanswered << " unanswered, "
		       << force_seq.size() << " FORCE_CMD, " << gaps << " sequence gaps, " << dev_datagrams
		       << " datagrams (controller sent " << ctl_out << "); controller dropped " << dropped
		       << " datagrams of other senders, took a device " << taken << " times; " << pose_z.size()
		       << " distinct object z in the telemetry\n"
		       << report);
	CHECK(flood.types.size() == swell_msg_desc_count);
	CHECK(flood.sent >= 20000);
	CHECK(flood.received == 0);
	CHECK(unanswered == 0);
	CHECK(gaps == 0);
	CHECK(dev_datagrams == ctl_out);
	CHECK(taken == 1);
	CHECK(dropped > 0);
	CHECK(dropped <= flood.sent);
	CHECK(pose_z.size() == 1);
	CHECK(status == 0);
}

TEST_CASE("swell-ctl UDP device link: a device that falls silent faults the loop while another sender "
	  "floods valid positions, and its commands go to the device only",
	  "[ctl][udp][peer]")
{
	Udp dev, host;
	const uint16_t ctl_port = swell_test::free_udp_port();
	const std::string out = tmp_path("silent.out");
	pid_t pid = spawn_ctl({"--device", "udp:" + std::to_string(ctl_port) + ",peer=127.0.0.1:" + std::to_string(dev.port),
			       "--host", "udp:" + std::to_string(host.port), "--autorun", "--silent-ticks", "250", "--no-rt",
			       "--quiet", "--seconds", "120"},
			      out);

	/* the device: a sample every 400 us while talking; it reads every command all along */
	std::atomic<bool> talking{true}, alive{true};
	std::atomic<long> forces{0}, enabled_after{0}, nonzero_after{0};
	std::atomic<bool> counting_after{false};
	std::thread device([&] {
		std::vector<swell_msg> v;
		uint8_t seq = 0;
		while (alive) {
			if (talking) {
				swell_msg p = device_pos_msg(seq++, 10000);
				dev.send(ctl_port, &p, 1);
			}
			while (dev.recv(v, 0))
				for (const swell_msg &m : v)
					if (m.type == SWELL_MSG_FORCE_CMD) {
						forces++;
						if (counting_after) {
							enabled_after += m.u.force_cmd.enable != 0;
							nonzero_after += m.u.force_cmd.fz_cN != 0;
						}
					}
			const timespec pause{0, 400000};
			nanosleep(&pause, nullptr);
		}
	});
	auto state_within = [&](uint8_t want, int ms) {
		const uint64_t until = swell_link_now_ns() + (uint64_t)ms * 1000000u;
		while (swell_link_now_ns() < until) {
			swell_msg hb = host.wait_for(SWELL_MSG_HEARTBEAT, 200);
			if (hb.type == SWELL_MSG_HEARTBEAT && hb.u.heartbeat.state == want)
				return hb;
		}
		return swell_msg{};
	};
	const swell_msg running = state_within(SWELL_CTL_RUNNING, 10000);
	CHECK(running.type == SWELL_MSG_HEARTBEAT);

	Flood flood(ctl_port);
	const timespec beside{0, 300000000};
	nanosleep(&beside, nullptr);
	talking = false;
	const uint64_t silent_at = swell_link_now_ns();
	const swell_msg fault = state_within(SWELL_CTL_FAULT, 5000);
	const double fault_ms = (swell_link_now_ns() - silent_at) / 1e6;
	nanosleep(&beside, nullptr); /* let the last commands of RUNNING arrive */
	counting_after = true;
	host.drain();
	int running_after = 0;
	const uint64_t until = swell_link_now_ns() + 700000000u;
	std::vector<swell_msg> v;
	while (swell_link_now_ns() < until)
		if (host.recv(v, 20))
			for (const swell_msg &m : v)
				running_after += m.type == SWELL_MSG_HEARTBEAT && m.u.heartbeat.state == SWELL_CTL_RUNNING;
	flood.stop();
	const int status = swell_test::stop(pid);
	alive = false;
	device.join();
	const std::string report = swell_test::slurp(out);
	std::remove(out.c_str());

	INFO("flood: " << flood.sent << " valid datagrams sent, " << flood.received << " came back to the flooder; FAULT seen "
		       << fault_ms << " ms after the device fell silent; " << running_after
		       << " RUNNING heartbeats after it; device got " << forces << " FORCE_CMD, " << enabled_after
		       << " enabled and " << nonzero_after << " non-zero after the fault\n"
		       << report);
	REQUIRE(fault.type == SWELL_MSG_HEARTBEAT);
	CHECK(fault.u.heartbeat.err == SWELL_ETIMEOUT);
	CHECK(running_after == 0);
	CHECK(enabled_after == 0);
	CHECK(nonzero_after == 0);
	CHECK(forces > 0);
	CHECK(flood.sent > 1000);
	CHECK(flood.received == 0);
	CHECK(number(report, "device taken", " times, let go") == 0); /* configured: never learned */
	CHECK(number(report, "device peer", "datagrams of other senders") > 0);
	CHECK(status == 0);
}

TEST_CASE("swell-ctl UDP host link: four clients beside the viewer get telemetry and answers, a fifth is "
	  "refused (its PARAM_SET and ENTER_BOOTLOADER take no effect), a silent client gives its place up",
	  "[ctl][udp][host]")
{
	Udp viewer, client[5];
	const uint16_t ctl_port = swell_test::free_udp_port(), listen_port = swell_test::free_udp_port();
	const std::string out = tmp_path("clients.out");
	pid_t pid = spawn_ctl({"--device", "udp:" + std::to_string(ctl_port), "--host",
			       "udp:" + std::to_string(viewer.port) + ",listen=" + std::to_string(listen_port), "--no-rt",
			       "--quiet", "--seconds", "120"},
			      out);
	REQUIRE(viewer.wait_for(SWELL_MSG_HEARTBEAT, 5000).type == SWELL_MSG_HEARTBEAT);

	auto ask = [&](Udp &c, const swell_msg &m, int ms) {
		REQUIRE(c.send(listen_port, &m, 1) == 0);
		const uint64_t until = swell_link_now_ns() + (uint64_t)ms * 1000000u;
		std::vector<swell_msg> v;
		while (swell_link_now_ns() < until)
			if (c.recv(v, 20))
				for (const swell_msg &a : v)
					if ((a.type == SWELL_MSG_PARAM_ACK && a.u.param_ack.seq == m.u.param_get.seq) ||
					    (a.type == SWELL_MSG_PARAM_NACK && a.u.param_nack.seq == m.u.param_get.seq))
						return a;
		return swell_msg{};
	};
	for (int k = 0; k < 4; k++) {
		const swell_msg a = ask(client[k], param_msg(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_DAMPING, 0, (uint8_t)k), 2000);
		INFO("client " << k);
		CHECK(a.type == SWELL_MSG_PARAM_ACK);
	}
	const swell_msg before = ask(client[0], param_msg(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_DAMPING, 0, 10), 2000);
	REQUIRE(before.type == SWELL_MSG_PARAM_ACK);

	/* a fifth: refused, its requests take no effect */
	const swell_msg refused = ask(
		client[4], param_msg(SWELL_MSG_PARAM_SET, SWELL_PARAM_WAVE_DAMPING, before.u.param_ack.value + 1000, 11), 500);
	swell_msg boot{};
	boot.type = SWELL_MSG_ENTER_BOOTLOADER;
	boot.u.enter_bootloader.key = SWELL_PROTO_BOOT_KEY;
	REQUIRE(client[4].send(listen_port, &boot, 1) == 0);
	const swell_msg after = ask(client[0], param_msg(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_DAMPING, 0, 12), 2000);
	int st = 0;
	const pid_t exited = waitpid(pid, &st, WNOHANG);
	CHECK(refused.type == 0);
	REQUIRE(after.type == SWELL_MSG_PARAM_ACK);
	CHECK(after.u.param_ack.value == before.u.param_ack.value);
	CHECK(exited == 0);

	/* each admitted client gets the telemetry, as does the viewer that never spoke (heartbeats come at
	 * 10 Hz; the wait is 2.5 s, inside the 3 s a client may be silent: a loaded machine has held a
	 * process back for 0.9 s, and the heartbeat's coming is the point here, not its period) */
	for (int k = 0; k < 4; k++) {
		INFO("client " << k);
		CHECK(client[k].wait_for(SWELL_MSG_HEARTBEAT, 2500).type == SWELL_MSG_HEARTBEAT);
	}
	CHECK(viewer.wait_for(SWELL_MSG_HEARTBEAT, 2500).type == SWELL_MSG_HEARTBEAT);
	client[4].drain();
	CHECK(client[4].wait_for(SWELL_MSG_HEARTBEAT, 300).type == 0);

	/* client 3 falls silent; the others keep talking; after its silence the fifth is admitted */
	const uint64_t quiet_until = swell_link_now_ns() + (uint64_t)(SWELL_UDP_CLIENT_SILENT_MS + 700) * 1000000u;
	uint8_t s = 20;
	while (swell_link_now_ns() < quiet_until)
		for (int k = 0; k < 3; k++)
			CHECK(ask(client[k], param_msg(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_E, 0, s++), 2000).type ==
			      SWELL_MSG_PARAM_ACK);
	const swell_msg joined = ask(client[4], param_msg(SWELL_MSG_PARAM_GET, SWELL_PARAM_WAVE_E, 0, 99), 2000);
	CHECK(joined.type == SWELL_MSG_PARAM_ACK);
	client[3].drain();
	const int late = client[3].wait_for(SWELL_MSG_HEARTBEAT, 300).type;
	CHECK(late == 0);

	const int status = swell_test::stop(pid);
	const std::string report = swell_test::slurp(out);
	std::remove(out.c_str());
	INFO(report);
	CHECK(status == 0);
	CHECK(number(report, "host clients", " admitted") == 5);
	CHECK(number(report, "host clients", " dropped after") == 1);
	CHECK(number(report, "host clients", " packets of senders refused") >= 2);
}
