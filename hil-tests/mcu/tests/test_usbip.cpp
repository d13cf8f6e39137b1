// The USB/IP server of the OTG FS model (hil-tests/mcu/usbip.c): the codec against the layouts of
// the kernel's usbip_protocol.rst, and a client on a socketpair that imports the device (the
// model driven by the scripted driver of otgfs_script.hpp) and moves control and bulk URBs.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <memory>

#include "otgfs_script.hpp"

extern "C" {
#include "usbip.h"
}

using namespace otgfs_script;

namespace
{

std::vector<uint8_t> hex(const char *s)
{
	std::vector<uint8_t> v;
	for (; *s; s++) {
		if (*s == ' ')
			continue;
		unsigned b;
		REQUIRE(sscanf(s, "%2x", &b) == 1);
		v.push_back((uint8_t)b);
		s++;
	}
	return v;
}

uint32_t be32(const uint8_t *p)
{
	return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

struct Link {
	std::unique_ptr<otgfs> m{ new otgfs };
	std::unique_ptr<usbip_server> srv{ new usbip_server };
	uint64_t now = 1000;
	Driver drv;
	int fd[2] = { -1, -1 }; // fd[0] the client's, fd[1] the server's
	std::vector<uint8_t> got;
	enum usbip_step last = USBIP_IDLE;

	Link() : drv(m.get(), &now)
	{
		otgfs_init(m.get(), 1000000000u);
		REQUIRE(socketpair(AF_UNIX, SOCK_STREAM, 0, fd) == 0);
		REQUIRE(fcntl(fd[0], F_SETFL, O_NONBLOCK) == 0);
		usbip_server_init(srv.get(), fd[1], m.get(), 7);
	}
	~Link()
	{
		close(fd[0]);
		close(fd[1]);
	}
	void send(const std::vector<uint8_t> &b)
	{
		REQUIRE(write(fd[0], b.data(), b.size()) == (ssize_t)b.size());
	}
	// Run server, driver and time until the client holds n bytes (or the server closes).
	bool wait_bytes(size_t n, int max_us = 200000)
	{
		for (int i = 0; i < max_us && got.size() < n; i++) {
			last = usbip_server_step(srv.get(), now);
			if (last == USBIP_CLOSED)
				return false;
			drv.isr();
			now += 1000;
			otgfs_advance(m.get(), now);
			uint8_t b[8192];
			ssize_t r = read(fd[0], b, sizeof(b));
			if (r > 0)
				got.insert(got.end(), b, b + r);
		}
		return got.size() >= n;
	}
	std::vector<uint8_t> take(size_t n)
	{
		REQUIRE(wait_bytes(n));
		std::vector<uint8_t> v(got.begin(), got.begin() + (long)n);
		got.erase(got.begin(), got.begin() + (long)n);
		return v;
	}
	void import_device()
	{
		REQUIRE(drv.start());
		std::vector<uint8_t> req(8 + 32, 0);
		usbip_op_encode(USBIP_OP_REQ_IMPORT, 0, req.data());
		std::memcpy(req.data() + 8, USBIP_BUSID, sizeof(USBIP_BUSID));
		send(req);
		auto rep = take(8 + USBIP_DEV_LEN);
		uint16_t version, code;
		uint32_t status;
		usbip_op_decode(rep.data(), &version, &code, &status);
		REQUIRE(code == USBIP_OP_REP_IMPORT);
		REQUIRE(status == 0);
		REQUIRE(usbip_dev_decode(rep.data() + 8, &dev) == 0);
	}
	usbip_dev dev{};
	uint32_t seq = 1;
	uint32_t submit(uint32_t dir, uint32_t ep, uint32_t len, const uint8_t setup[8],
			const std::vector<uint8_t> &out = {}, uint32_t flags = 0)
	{
		usbip_hdr h{};
		h.command = USBIP_CMD_SUBMIT;
		h.seqnum = seq++;
		h.devid = (USBIP_BUSNUM << 16) | dev.devnum;
		h.direction = dir;
		h.ep = ep;
		h.u.submit.flags = flags;
		h.u.submit.length = len;
		if (setup)
			std::memcpy(h.u.submit.setup, setup, 8);
		std::vector<uint8_t> b(USBIP_HDR_LEN);
		usbip_hdr_encode(&h, b.data());
		b.insert(b.end(), out.begin(), out.end());
		send(b);
		return h.seqnum;
	}
	// The next RET_SUBMIT, and its IN data.
	usbip_hdr ret(std::vector<uint8_t> &data, uint32_t dir)
	{
		auto b = take(USBIP_HDR_LEN);
		usbip_hdr h{};
		REQUIRE(usbip_hdr_decode(b.data(), &h) == 0);
		data.clear();
		if (h.command == USBIP_RET_SUBMIT && dir == USBIP_DIR_IN)
			data = take(h.u.ret_submit.actual_length);
		return h;
	}
};

} // namespace

TEST_CASE("USB/IP codec: the protocol document's CmdIntrIN capture decodes field by field and encodes back")
{
	auto b = hex("00000001 00000d05 0001000f 00000001 00000001 00000200 00000040 ffffffff 00000000 00000004 "
		     "00000000 00000000");
	REQUIRE(b.size() == USBIP_HDR_LEN);
	usbip_hdr h{};
	REQUIRE(usbip_hdr_decode(b.data(), &h) == 0);
	CHECK(h.command == USBIP_CMD_SUBMIT);
	CHECK(h.seqnum == 0xd05u);
	CHECK(h.devid == 0x0001000fu);
	CHECK(h.direction == USBIP_DIR_IN);
	CHECK(h.ep == 1u);
	CHECK(h.u.submit.flags == 0x200u);
	CHECK(h.u.submit.length == 0x40u);
	CHECK(h.u.submit.start_frame == 0xffffffffu);
	CHECK(h.u.submit.number_of_packets == 0u);
	CHECK(h.u.submit.interval == 4u);
	uint8_t again[USBIP_HDR_LEN];
	usbip_hdr_encode(&h, again);
	CHECK(std::vector<uint8_t>(again, again + USBIP_HDR_LEN) == b);
}

TEST_CASE(
	"USB/IP codec: RET_SUBMIT and RET_UNLINK carry a negative status big-endian, and an unknown command is refused")
{
	usbip_hdr h{};
	h.command = USBIP_RET_SUBMIT;
	h.seqnum = 0x01020304u;
	h.u.ret_submit.status = USBIP_EPIPE;
	h.u.ret_submit.actual_length = 18;
	uint8_t b[USBIP_HDR_LEN];
	usbip_hdr_encode(&h, b);
	CHECK(be32(b) == 3u);
	CHECK(be32(b + 4) == 0x01020304u);
	CHECK(be32(b + 20) == 0xFFFFFFE0u); // -32
	CHECK(be32(b + 24) == 18u);
	usbip_hdr d{};
	REQUIRE(usbip_hdr_decode(b, &d) == 0);
	CHECK(d.u.ret_submit.status == USBIP_EPIPE);
	h = usbip_hdr{};
	h.command = USBIP_RET_UNLINK;
	h.u.ret_unlink.status = USBIP_ECONNRESET;
	usbip_hdr_encode(&h, b);
	CHECK(be32(b + 20) == (uint32_t)-104);
	b[3] = 9;
	d.seqnum = 77;
	CHECK(usbip_hdr_decode(b, &d) == -1);
	CHECK(d.seqnum == 77u);
}

TEST_CASE("USB/IP codec: the device record puts busnum, devnum, speed and the IDs at the documented offsets")
{
	usbip_dev d{};
	std::strcpy(d.path, "/x");
	std::strcpy(d.busid, "1-1");
	d.busnum = 1;
	d.devnum = 7;
	d.speed = 2;
	d.id_vendor = 0x1209;
	d.id_product = 0x0001;
	d.num_interfaces = 1;
	uint8_t b[USBIP_DEV_LEN];
	usbip_dev_encode(&d, b);
	// OP_REP_IMPORT offsets less its 8-byte header
	CHECK(be32(b + 0x128 - 8) == 1u);
	CHECK(be32(b + 0x12C - 8) == 7u);
	CHECK(be32(b + 0x130 - 8) == 2u);
	CHECK(b[0x134 - 8] == 0x12);
	CHECK(b[0x135 - 8] == 0x09);
	CHECK(b[0x13F - 8] == 1);
	CHECK(std::string((const char *)b + 0x108 - 8) == "1-1");
	usbip_dev e{};
	REQUIRE(usbip_dev_decode(b, &e) == 0);
	CHECK(e.id_vendor == 0x1209);
	b[0x100 + 31] = 'x';
	std::memset(b + 0x100, 'x', 32); // busid without its terminating zero
	CHECK(usbip_dev_decode(b, &e) == -1);
}

TEST_CASE("USB/IP server: OP_REQ_IMPORT enumerates the device and answers with its IDs, address and full speed")
{
	Link l;
	l.import_device();
	CHECK(l.dev.id_vendor == 0x1209);
	CHECK(l.dev.id_product == 0x0001);
	CHECK(l.dev.devnum == 7u);
	CHECK(l.dev.speed == 2u);
	CHECK(l.dev.num_interfaces == 1);
	CHECK(std::string(l.dev.busid) == USBIP_BUSID);
	CHECK(otgfs_host_address(l.m.get()) == 7);
	CHECK(l.drv.address == 7);
}

TEST_CASE("USB/IP server: an import of another bus ID is refused with status 1")
{
	Link l;
	std::vector<uint8_t> req(8 + 32, 0);
	usbip_op_encode(USBIP_OP_REQ_IMPORT, 0, req.data());
	std::memcpy(req.data() + 8, "2-5", 3);
	l.send(req);
	auto rep = l.take(8);
	uint16_t version, code;
	uint32_t status;
	usbip_op_decode(rep.data(), &version, &code, &status);
	CHECK(version == USBIP_VERSION);
	CHECK(code == USBIP_OP_REP_IMPORT);
	CHECK(status == 1u);
}

TEST_CASE("USB/IP server: control URBs: GET_DESCRIPTOR returns the descriptor, SET_CONFIGURATION configures, a refused "
	  "request is -EPIPE")
{
	Link l;
	l.import_device();
	std::vector<uint8_t> d;
	const uint8_t get_dev[8] = { 0x80, 6, 0, 1, 0, 0, 64, 0 };
	uint32_t sq = l.submit(USBIP_DIR_IN, 0, 64, get_dev);
	usbip_hdr r = l.ret(d, USBIP_DIR_IN);
	CHECK(r.command == USBIP_RET_SUBMIT);
	CHECK(r.seqnum == sq);
	CHECK(r.u.ret_submit.status == 0);
	CHECK(d == std::vector<uint8_t>(device_desc, device_desc + 18));
	const uint8_t set_cfg[8] = { 0x00, 9, 1, 0, 0, 0, 0, 0 };
	l.submit(USBIP_DIR_OUT, 0, 0, set_cfg);
	r = l.ret(d, USBIP_DIR_OUT);
	CHECK(r.u.ret_submit.status == 0);
	CHECK(l.drv.config == 1);
	const uint8_t bad[8] = { 0x80, 6, 0, 6, 0, 0, 10, 0 };
	l.submit(USBIP_DIR_IN, 0, 10, bad);
	r = l.ret(d, USBIP_DIR_IN);
	CHECK(r.u.ret_submit.status == USBIP_EPIPE);
	CHECK(r.u.ret_submit.actual_length == 0u);
	CHECK(l.srv->stats.stalls == 1u);
	CHECK(l.srv->stats.errors == 1u);
}

TEST_CASE("USB/IP server: 200 bulk URBs OUT come back IN intact, in order, with the IN URB queued first")
{
	Link l;
	l.import_device();
	std::vector<uint8_t> d;
	const uint8_t set_cfg[8] = { 0x00, 9, 1, 0, 0, 0, 0, 0 };
	l.submit(USBIP_DIR_OUT, 0, 0, set_cfg);
	REQUIRE(l.ret(d, USBIP_DIR_OUT).u.ret_submit.status == 0);
	for (unsigned i = 0; i < 200; i++) {
		std::vector<uint8_t> p(1 + (i * 13) % 64);
		for (size_t k = 0; k < p.size(); k++)
			p[k] = (uint8_t)(i + 3 * k);
		uint32_t in_seq = l.submit(USBIP_DIR_IN, 1, 64, nullptr); // waits (NAK) until the echo
		uint32_t out_seq = l.submit(USBIP_DIR_OUT, 1, (uint32_t)p.size(), nullptr, p);
		usbip_hdr r1 = l.ret(d, USBIP_DIR_OUT);
		REQUIRE(r1.seqnum == out_seq);
		REQUIRE(r1.u.ret_submit.actual_length == p.size());
		usbip_hdr r2 = l.ret(d, USBIP_DIR_IN);
		REQUIRE(r2.seqnum == in_seq);
		REQUIRE(r2.u.ret_submit.status == 0);
		REQUIRE(d == p);
	}
	CHECK(l.srv->stats.errors == 0u);
	CHECK(otgfs_fault(l.m.get()) == nullptr);
}

TEST_CASE("USB/IP server: unlinking a pending URB answers -ECONNRESET and no RET_SUBMIT, an answered one 0")
{
	Link l;
	l.import_device();
	std::vector<uint8_t> d;
	const uint8_t set_cfg[8] = { 0x00, 9, 1, 0, 0, 0, 0, 0 };
	uint32_t cfg_seq = l.submit(USBIP_DIR_OUT, 0, 0, set_cfg);
	REQUIRE(l.ret(d, USBIP_DIR_OUT).u.ret_submit.status == 0);
	uint32_t in_seq = l.submit(USBIP_DIR_IN, 1, 64, nullptr); // nothing to read: stays pending
	l.wait_bytes(1, 2000);
	REQUIRE(l.got.empty());
	usbip_hdr u{};
	u.command = USBIP_CMD_UNLINK;
	u.seqnum = l.seq++;
	u.u.unlink.seqnum = in_seq;
	std::vector<uint8_t> b(USBIP_HDR_LEN);
	usbip_hdr_encode(&u, b.data());
	l.send(b);
	usbip_hdr r = l.ret(d, USBIP_DIR_OUT);
	CHECK(r.command == USBIP_RET_UNLINK);
	CHECK(r.seqnum == u.seqnum);
	CHECK(r.u.ret_unlink.status == USBIP_ECONNRESET);
	u.seqnum = l.seq++;
	u.u.unlink.seqnum = cfg_seq;
	usbip_hdr_encode(&u, b.data());
	l.send(b);
	r = l.ret(d, USBIP_DIR_OUT);
	CHECK(r.command == USBIP_RET_UNLINK);
	CHECK(r.u.ret_unlink.status == 0);
	// the unlinked IN URB never answers, even when data arrives for a new one
	l.submit(USBIP_DIR_OUT, 1, 3, nullptr, { 1, 2, 3 });
	REQUIRE(l.ret(d, USBIP_DIR_OUT).u.ret_submit.status == 0);
	uint32_t in2 = l.submit(USBIP_DIR_IN, 1, 64, nullptr);
	r = l.ret(d, USBIP_DIR_IN);
	CHECK(r.seqnum == in2);
	CHECK(d == std::vector<uint8_t>{ 1, 2, 3 });
}

TEST_CASE("USB/IP server: a command it cannot take closes the connection with a reason")
{
	Link l;
	l.import_device();
	std::vector<uint8_t> b(USBIP_HDR_LEN, 0);
	b[3] = 3; // RET_SUBMIT from the client
	l.send(b);
	CHECK(!l.wait_bytes(1, 100));
	CHECK(l.last == USBIP_CLOSED);
	REQUIRE(l.srv->error != nullptr);
	CHECK(std::string(l.srv->error).find("reply") != std::string::npos);
}

TEST_CASE("USB/IP server: a device that leaves the bus ends the session, and a new session imports it again")
{
	Link l;
	l.import_device();
	l.drv.wr(DCTL, 2u); // SDIS: the pull-up off, as an unplug
	CHECK(!l.wait_bytes(1, 100));
	CHECK(l.last == USBIP_CLOSED);
	REQUIRE(l.srv->error != nullptr);
	CHECK(std::string(l.srv->error).find("left the bus") != std::string::npos);
	// the caller's next connection: a fresh server finds the device once it is back
	close(l.fd[0]);
	close(l.fd[1]);
	REQUIRE(socketpair(AF_UNIX, SOCK_STREAM, 0, l.fd) == 0);
	REQUIRE(fcntl(l.fd[0], F_SETFL, O_NONBLOCK) == 0);
	usbip_server_init(l.srv.get(), l.fd[1], l.m.get(), 9);
	l.got.clear();
	l.drv.wr(DCTL, 0u);
	l.import_device();
	CHECK(l.dev.devnum == 9u);
	CHECK(l.drv.resets == 2u);
	std::vector<uint8_t> d;
	const uint8_t get_dev[8] = { 0x80, 6, 0, 1, 0, 0, 18, 0 };
	l.submit(USBIP_DIR_IN, 0, 18, get_dev);
	CHECK(l.ret(d, USBIP_DIR_IN).u.ret_submit.status == 0);
	CHECK(d.size() == 18);
}

TEST_CASE("USB/IP server: the host closing the connection pulls the cable (the device's suspend 6 ms later), the "
	  "next session plugs it in again, and waiting says when a URB waits on the device")
{
	constexpr uint32_t USBSUSP = 1u << 11;
	Link l;
	CHECK(!usbip_server_waiting(l.srv.get()));
	l.import_device();
	const uint8_t set_cfg[8] = { 0x00, 9, 1, 0, 0, 0, 0, 0 };
	std::vector<uint8_t> d;
	l.submit(USBIP_DIR_OUT, 0, 0, set_cfg);
	CHECK(l.ret(d, USBIP_DIR_OUT).u.ret_submit.status == 0);
	// a bulk IN with nothing to send waits on the device
	l.submit(USBIP_DIR_IN, 1, 64, nullptr);
	CHECK(!l.wait_bytes(1, 20));
	CHECK(usbip_server_waiting(l.srv.get()));
	close(l.fd[0]); // the host lets go
	l.fd[0] = -1;
	CHECK(usbip_server_step(l.srv.get(), l.now) == USBIP_CLOSED);
	const uint64_t out_at = l.now;
	CHECK(!otgfs_host_plugged(l.m.get()));
	CHECK((otgfs_read(l.m.get(), GINTSTS, out_at + 6000000u - 1) & USBSUSP) == 0u);
	CHECK((otgfs_read(l.m.get(), GINTSTS, out_at + 6000000u) & USBSUSP) != 0u);
	l.now = out_at + 6000000u;
	// the next session
	close(l.fd[1]);
	REQUIRE(socketpair(AF_UNIX, SOCK_STREAM, 0, l.fd) == 0);
	REQUIRE(fcntl(l.fd[0], F_SETFL, O_NONBLOCK) == 0);
	usbip_server_init(l.srv.get(), l.fd[1], l.m.get(), 7);
	l.got.clear();
	l.import_device();
	CHECK(otgfs_host_plugged(l.m.get()));
	CHECK(l.drv.resets == 2u);
	CHECK(!usbip_server_waiting(l.srv.get()));
}
