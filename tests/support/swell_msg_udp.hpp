// A UDP end that speaks swell packets, on the link library's socket layer (the test links swell_links).
#ifndef SWELL_TEST_MSG_UDP_HPP
#define SWELL_TEST_MSG_UDP_HPP

#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <unistd.h>

#include <vector>

#include "swell_msgs.hpp"

extern "C" {
#include "swell/link.h"
}

namespace swell_test {

// A UDP socket on 127.0.0.1 (any free port) that sends swell packets of node 0 to a port, or back to
// whoever sent last, and hears every sender.
struct MsgUdp {
	int fd = -1;
	uint16_t port = 0;
	uint8_t seq = 0;
	sockaddr_in last{}; // the sender of the last datagram received (port 0: none yet)
	static sockaddr_in at(uint16_t p)
	{
		sockaddr_in a{};
		a.sin_family = AF_INET;
		a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
		a.sin_port = htons(p);
		return a;
	}
	MsgUdp()
	{
		sockaddr_in a = at(0);
		fd = swell_udp_socket(&a, 0, 0, nullptr, &a);
		REQUIRE(fd >= 0);
		port = ntohs(a.sin_port);
	}
	~MsgUdp() { close(fd); }
	MsgUdp(const MsgUdp &) = delete;
	MsgUdp &operator=(const MsgUdp &) = delete;
	// m[0..n) in one packet to 127.0.0.1:to (0: to the last sender); 0 when sent
	int send(uint16_t to, const swell_msg *m, size_t n = 1)
	{
		uint8_t pkt[SWELL_PKT_MAX];
		size_t len = 0, used = 0;
		const sockaddr_in dst = to ? at(to) : last;
		if (swell_pkt_encode(0, seq++, m, n, pkt, sizeof pkt, &len, &used) != SWELL_OK || used != n)
			return -1;
		return swell_udp_send(fd, &dst, pkt, len);
	}
	// One datagram within timeout_ms (0: only one already there), decoded into out (cleared); false
	// when none came. A datagram that does not decode gives true with out empty.
	bool recv(std::vector<swell_msg> &out, int timeout_ms)
	{
		uint8_t buf[SWELL_PKT_MAX + 1];
		swell_msg m[SWELL_PKT_MSGS_MAX];
		size_t n = 0;
		uint8_t s = 0;
		out.clear();
		const long r = swell_udp_recv(fd, buf, sizeof buf, &last, timeout_ms);
		if (r < 0)
			return false;
		if (r <= (long)sizeof buf && swell_pkt_decode(buf, (size_t)r, m, SWELL_PKT_MSGS_MAX, &n, &s, nullptr) == SWELL_OK)
			out.assign(m, m + n);
		return true;
	}
	// The first message of type (or or_type) within timeout_ms; type 0 when none came.
	swell_msg wait_for(uint8_t type, int timeout_ms, uint8_t or_type = 0)
	{
		const uint64_t until = swell_link_now_ns() + (uint64_t)timeout_ms * 1000000u;
		std::vector<swell_msg> got;
		while (swell_link_now_ns() < until)
			if (recv(got, 20))
				for (const swell_msg &m : got)
					if (m.type == type || (or_type && m.type == or_type))
						return m;
		return swell_msg{};
	}
	// Datagrams waiting now, read and thrown away.
	int drain()
	{
		std::vector<swell_msg> got;
		int n = 0;
		while (recv(got, 0))
			n++;
		return n;
	}
};

} // namespace swell_test

#endif
