#include <catch2/catch.hpp>

#include "swell_msgs.hpp"

#include <arpa/inet.h>
#include <linux/can/error.h>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <netinet/in.h>
#include <string>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>
#include <vector>

extern "C" {
#include "swell/link.h"
#include "swell/link_peers.h"
#include "swell/transport.h"
}

namespace {

struct link_ptr {
	swell_link *l = nullptr;
	~link_ptr() { swell_link_close(l); }
};

swell_msg msg_of(unsigned ti, int salt)
{
	const swell_msg_desc &d = swell_msg_descs[ti % swell_msg_desc_count];
	swell_msg m;
	std::memset(&m, 0, sizeof(m));
	m.type = d.type;
	for (unsigned i = 0; i < d.nfields; i++) {
		const swell_field_desc &f = d.fields[i];
		int64_t span = f.max - f.min;
		int64_t v = span ? f.min + (int64_t(ti) * 7919 + salt * 104729 + i * 31) % (span + 1) : f.min;
		REQUIRE(swell_msg_field_set(&m, &f, v) == SWELL_OK);
	}
	return m;
}

std::string tmp_path(const char *stem)
{
	char buf[256];
	std::snprintf(buf, sizeof(buf), "%s/swell-%s-%d.rec", P_tmpdir, stem, int(getpid()));
	return buf;
}

void open_pair(link_ptr &a, link_ptr &b)
{
	REQUIRE(swell_link_open_udp(&b.l, SWELL_UDP_HOST, 0, nullptr, 0) == 0);
	REQUIRE(swell_link_udp_port(b.l) != 0);
	REQUIRE(swell_link_open_udp(&a.l, SWELL_UDP_HOST, 0, SWELL_UDP_HOST, swell_link_udp_port(b.l)) == 0);
}

} // namespace

TEST_CASE("UDP links on loopback carry every message both ways and count frames and bytes", "[links]")
{
	link_ptr a, b;
	open_pair(a, b);
	CHECK(swell_link_carrier(a.l) == SWELL_CARRIER_PKT);
	CHECK(swell_link_can_health(a.l) == nullptr); /* a bus state is a CAN link's only */
	uint64_t bytes = 0;
	for (unsigned t = 0; t < swell_msg_desc_count; t++) {
		swell_link *from = (t % 2) ? b.l : a.l, *to = (t % 2) ? a.l : b.l;
		swell_msg m[2] = {msg_of(t, 1), msg_of(t + 3, 2)};
		swell_frame f, in;
		size_t used = 0, n = 0;
		uint8_t seq = 0;
		REQUIRE(swell_link_encode(SWELL_CARRIER_PKT, 4, uint8_t(t), m, 2, &f, &used) == SWELL_OK);
		REQUIRE(used == 2);
		/* b learns a's address from the first datagram, so a speaks first */
		REQUIRE(swell_link_send(from, &f) == 0);
		REQUIRE(swell_link_recv(to, &in, 1000) == 0);
		bytes += f.len;
		CHECK(in.len == f.len);
		CHECK(std::memcmp(in.data, f.data, f.len) == 0);
		swell_msg got[SWELL_PKT_MSGS_MAX];
		REQUIRE(swell_link_decode(SWELL_CARRIER_PKT, &in, got, SWELL_PKT_MSGS_MAX, &n, &seq, nullptr) == SWELL_OK);
		REQUIRE(n == 2);
		CHECK(seq == uint8_t(t));
		m[0].node = m[1].node = 4;
		CHECK(swell_msg_equal(&got[0], &m[0]));
		CHECK(swell_msg_equal(&got[1], &m[1]));
	}
	const struct swell_link_counters *ca = swell_link_get_counters(a.l), *cb = swell_link_get_counters(b.l);
	CHECK(ca->tx_frames + cb->tx_frames == swell_msg_desc_count);
	CHECK(ca->rx_frames + cb->rx_frames == swell_msg_desc_count);
	CHECK(ca->tx_bytes + cb->tx_bytes == bytes);
	CHECK(ca->rx_bytes + cb->rx_bytes == bytes);
	CHECK(ca->rx_errors + cb->rx_errors == 0u);
}

TEST_CASE("a UDP receive with nothing to read times out and counts it, and oversized datagrams are dropped", "[links]")
{
	link_ptr a, b;
	open_pair(a, b);
	swell_frame in;
	auto t0 = std::chrono::steady_clock::now();
	CHECK(swell_link_recv(b.l, &in, 50) == -ETIMEDOUT);
	double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
	INFO("waited " << ms << " ms for a 50 ms timeout");
	CHECK(ms >= 45.0);
	CHECK(swell_link_get_counters(b.l)->rx_timeouts == 1u);

	/* a 100-byte datagram is no swell packet: dropped, counted, and the next one is delivered */
	int s = socket(AF_INET, SOCK_DGRAM, 0);
	REQUIRE(s >= 0);
	sockaddr_in to{};
	to.sin_family = AF_INET;
	to.sin_port = htons(swell_link_udp_port(b.l));
	inet_pton(AF_INET, SWELL_UDP_HOST, &to.sin_addr);
	std::vector<uint8_t> big(100, 0x57);
	REQUIRE(sendto(s, big.data(), big.size(), 0, reinterpret_cast<sockaddr *>(&to), sizeof(to)) == 100);
	REQUIRE(sendto(s, big.data(), 10, 0, reinterpret_cast<sockaddr *>(&to), sizeof(to)) == 10);
	close(s);
	REQUIRE(swell_link_recv(b.l, &in, 1000) == 0);
	CHECK(in.len == 10u);
	CHECK(swell_link_get_counters(b.l)->rx_dropped == 1u);
	/* and the 10 bytes are rejected by the decoder with a counted reason */
	swell_msg got[SWELL_PKT_MSGS_MAX];
	size_t n;
	swell_proto_stats st = {};
	CHECK(swell_link_decode(SWELL_CARRIER_PKT, &in, got, SWELL_PKT_MSGS_MAX, &n, nullptr, &st) == SWELL_ECRC);
	CHECK(st.rejected[SWELL_ECRC] == 1u);
}

TEST_CASE("a UDP link with a fixed peer hears only that peer: a third sender's datagram is dropped and counted", "[links]")
{
	link_ptr a, b, c;
	open_pair(a, b); /* a's peer is b */
	REQUIRE(swell_link_open_udp(&c.l, SWELL_UDP_HOST, 0, SWELL_UDP_HOST, swell_link_udp_port(a.l)) == 0);
	swell_msg m = msg_of(0, 1);
	swell_frame f, in;
	size_t used = 0;
	REQUIRE(swell_link_encode(SWELL_CARRIER_PKT, 1, 0, &m, 1, &f, &used) == SWELL_OK);
	REQUIRE(swell_link_send(c.l, &f) == 0); /* the stranger first */
	REQUIRE(swell_link_send(b.l, &f) == -ENOTCONN); /* b answers the last sender: none yet */
	REQUIRE(swell_link_send(a.l, &f) == 0);
	REQUIRE(swell_link_recv(b.l, &in, 1000) == 0);
	REQUIRE(swell_link_send(b.l, &f) == 0);
	REQUIRE(swell_link_recv(a.l, &in, 1000) == 0);
	CHECK(swell_link_get_counters(a.l)->rx_dropped == 1u);
	CHECK(swell_link_recv(a.l, &in, 50) == -ETIMEDOUT);
}

TEST_CASE("a recording replays the same frames and times, as fast as possible or at recorded speed", "[links]")
{
	const std::string path = tmp_path("rec");
	std::vector<swell_frame> sent;
	uint64_t span_ns = 0;
	{
		link_ptr a, b, rec;
		open_pair(a, b);
		REQUIRE(swell_link_open_record(&rec.l, b.l, path.c_str()) == 0);
		b.l = nullptr; /* owned by the recorder now */
		for (unsigned i = 0; i < 40; i++) {
			swell_msg m = msg_of(i, 5);
			swell_frame f, in;
			size_t used;
			REQUIRE(swell_link_encode(SWELL_CARRIER_PKT, 0, uint8_t(i), &m, 1, &f, &used) == SWELL_OK);
			REQUIRE(swell_link_send(a.l, &f) == 0);
			REQUIRE(swell_link_recv(rec.l, &in, 1000) == 0);
			sent.push_back(in);
			std::this_thread::sleep_for(std::chrono::milliseconds(i % 4 == 0 ? 5 : 1));
		}
	}
	std::vector<uint64_t> times;
	{
		link_ptr r;
		REQUIRE(swell_link_open_replay(&r.l, path.c_str(), 0) == 0);
		CHECK(swell_link_carrier(r.l) == SWELL_CARRIER_PKT);
		swell_frame f;
		CHECK(swell_link_send(r.l, &sent[0]) == -EROFS);
		for (size_t i = 0; i < sent.size(); i++) {
			INFO("frame " << i);
			REQUIRE(swell_link_recv(r.l, &f, 0) == 0);
			CHECK(f.len == sent[i].len);
			CHECK(std::memcmp(f.data, sent[i].data, f.len) == 0);
			times.push_back(f.t_ns);
			if (i)
				CHECK(f.t_ns - times[i - 1] == sent[i].t_ns - sent[i - 1].t_ns);
		}
		CHECK(swell_link_recv(r.l, &f, 0) == -ENODATA);
		span_ns = times.back() - times.front();
	}
	{
		link_ptr r;
		auto t0 = std::chrono::steady_clock::now();
		REQUIRE(swell_link_open_replay(&r.l, path.c_str(), 1) == 0);
		swell_frame f;
		REQUIRE(swell_link_recv(r.l, &f, -1) == 0);
		size_t k = 1;
		while (swell_link_recv(r.l, &f, -1) == 0)
			k++;
		CHECK(k == sent.size());
		// From before the open: the replay's clock starts there (frame k is due at open + t_k), so
		// a process descheduled between the open and its first look at the clock would otherwise
		// see the span shortened.
		double took = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
		INFO("recorded span " << span_ns / 1e6 << " ms, replay took " << took / 1e6 << " ms");
		CHECK(took >= 0.95 * double(span_ns));
	}
	std::remove(path.c_str());
}

TEST_CASE("replay refuses a file that is not a recording and reports a truncated one", "[links]")
{
	const std::string path = tmp_path("bad");
	FILE *f = std::fopen(path.c_str(), "wb");
	REQUIRE(f);
	std::fputs("not a swell recording at all", f);
	std::fclose(f);
	swell_link *l = nullptr;
	CHECK(swell_link_open_replay(&l, path.c_str(), 0) == -EPROTO);
	CHECK(l == nullptr);
	CHECK(swell_link_open_replay(&l, "/nonexistent/swell.rec", 0) == -ENOENT);

	/* a valid header and half a record */
	const uint8_t hdr[16] = {'S', 'W', 'E', 'L', 'L', 'R', 'E', 'C', 1, 0, 0, 0, SWELL_CARRIER_CAN, 0, 0, 0};
	const uint8_t rec[10] = {0, 0, 0, 0, 0, 0, 0, 0, 0x10, 0};
	f = std::fopen(path.c_str(), "wb");
	REQUIRE(f);
	std::fwrite(hdr, 1, sizeof(hdr), f);
	std::fwrite(rec, 1, sizeof(rec), f);
	std::fclose(f);
	REQUIRE(swell_link_open_replay(&l, path.c_str(), 0) == 0);
	CHECK(swell_link_carrier(l) == SWELL_CARRIER_CAN);
	swell_frame fr;
	CHECK(swell_link_recv(l, &fr, 0) == -EIO);
	CHECK(swell_link_get_counters(l)->rx_errors == 1u);
	swell_link_close(l);
	std::remove(path.c_str());
}

TEST_CASE("SocketCAN and libusb links fail cleanly with an errno where there is no such device", "[links]")
{
	swell_link *l = nullptr;
	swell_can_opts co{};
	int rc = swell_link_open_can(&l, "swellnone0", &co);
	INFO("open_can: " << std::strerror(-rc));
	CHECK(rc < 0);
	CHECK(l == nullptr);
	CHECK(swell_link_open_can(&l, "an-interface-name-far-too-long", &co) == -EINVAL);

	swell_usb_opts uo;
	swell_usb_opts_default(&uo);
	CHECK(uo.vid == 0x1209u);
	CHECK(uo.pid == 0x0001u);
	CHECK(uo.ep_out == 0x01u);
	CHECK(uo.ep_in == 0x81u);
	uo.pid = 0xFFFE; /* no such device anywhere */
	rc = swell_link_open_usb(&l, &uo);
	INFO("open_usb: " << std::strerror(-rc));
	CHECK(rc < 0);
	CHECK(l == nullptr);
}

TEST_CASE("link framing: CAN takes one message, CAN FD one type, packets a mix", "[links]")
{
	std::vector<swell_msg> m;
	for (unsigned k = 0; k < 8; k++)
		m.push_back(msg_of(0, int(k))); /* eight FORCE_CMDs */
	m.push_back(msg_of(1, 0));
	swell_frame f;
	size_t used = 0;
	REQUIRE(swell_link_encode(SWELL_CARRIER_CAN, 0, 0, m.data(), m.size(), &f, &used) == SWELL_OK);
	CHECK(used == 1u);
	CHECK(f.len == 8u);
	REQUIRE(swell_link_encode(SWELL_CARRIER_CANFD, 0, 0, m.data(), m.size(), &f, &used) == SWELL_OK);
	CHECK(used == 8u);
	CHECK(f.len == 64u);
	CHECK((f.flags & SWELL_FRAME_FD) != 0);
	REQUIRE(swell_link_encode(SWELL_CARRIER_PKT, 0, 0, m.data(), m.size(), &f, &used) == SWELL_OK);
	CHECK(used == 6u); /* 5 + 6 x 9 + 4 = 63 bytes */
	CHECK(f.len == 63u);
	/* a 29-bit frame is never taken for a swell frame */
	swell_frame e = {};
	e.id = SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0);
	e.flags = SWELL_FRAME_EFF;
	e.len = 8;
	swell_msg got[SWELL_CANFD_MSGS_MAX];
	size_t n;
	CHECK(swell_link_decode(SWELL_CARRIER_CAN, &e, got, SWELL_CANFD_MSGS_MAX, &n, nullptr, nullptr) == SWELL_EUNKNOWN);
}

TEST_CASE("recording a replay keeps the recorded times: the copy replays as the original", "[links]")
{
	const std::string orig = tmp_path("orig"), copy = tmp_path("copy");
	const uint64_t t_ns[3] = {0, 5000000, 12000000};
	{
		const uint8_t hdr[16] = {'S', 'W', 'E', 'L', 'L', 'R', 'E', 'C', 1, 0, 0, 0, SWELL_CARRIER_CAN, 0, 0, 0};
		FILE *f = std::fopen(orig.c_str(), "wb");
		REQUIRE(f);
		std::fwrite(hdr, 1, sizeof(hdr), f);
		for (int k = 0; k < 3; k++) {
			uint8_t rec[16 + 2] = {0};
			for (int b = 0; b < 8; b++)
				rec[b] = uint8_t(t_ns[k] >> (8 * b));
			rec[8] = uint8_t(0x100 + k); /* CAN id */
			rec[9] = 0x01;
			rec[12] = 2; /* two data bytes */
			rec[16] = uint8_t(k);
			rec[17] = 0xA5;
			std::fwrite(rec, 1, sizeof(rec), f);
		}
		std::fclose(f);
	}
	{
		link_ptr replay, rec;
		REQUIRE(swell_link_open_replay(&replay.l, orig.c_str(), 0) == 0);
		REQUIRE(swell_link_open_record(&rec.l, replay.l, copy.c_str()) == 0);
		replay.l = nullptr; /* owned by the recorder now */
		swell_frame f;
		for (int k = 0; k < 3; k++)
			REQUIRE(swell_link_recv(rec.l, &f, 0) == 0);
		CHECK(swell_link_recv(rec.l, &f, 0) == -ENODATA);
	}
	link_ptr r;
	REQUIRE(swell_link_open_replay(&r.l, copy.c_str(), 0) == 0);
	CHECK(swell_link_carrier(r.l) == SWELL_CARRIER_CAN);
	for (int k = 0; k < 3; k++) {
		swell_frame f;
		REQUIRE(swell_link_recv(r.l, &f, 0) == 0);
		INFO("frame " << k << ": time " << f.t_ns << " ns, recorded " << t_ns[k] << " ns");
		CHECK(f.t_ns == t_ns[k]);
		CHECK(f.id == uint32_t(0x100 + k));
		CHECK(f.len == 2);
		CHECK(f.data[0] == k);
		CHECK(f.data[1] == 0xA5);
	}
	std::remove(orig.c_str());
	std::remove(copy.c_str());
}

/* ---- the CAN bus state kept from the driver's error frames (swell-ctl's CAN links) ---- */

namespace {

using swell_test::err_frame;

swell_can_event feed(swell_can_health *h, const can_frame &f) { return swell_can_error_frame(h, f.can_id, f.data); }

} // namespace

TEST_CASE("CAN error frames: warning and passive are counted, bus-off holds until a restart", "[links]")
{
	struct swell_can_health h;
	memset(&h, 0, sizeof(h));

	CHECK(feed(&h, err_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_TX_WARNING, 96, 0)) == SWELL_CAN_EV_STATE);
	CHECK(h.state == SWELL_CAN_WARNING);
	CHECK(h.tx_err == 96);
	CHECK(feed(&h, err_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_TX_PASSIVE, 128, 3)) == SWELL_CAN_EV_STATE);
	CHECK(h.state == SWELL_CAN_PASSIVE);
	CHECK(h.tx_err == 128);
	CHECK(h.rx_err == 3);
	CHECK(feed(&h, err_frame(CAN_ERR_ACK)) == SWELL_CAN_EV_NONE); /* no ACK: counted, state unchanged */
	CHECK(h.no_ack == 1);
	CHECK(feed(&h, err_frame(CAN_ERR_BUSOFF)) == SWELL_CAN_EV_BUS_OFF);
	CHECK(h.state == SWELL_CAN_BUS_OFF);
	/* a counter report while off the bus does not bring it back */
	CHECK(feed(&h, err_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING)) == SWELL_CAN_EV_NONE);
	CHECK(h.state == SWELL_CAN_BUS_OFF);
	CHECK(feed(&h, err_frame(CAN_ERR_RESTARTED)) == SWELL_CAN_EV_RESTARTED);
	CHECK(h.state == SWELL_CAN_ACTIVE);
	CHECK(h.tx_err == 0); /* the kernel's restart frame carries no counters: a restart clears them */
	CHECK(feed(&h, err_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE)) == SWELL_CAN_EV_NONE); /* already active */
	INFO("frames " << h.error_frames << ", warnings " << h.warnings << ", passives " << h.passives << ", bus-offs "
		       << h.bus_offs << ", restarts " << h.restarts);
	CHECK(h.error_frames == 7);
	CHECK(h.warnings == 1);
	CHECK(h.passives == 1);
	CHECK(h.bus_offs == 1);
	CHECK(h.restarts == 1);
	CHECK(h.actives == 1);
}

TEST_CASE("CAN error frames: bus-off wins over a restart in the same frame, a data frame is refused", "[links]")
{
	struct swell_can_health h, before;
	memset(&h, 0, sizeof(h));

	CHECK(feed(&h, err_frame(CAN_ERR_RESTARTED | CAN_ERR_BUSOFF)) == SWELL_CAN_EV_BUS_OFF);
	CHECK(h.state == SWELL_CAN_BUS_OFF);
	/* recovered to error-active (some drivers say so instead of RESTARTED) also leaves bus-off */
	CHECK(feed(&h, err_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE)) == SWELL_CAN_EV_RESTARTED);
	CHECK(h.state == SWELL_CAN_ACTIVE);
	before = h;
	const uint8_t d[8] = {0};
	CHECK(swell_can_error_frame(&h, 0x123, d) == SWELL_CAN_EV_NONE);
	CHECK(swell_can_error_frame(&h, CAN_ERR_FLAG | CAN_ERR_BUSOFF, nullptr) == SWELL_CAN_EV_NONE);
	CHECK(swell_can_error_frame(nullptr, CAN_ERR_FLAG | CAN_ERR_BUSOFF, d) == SWELL_CAN_EV_NONE);
	CHECK(memcmp(&h, &before, sizeof(h)) == 0);
}

TEST_CASE("CAN read (the CAN link's and swell-ctl's) gives a data frame's size, classic or FD, and refuses another "
	  "size",
	  "[links]")
{
	int sv[2];
	REQUIRE(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv) == 0);
	swell_can_health h{};
	canfd_frame f{}, fd{};
	can_frame data{};
	data.can_id = 0x123;
	fd.can_id = 0x124;
	fd.len = 12;
	REQUIRE(write(sv[0], &data, CAN_MTU) == ssize_t(CAN_MTU));
	REQUIRE(write(sv[0], &fd, CANFD_MTU) == ssize_t(CANFD_MTU));
	REQUIRE(write(sv[0], "short", 5) == 5);
	CHECK(swell_can_read(sv[1], &h, &f) == int(CAN_MTU));
	CHECK(swell_can_read(sv[1], &h, &f) == int(CANFD_MTU));
	CHECK(f.len == 12);
	errno = 0;
	CHECK(swell_can_read(sv[1], &h, &f) == -1);
	CHECK(errno == EIO);
	close(sv[0]);
	close(sv[1]);
}

TEST_CASE("CAN health: the interface going down counts once a spell, whether a write or a read hears of it, and "
	  "ends a bus-off",
	  "[links]")
{
	swell_can_health h{};
	h.state = SWELL_CAN_BUS_OFF;
	h.tx_err = 255;
	swell_can_io_result(&h, -ENETDOWN); // a write took the kernel's report
	CHECK(h.downs == 1);
	CHECK(h.state == SWELL_CAN_ACTIVE);
	CHECK(h.restarts == 1);
	CHECK(h.tx_err == 0);
	swell_can_io_result(&h, -ENETDOWN); // every write while it stays down: the same down
	swell_can_io_result(&h, -ENOBUFS);
	swell_can_io_result(&h, -EAGAIN);
	CHECK(h.downs == 1);
	CHECK(h.restarts == 1);
	swell_can_io_result(&h, 0); // a frame went through: up again
	swell_can_io_result(&h, -ENETDOWN);
	CHECK(h.downs == 2);
	CHECK(h.restarts == 1); // not bus-off this time: no restart

	// a read that hears of it: the same count
	int sv[2];
	REQUIRE(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv) == 0);
	swell_can_health r{};
	canfd_frame f{};
	can_frame data{};
	REQUIRE(write(sv[0], &data, CAN_MTU) == ssize_t(CAN_MTU));
	CHECK(swell_can_read(sv[1], &r, &f) == int(CAN_MTU));
	CHECK(r.downs == 0);
	close(sv[0]);
	close(sv[1]);
}

TEST_CASE("CAN link names its states", "[links]")
{
	CHECK(std::string(swell_can_state_name(SWELL_CAN_ACTIVE)) == "error-active");
	CHECK(std::string(swell_can_state_name(SWELL_CAN_PASSIVE)) == "error-passive");
	CHECK(std::string(swell_can_state_name(SWELL_CAN_BUS_OFF)) == "bus-off");
}

/* ---- the peer rules of a served UDP socket (swell/link_peers.h), on made-up addresses and times ---- */

namespace {

sockaddr_in loopback_at(uint16_t port)
{
	sockaddr_in a{};
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	a.sin_port = htons(port);
	return a;
}

} // namespace

TEST_CASE("peers: four clients beside the viewer, a fifth refused until one is silent for 3 s, a client's "
	  "HEARTBEAT taken",
	  "[links]")
{
	const sockaddr_in viewer = loopback_at(47801);
	const int64_t s = 1000000000;
	swell_peers p;
	swell_msg m[2] = {};
	sockaddr_in to[1 + SWELL_PEERS_CLIENTS];

	swell_peers_init(&p, 0, &viewer);
	m[0].type = SWELL_MSG_HEARTBEAT;
	m[1].type = SWELL_MSG_PARAM_GET;
	CHECK(swell_peers_take(&p, &viewer, m, 2, s) == 2); /* the viewer's HEARTBEAT is handed on */
	for (uint16_t k = 0; k < SWELL_PEERS_CLIENTS; k++) {
		const sockaddr_in c = loopback_at((uint16_t)(50000 + k));
		CHECK(swell_peers_take(&p, &c, m, 1, s + k) == 0); /* admitted by its keep-alive, which is taken */
	}
	const sockaddr_in fifth = loopback_at(50009);
	CHECK(swell_peers_take(&p, &fifth, m, 2, 2 * s) == 0);
	CHECK(p.clients_refused == 1);
	CHECK(swell_peers_dests(&p, to) == 1 + SWELL_PEERS_CLIENTS);
	const sockaddr_in first = loopback_at(50000);
	CHECK(swell_peers_take(&p, &first, m, 2, 3 * s) == 1); /* keeps its slot: the PARAM_GET goes on */
	CHECK(m[0].type == SWELL_MSG_PARAM_GET);
	m[0].type = SWELL_MSG_HEARTBEAT;
	/* 3 s after their last packet the other three are silent: the fifth gets a slot */
	CHECK(swell_peers_take(&p, &fifth, m, 2, 4 * s + 10) == 1);
	CHECK(p.clients_silent == 3);
	CHECK(swell_peers_clients(&p) == 2);
	CHECK(p.clients_admitted == 5);
}

TEST_CASE("peers: the first sender of DEVICE_POS is the device until let go, a configured one never is", "[links]")
{
	const sockaddr_in dev = loopback_at(50100), other = loopback_at(50101);
	swell_peers p;
	swell_msg pos[1] = {}, hb[1] = {};

	pos[0].type = SWELL_MSG_DEVICE_POS;
	hb[0].type = SWELL_MSG_HEARTBEAT;
	swell_peers_init(&p, 1, nullptr);
	CHECK(swell_peers_hear(&p, &other) == 1);
	CHECK(swell_peers_take(&p, &other, hb, 1, 0) == 0); /* not a position: nobody is held */
	CHECK(swell_peers_take(&p, &dev, pos, 1, 0) == 1);
	CHECK(swell_peers_hear(&p, &other) == 0); /* dropped unread */
	CHECK(p.others == 2);
	CHECK(swell_peers_release(&p) == 1);
	CHECK(swell_peers_hear(&p, &other) == 1);
	CHECK(swell_peers_take(&p, &other, pos, 1, 0) == 1);
	CHECK(p.peers_taken == 2);
	swell_peers_init(&p, 1, &dev);
	CHECK(swell_peers_hear(&p, &other) == 0);
	CHECK(swell_peers_release(&p) == 0);
}
