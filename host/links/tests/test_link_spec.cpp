// Link specs (swell/link_spec.h): every accepted spelling with its defaults, and every rejection as
// one line naming the spec, with the result left untouched.
#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <cstring>
#include <string>

extern "C" {
#include "swell/link_spec.h"
}

namespace {

const unsigned host_side =
	SWELL_LINK_ACCEPT(SWELL_LINK_UDP) | SWELL_LINK_ACCEPT(SWELL_LINK_CAN) | SWELL_LINK_ACCEPT(SWELL_LINK_USB);
const unsigned viewer = host_side | SWELL_LINK_ACCEPT(SWELL_LINK_CANFD) | SWELL_LINK_ACCEPT(SWELL_LINK_REPLAY);
const unsigned ctl_device = SWELL_LINK_ACCEPT(SWELL_LINK_UDP) | SWELL_LINK_ACCEPT(SWELL_LINK_CAN) |
	SWELL_LINK_ACCEPT(SWELL_LINK_FFS) | SWELL_LINK_ACCEPT(SWELL_LINK_HM) | SWELL_LINK_ACCEPT_PEER;
const unsigned ctl_host = SWELL_LINK_ACCEPT(SWELL_LINK_UDP) | SWELL_LINK_ACCEPT(SWELL_LINK_CAN) |
	SWELL_LINK_ACCEPT(SWELL_LINK_FFS) | SWELL_LINK_ACCEPT_LISTEN;

swell_link_spec ok(const char *text, unsigned accept, uint16_t port = 47802)
{
	swell_link_spec s;
	char err[200] = "";
	INFO("'" << text << "'");
	REQUIRE(swell_link_spec_parse(text, accept, port, &s, err, sizeof(err)) == 0);
	CHECK(std::string(err).empty());
	return s;
}

std::string described(const swell_link_spec &s)
{
	char d[300];
	swell_link_spec_describe(&s, d, sizeof(d));
	return d;
}

} // namespace

TEST_CASE("link specs: udp with its port and options, the caller's default port when none is spelled")
{
	swell_link_spec s = ok("udp", host_side);
	CHECK(s.kind == SWELL_LINK_UDP);
	CHECK(s.port == 47802);
	CHECK(s.port_given == 0);
	CHECK(described(s) == "udp 127.0.0.1:47802");
	s = ok("udp:1", host_side);
	CHECK(s.port == 1);
	CHECK(s.port_given == 1);
	s = ok("udp:65535", host_side);
	CHECK(described(s) == "udp 127.0.0.1:65535");
	CHECK(ok("udp", ctl_device, 47800).port == 47800);

	s = ok("udp:47800,peer=10.1.2.3:9", ctl_device);
	CHECK(s.port == 47800);
	REQUIRE(s.have_peer == 1);
	CHECK(s.have_listen == 0);
	CHECK(s.peer.sin_addr.s_addr == inet_addr("10.1.2.3"));
	CHECK(ntohs(s.peer.sin_port) == 9);
	s = ok("udp:47800,peer=5", ctl_device); // only the port: loopback
	CHECK(s.peer.sin_addr.s_addr == htonl(INADDR_LOOPBACK));
	CHECK(ntohs(s.peer.sin_port) == 5);

	s = ok("udp:47801,listen=0", ctl_host); // any free port
	REQUIRE(s.have_listen == 1);
	CHECK(s.listen_at.sin_addr.s_addr == htonl(INADDR_LOOPBACK));
	CHECK(s.listen_at.sin_port == 0);
	s = ok("udp,listen=0.0.0.0:47900", ctl_host);
	CHECK(s.port_given == 0);
	CHECK(s.listen_at.sin_addr.s_addr == htonl(INADDR_ANY));
	CHECK(ntohs(s.listen_at.sin_port) == 47900);
}

TEST_CASE("link specs: can, canfd, usb (libusb or FunctionFS), hm and replays")
{
	swell_link_spec s = ok("can:can1", host_side);
	CHECK(s.kind == SWELL_LINK_CAN);
	CHECK(std::string(s.name) == "can1");
	s = ok("can:abcdefghijklmno", host_side); // 15: the longest
	CHECK(described(s) == "can abcdefghijklmno");
	s = ok("canfd:vcan0", viewer);
	CHECK(s.kind == SWELL_LINK_CANFD);
	CHECK(described(s) == "canfd vcan0");

	s = ok("usb", host_side);
	CHECK(s.kind == SWELL_LINK_USB);
	CHECK(s.vid == 0x1209);
	CHECK(s.pid == 0x0001);
	CHECK(s.iface == 0);
	s = ok("usb:0483:DF11", host_side);
	CHECK(s.vid == 0x0483);
	CHECK(s.pid == 0xdf11);
	CHECK(described(s) == "usb 0483:df11 interface 0");

	s = ok("usb:/dev/ffs-swell", ctl_device); // the controller's side: a FunctionFS mount
	CHECK(s.kind == SWELL_LINK_FFS);
	CHECK(std::string(s.name) == "/dev/ffs-swell");
	s = ok("usb:1209:0001", ctl_host); // a directory of that name, where libusb is not spoken
	CHECK(s.kind == SWELL_LINK_FFS);
	CHECK(std::string(s.name) == "1209:0001");

	s = ok("hm:127.0.0.1:7654", ctl_device);
	CHECK(s.kind == SWELL_LINK_HM);
	CHECK(std::string(s.name) == "127.0.0.1:7654");

	s = ok("replay:run.rec", viewer);
	CHECK(s.kind == SWELL_LINK_REPLAY);
	CHECK(s.realtime == 1);
	CHECK(std::string(s.name) == "run.rec");
	s = ok("replay-fast:a:b.rec", viewer);
	CHECK(s.realtime == 0);
	CHECK(std::string(s.name) == "a:b.rec");
}

TEST_CASE("link specs: a bad one is refused with one line naming it, and the result is left untouched")
{
	const std::string long_one(300, 'x');
	struct {
		const char *spec;
		unsigned accept;
		const char *reason;
	} bad[] = {{"", host_side, "'': not a link: udp[:PORT], can:IFACE, usb[:VID:PID]"},
		   {"tcp:1", host_side, "'tcp:1': not a link: udp[:PORT], can:IFACE, usb[:VID:PID]"},
		   {"tcp:1", ctl_device, "'tcp:1': not a link: udp[:PORT], can:IFACE, usb:FFS_DIR, hm:HOST[:PORT]"},
		   {"tcp:1", viewer, "canfd:IFACE, usb[:VID:PID], replay:FILE or replay-fast:FILE"},
		   {"udpx", host_side, "not a link"},
		   {"udp:", host_side, "'udp:': UDP port not in 1..65535"},
		   {"udp:0", host_side, "UDP port not in 1..65535"},
		   {"udp:65536", host_side, "UDP port not in 1..65535"},
		   {"udp:-1", host_side, "UDP port not in 1..65535"},
		   {"udp:+80", host_side, "UDP port not in 1..65535"},
		   {"udp:80x", host_side, "UDP port not in 1..65535"},
		   {"udp:99999999999999999999", host_side, "UDP port not in 1..65535"},
		   {"udp:80,peer=127.0.0.1:5", host_side, "UDP port not in 1..65535"}, // no options here
		   {"udp:,peer=127.0.0.1:5", ctl_device, "UDP port not in 1..65535"},
		   {"udp:47800,peer=", ctl_device, "is not peer=ADDR:PORT"},
		   {"udp:47800,peer=1.2.3:5", ctl_device, "is not peer=ADDR:PORT"},
		   {"udp:47800,peer=127.0.0.1:0", ctl_device, "is not peer=ADDR:PORT"},
		   {"udp:47800,peer=127.0.0.1:70000", ctl_device, "is not peer=ADDR:PORT"},
		   {"udp:47800,listen=5", ctl_device, "is not peer=ADDR:PORT"},
		   {"udp:47801,peer=5", ctl_host, "is not listen=[ADDR:]PORT"},
		   {"udp:47801,listen=1.2.3.4.5:1", ctl_host, "'udp:47801,listen=1.2.3.4.5:1': the option is not listen="},
		   {"can:", host_side, "'can:': give the CAN interface, e.g. can:can0"},
		   {"can", host_side, "not a link"},
		   {"can:abcdefghijklmnop", host_side, "interface name longer than 15 characters"},
		   {"can:can0,3", host_side, "not an interface name (the node is chosen with --node)"},
		   {"can:a/b", host_side, "not an interface name"},
		   {"can:..", host_side, "not an interface name"},
		   {"canfd:", viewer, "give the CAN interface"},
		   {"canfd:can0", host_side, "'canfd:can0': swell's controller links are classic CAN"},
		   {"usb:", host_side, "not usb:VID:PID in hex"},
		   {"usb:1209", host_side, "not usb:VID:PID in hex"},
		   {"usb:1209:", host_side, "not usb:VID:PID in hex"},
		   {"usb:12345:1", host_side, "not usb:VID:PID in hex"},
		   {"usb:1209:0001:0", host_side, "not usb:VID:PID in hex"},
		   {"usb:xyz:0001", host_side, "not usb:VID:PID in hex"},
		   {"usb:/dev/ffs-swell", host_side, "usb:FFS_DIR is swell-ctl's side of the link"},
		   {"usbx", host_side, "not a link"},
		   {"usb", ctl_device, "'usb': give the FunctionFS mount, e.g. usb:/dev/ffs-swell"},
		   {"usb:", ctl_host, "give the FunctionFS mount"},
		   {"hm:", ctl_device, "'hm:': want hm:HOST[:PORT]"},
		   {"hm:1.2.3.4", ctl_host, "not a link"}, // the host link is never a HapticMaster
		   {"replay:", viewer, "'replay:': give the recording"},
		   {"replay-fast:", viewer, "give the recording"},
		   {"replay:x.rec", host_side, "not a link"},
		   {long_one.c_str(), host_side, "longer than 255 characters"}};
	for (auto &b : bad) {
		swell_link_spec s, before;
		std::memset(&s, 0x5a, sizeof(s));
		before = s;
		char err[200] = "";
		INFO("'" << b.spec << "'");
		CHECK(swell_link_spec_parse(b.spec, b.accept, 47802, &s, err, sizeof(err)) == -1);
		INFO(err);
		CHECK(std::string(err).find(b.reason) != std::string::npos);
		CHECK(std::strchr(err, '\n') == nullptr);
		CHECK(std::memcmp(&s, &before, sizeof(s)) == 0);
	}
}
