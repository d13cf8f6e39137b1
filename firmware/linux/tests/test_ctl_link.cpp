/* swell-ctl's links: the CAN read path over a stand-in socket (a SOCK_SEQPACKET pair carries struct
 * can_frame records as a raw CAN socket does; the build machines have no CAN), the held USB answer,
 * the UDP peers and clients. The CAN bus state itself is the link library's (test_links.cpp there). */
#include <catch2/catch.hpp>

#include "swell_msgs.hpp"

#include "swell_msg_udp.hpp"
#include "swell_test.hpp"

#include <linux/can.h>
#include <netinet/in.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

extern "C" {
#include "ctl_link.h"
#include "link_priv.h"
}

namespace {

using swell_test::err_frame;

struct can_frame device_pos(uint8_t node, uint8_t seq)
{
	struct swell_msg m = swell_test::device_pos_msg(seq, -3940);
	struct can_frame f;
	uint32_t id = 0;
	uint8_t len = 0;

	memset(&f, 0, sizeof(f));
	m.node = node;
	REQUIRE(swell_can_encode(&m, &id, f.data, &len) == SWELL_OK);
	f.can_id = id;
	f.can_dlc = len;
	return f;
}

swell_msg zero_force()
{
	swell_msg m{};
	m.type = SWELL_MSG_FORCE_CMD;
	return m;
}

/* A CAN link whose socket is one end of a SEQPACKET pair; the test writes frames into the other. */
struct FakeCan {
	int sv[2] = {-1, -1};
	struct ctl_link l;
	FakeCan()
	{
		REQUIRE(socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0, sv) == 0);
		memset(&l, 0, sizeof(l));
		l.kind = CTL_LINK_CAN;
		l.fd = sv[0];
		l.node = 0;
		snprintf(l.name, sizeof(l.name), "can:fake");
	}
	~FakeCan()
	{
		close(sv[0]);
		close(sv[1]);
	}
	// fills the TX side, the stand-in for a queue that the bus does not drain: the frames queued
	int fill()
	{
		const struct can_frame f = device_pos(0, 1);
		int queued = 0;

		while (write(sv[0], &f, sizeof(f)) == (ssize_t)sizeof(f))
			queued++;
		REQUIRE(errno == EAGAIN);
		return queued;
	}
	size_t put(const struct can_frame &f)
	{
		struct swell_msg m[4];

		REQUIRE(write(sv[1], &f, sizeof(f)) == (ssize_t)sizeof(f));
		return ctl_link_recv(&l, m, 4);
	}
};

/* A stand-in for the library's FunctionFS link: every send refused with the code the test sets (-EBUSY:
 * every IN slot in flight, or the host going away before DISABLE; -ENODEV: unplugged). */
struct FakeUsb {
	struct swell_link base;
	int refuse = -EBUSY;
	static int send(struct swell_link *l, const struct swell_frame *) { return reinterpret_cast<FakeUsb *>(l)->refuse; }
	static int recv(struct swell_link *, struct swell_frame *, int) { return -ETIMEDOUT; }
	static void close(struct swell_link *) {}
	FakeUsb()
	{
		static const struct swell_link_ops ops = {send, recv, close, nullptr};
		memset(&base, 0, sizeof(base));
		base.ops = &ops;
	}
};

} // namespace

TEST_CASE("CAN link: data frames are taken, error frames are not messages, nothing is taken while bus-off", "[ctl_link]")
{
	FakeCan c;

	CHECK(c.put(device_pos(0, 1)) == 1);
	CHECK(c.put(device_pos(5, 2)) == 0); /* another node's sample */
	CHECK(c.l.foreign == 1);
	CHECK(c.put(err_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_RX_PASSIVE, 0, 130)) == 0);
	CHECK(c.l.can.state == SWELL_CAN_PASSIVE);
	CHECK(c.put(device_pos(0, 3)) == 1); /* error-passive still takes part in the bus */
	CHECK(c.put(err_frame(CAN_ERR_BUSOFF)) == 0);
	CHECK(c.l.can.bus_offs == 1);
	CHECK(c.put(device_pos(0, 4)) == 0);
	CHECK(c.put(device_pos(0, 5)) == 0);
	CHECK(c.l.can.dropped_off == 2);
	CHECK(c.put(err_frame(CAN_ERR_RESTARTED)) == 0);
	CHECK(c.l.can.state == SWELL_CAN_ACTIVE);
	CHECK(c.put(device_pos(0, 6)) == 1);
	INFO("bad frames " << swell_proto_rejected_total(&c.l.st) << ", error frames " << c.l.can.error_frames);
	CHECK(swell_proto_rejected_total(&c.l.st) == 0); /* error frames are not counted as bad frames */
	CHECK(c.l.can.error_frames == 3);
	CHECK(c.l.frames_rx == 9);
}

TEST_CASE("USB link: an answer that finds the IN queue busy is held and kept in order, telemetry is dropped, "
	  "an unplug drops the held answer",
	  "[ctl_link]")
{
	struct ctl_link l;
	struct swell_msg ack, quad;
	FakeUsb usb; /* every write is refused, the link is up: a busy IN queue */

	memset(&l, 0, sizeof(l));
	l.kind = CTL_LINK_USB;
	l.fd = -1;
	l.usb = &usb.base;
	memset(&ack, 0, sizeof(ack));
	ack.type = SWELL_MSG_PARAM_NACK;
	ack.u.param_nack.id = 999;
	ack.u.param_nack.err = SWELL_EUNKNOWN;
	memset(&quad, 0, sizeof(quad));
	quad.type = SWELL_MSG_HEIGHT_QUAD;

	ctl_link_send(&l, &quad, 1);
	CHECK(l.tx_errors == 1);
	CHECK(l.held.len == 0);
	ctl_link_send(&l, &ack, 1);
	CHECK(l.held.len > 0);
	CHECK(l.answers_held == 1);
	CHECK(l.tx_errors == 1);
	const uint16_t held = l.held.len;
	uint8_t first[SWELL_PKT_MAX];
	memcpy(first, l.held.data, held);
	ctl_link_send(&l, &quad, 1); /* cannot overtake the held answer */
	ctl_link_send(&l, &ack, 1); /* a second answer while one is held: dropped, counted */
	INFO("tx errors " << l.tx_errors << ", answers held " << l.answers_held << ", dropped " << l.answers_dropped);
	CHECK(l.tx_errors == 3);
	CHECK(l.answers_dropped == 1);
	CHECK(l.held.len == held);
	CHECK(memcmp(l.held.data, first, held) == 0);
	usb.refuse = -ENODEV; /* unplugged: the host asks again after the replug */
	ctl_link_send(&l, &quad, 1);
	CHECK(l.held.len == 0);
	CHECK(l.answers_dropped == 2);
	CHECK(l.frames_tx == 0);
}

TEST_CASE("CAN link: the zero force on exit waits for room in a full TX queue, a tick's force is dropped", "[ctl_link]")
{
	FakeCan c;
	const int queued = c.fill();
	swell_msg zero = zero_force();
	zero.u.force_cmd.seq = 77;
	ctl_link_send(&c.l, &zero, 1); /* a tick's send: refused, counted, gone */
	CHECK(c.l.tx_errors == 1);
	CHECK(c.l.frames_tx == 0);

	/* the bus takes the queued frames 20 ms later */
	std::vector<struct can_frame> out;
	std::thread bus([&] {
		std::this_thread::sleep_for(std::chrono::milliseconds(20));
		struct can_frame f;
		while (read(c.sv[1], &f, sizeof(f)) == (ssize_t)sizeof(f))
			out.push_back(f);
	});
	const int rc = ctl_link_send_wait(&c.l, &zero, 1, 500);
	bus.join();
	struct can_frame f;
	while (read(c.sv[1], &f, sizeof(f)) == (ssize_t)sizeof(f))
		out.push_back(f);
	INFO("frames queued before " << queued << ", frames out " << out.size() << ", tx errors " << c.l.tx_errors);
	CHECK(rc == 0);
	CHECK(c.l.tx_errors == 1); /* the tick's drop only: the waits are not errors */
	CHECK(c.l.frames_tx == 1);
	REQUIRE(out.size() == (size_t)queued + 1);
	struct swell_msg got;
	struct swell_proto_stats st;
	memset(&st, 0, sizeof(st));
	REQUIRE(swell_can_decode(out.back().can_id, out.back().data, out.back().can_dlc, &got, &st) == SWELL_OK);
	CHECK(got.type == SWELL_MSG_FORCE_CMD);
	CHECK(got.u.force_cmd.seq == 77);
	CHECK(got.u.force_cmd.fz_cN == 0);
}

TEST_CASE("CAN link: the zero force on exit gives up after its wait when the queue never drains", "[ctl_link]")
{
	FakeCan c;
	c.fill();
	swell_msg zero = zero_force();
	const auto t0 = std::chrono::steady_clock::now();
	const int rc = ctl_link_send_wait(&c.l, &zero, 1, 30);
	const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0).count();
	INFO("gave up after " << ms << " ms");
	CHECK(rc == -1);
	CHECK(c.l.tx_errors == 1);
	CHECK(ms >= 30);
	CHECK(ms < 1000);
}

TEST_CASE("UDP link: an open that fails (port taken) leaves no socket open and names the reason", "[ctl_link]")
{
	int taken = socket(AF_INET, SOCK_DGRAM, 0);
	struct sockaddr_in a;
	socklen_t al = sizeof(a);

	REQUIRE(taken >= 0);
	memset(&a, 0, sizeof(a));
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	REQUIRE(bind(taken, (struct sockaddr *)&a, sizeof(a)) == 0);
	REQUIRE(getsockname(taken, (struct sockaddr *)&a, &al) == 0);
	const std::string spec = "udp:" + std::to_string(ntohs(a.sin_port));
	struct ctl_link l;
	char err[160] = "";
	const int before = swell_test::open_fds();
	CHECK(ctl_link_open(&l, spec.c_str(), 1, 0, err, sizeof(err)) == -1);
	const int after = swell_test::open_fds();
	INFO("open files before " << before << ", after " << after << "; reason: " << err);
	CHECK(after == before);
	CHECK(l.fd == -1);
	CHECK(std::string(err).find("Address already in use") != std::string::npos);
	close(taken);
}

TEST_CASE("UDP host link: clients on 127.0.0.1:47802 unless given, a second controller takes any free port, a "
	  "port spelled out is never swapped",
	  "[ctl_link]")
{
	struct ctl_link a, b, c;
	char err[160] = "";

	REQUIRE(ctl_link_open(&a, "udp:47990", 0, 0, err, sizeof(err)) == 0);
	INFO("first: clients on port " << ntohs(a.local.sin_port) << ", default taken " << a.clients_port_taken);
	CHECK(a.local.sin_addr.s_addr == htonl(INADDR_LOOPBACK));
	/* another process may hold 47802 while this runs: then the first falls back too */
	CHECK((ntohs(a.local.sin_port) == SWELL_UDP_PORT_CLIENTS) == !a.clients_port_taken);
	REQUIRE(ctl_link_open(&b, "udp:47991", 0, 0, err, sizeof(err)) == 0);
	CHECK(b.clients_port_taken == 1);
	CHECK(ntohs(b.local.sin_port) != SWELL_UDP_PORT_CLIENTS);
	CHECK(ntohs(b.local.sin_port) != 0);
	const std::string spelled = "udp:47992,listen=" + std::to_string(ntohs(b.local.sin_port));
	CHECK(ctl_link_open(&c, spelled.c_str(), 0, 0, err, sizeof(err)) == -1);
	CHECK(std::string(err).find("Address already in use") != std::string::npos);
	CHECK(c.fd == -1);
	REQUIRE(ctl_link_open(&c, "udp:47992,listen=0", 0, 0, err, sizeof(err)) == 0);
	CHECK(c.clients_port_taken == 0);
	CHECK(ntohs(c.local.sin_port) != 0);
	ctl_link_close(&c);
	ctl_link_close(&b);
	ctl_link_close(&a);
}

/* ---- UDP: who the device is, who the clients are ---- */

namespace {

/* A UDP end on loopback that sends a message with every field valid (at its minimum) to a link. */
struct UdpEnd : swell_test::MsgUdp {
	void send(const struct ctl_link &to, uint8_t type)
	{
		const struct swell_msg_desc *d = swell_msg_desc_find(type);
		struct swell_msg m;

		REQUIRE(d != nullptr);
		memset(&m, 0, sizeof(m));
		m.type = type;
		for (unsigned k = 0; k < d->nfields; k++)
			REQUIRE(swell_msg_field_set(&m, &d->fields[k], d->fields[k].min) == SWELL_OK);
		REQUIRE(MsgUdp::send(ntohs(to.local.sin_port), &m) == 0);
	}
	/* datagrams waiting, read */
	int got()
	{
		std::this_thread::sleep_for(std::chrono::milliseconds(5));
		return drain();
	}
};

size_t take(struct ctl_link &l)
{
	struct swell_msg m[SWELL_PKT_MSGS_MAX];

	std::this_thread::sleep_for(std::chrono::milliseconds(5));
	return ctl_link_recv(&l, m, SWELL_PKT_MSGS_MAX);
}

void force_cmd(struct ctl_link &l)
{
	struct swell_msg m;

	memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_FORCE_CMD;
	ctl_link_send(&l, &m, 1);
}

} // namespace

TEST_CASE("UDP host link: a client's HEARTBEAT admits it and keeps it and is not handed on, its requests are", "[ctl_link]")
{
	struct ctl_link l;
	char err[160] = "";
	UdpEnd tool;

	REQUIRE(ctl_link_open(&l, "udp:47994,listen=0", 0, 0, err, sizeof(err)) == 0);
	tool.send(l, SWELL_MSG_HEARTBEAT);
	CHECK(take(l) == 0u); /* the keep-alive: nothing for the core */
	CHECK(swell_peers_clients(&l.peers) == 1u);
	CHECK(l.peers.clients_admitted == 1u);
	force_cmd(l); /* telemetry of any kind goes to the client now */
	CHECK(tool.got() == 1);
	tool.send(l, SWELL_MSG_PARAM_GET);
	CHECK(take(l) == 1u);
	CHECK(l.peers.clients_admitted == 1u); /* the same client */
	ctl_link_close(&l);
}

TEST_CASE("UDP device link: the first sender of DEVICE_POS is the device, held against every other sender "
	  "until it is let go, and it keeps the commands",
	  "[ctl_link]")
{
	struct ctl_link l;
	char err[160] = "";
	UdpEnd dev, other;

	REQUIRE(ctl_link_open(&l, "udp:0", 1, 0, err, sizeof(err)) == -2); /* port 0 is not a device port */
	{
		/* a free port, then the link on it */
		UdpEnd probe;
		const std::string spec = "udp:" + std::to_string(probe.port);
		close(probe.fd);
		probe.fd = -1;
		REQUIRE(ctl_link_open(&l, spec.c_str(), 1, 0, err, sizeof(err)) == 0);
	}
	other.send(l, SWELL_MSG_HEARTBEAT); /* valid, but not a position: takes nothing */
	CHECK(take(l) == 0);
	CHECK(l.peers.have_peer == 0);
	dev.send(l, SWELL_MSG_DEVICE_POS);
	CHECK(take(l) == 1);
	CHECK(l.peers.peers_taken == 1);
	/* every type from another sender, positions too: dropped unread */
	for (unsigned t = 0; t < swell_msg_desc_count; t++)
		other.send(l, swell_msg_descs[t].type);
	for (unsigned t = 0; t < swell_msg_desc_count; t++)
		CHECK(take(l) == 0);
	dev.send(l, SWELL_MSG_DEVICE_VEL);
	CHECK(take(l) == 1);
	force_cmd(l);
	INFO("other senders' datagrams " << l.peers.others);
	CHECK(l.peers.others == swell_msg_desc_count + 1);
	CHECK(dev.got() == 1);
	CHECK(other.got() == 0);

	/* let go (declared lost): the old device still gets the zero force; the next DEVICE_POS takes it */
	CHECK(swell_peers_release(&l.peers) == 1);
	CHECK(swell_peers_release(&l.peers) == 0);
	force_cmd(l);
	CHECK(dev.got() == 1);
	other.send(l, SWELL_MSG_DEVICE_POS);
	CHECK(take(l) == 1);
	CHECK(l.peers.peers_taken == 2);
	force_cmd(l);
	CHECK(other.got() == 1);
	CHECK(dev.got() == 0);
	dev.send(l, SWELL_MSG_DEVICE_POS);
	CHECK(take(l) == 0);
	ctl_link_close(&l);
}

TEST_CASE("UDP device link: a configured device is never let go, others are refused from the start, bad "
	  "options are refused with the reason",
	  "[ctl_link]")
{
	struct ctl_link l;
	char err[160] = "";
	UdpEnd dev, other;
	const char *bad[] = {"udp:47800,peer=",
			     "udp:47800,peer=1.2.3:5",
			     "udp:47800,peer=127.0.0.1:0",
			     "udp:47800,listen=5",
			     "udp:,peer=127.0.0.1:5",
			     "udp:47800,peer=127.0.0.1:70000",
			     "udp:abc"};

	for (const char *b : bad) {
		INFO(b);
		CHECK(ctl_link_open(&l, b, 1, 0, err, sizeof(err)) == -2); /* a malformed spec, not a system failure */
		CHECK(std::string(err).find(b) != std::string::npos);
		CHECK(l.fd == -1);
	}
	/* a free port, then the link on it with the device's address (loopback when only the port is given) */
	UdpEnd probe;
	const std::string good = "udp:" + std::to_string(probe.port) + ",peer=" + std::to_string(dev.port);
	close(probe.fd);
	probe.fd = -1;
	REQUIRE(ctl_link_open(&l, good.c_str(), 1, 0, err, sizeof(err)) == 0);
	other.send(l, SWELL_MSG_DEVICE_POS);
	CHECK(take(l) == 0);
	force_cmd(l);
	CHECK(dev.got() == 1);
	CHECK(other.got() == 0);
	CHECK(swell_peers_release(&l.peers) == 0);
	other.send(l, SWELL_MSG_DEVICE_POS);
	CHECK(take(l) == 0);
	dev.send(l, SWELL_MSG_DEVICE_POS);
	CHECK(take(l) == 1);
	CHECK(l.peers.others == 2);
	CHECK(l.peers.peers_taken == 0);
	ctl_link_close(&l);
}

TEST_CASE("links count the sends in a row in which nothing reached the carrier", "[ctl_link]")
{
	FakeCan c;
	c.fill();
	swell_msg zero = zero_force();
	for (int k = 0; k < 5; k++)
		ctl_link_send(&c.l, &zero, 1);
	CHECK(c.l.unsent_run == 5);
	struct can_frame f;
	while (read(c.sv[1], &f, sizeof(f)) == (ssize_t)sizeof(f))
		;
	ctl_link_send(&c.l, &zero, 1);
	CHECK(c.l.unsent_run == 0);
}
