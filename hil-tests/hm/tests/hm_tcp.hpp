// A HapticMaster TCP client for the tests: the 8-byte header (big-endian length, four zero bytes)
// and the text, both ways; swell-hm --serve started on a free loopback port.
#pragma once

#include "swell_test.hpp"

#include <netinet/tcp.h>
#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

namespace hmtcp {

inline std::string frame(const std::string &text)
{
	const uint32_t n = (uint32_t)text.size();
	std::string h = {char(n >> 24), char(n >> 16), char(n >> 8), char(n), 0, 0, 0, 0};
	return h + text;
}

struct Client {
	int fd = -1;

	// rcvbuf > 0: a small receive buffer, set before the connection so that the window stays small
	explicit Client(int port, int rcvbuf = 0)
	{
		fd = socket(AF_INET, SOCK_STREAM, 0);
		if (rcvbuf > 0)
			setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
		sockaddr_in a{};
		a.sin_family = AF_INET;
		a.sin_port = htons((uint16_t)port);
		a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
		if (connect(fd, reinterpret_cast<sockaddr *>(&a), sizeof a) != 0) {
			close(fd);
			fd = -1;
		}
		int one = 1;
		if (fd >= 0)
			setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
	}
	~Client()
	{
		if (fd >= 0)
			close(fd);
	}
	Client(const Client &) = delete;
	Client &operator=(const Client &) = delete;

	bool raw(const std::string &bytes) const
	{
		return send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) == (ssize_t)bytes.size();
	}
	// n bytes within ms; false on EOF, error or timeout
	bool read_n(std::string &out, size_t n, int ms) const
	{
		out.clear();
		while (out.size() < n) {
			pollfd p = {fd, POLLIN, 0};
			if (poll(&p, 1, ms) <= 0)
				return false;
			char buf[4096];
			const ssize_t r = recv(fd, buf, std::min(sizeof buf, n - out.size()), 0);
			if (r <= 0)
				return false;
			out.append(buf, (size_t)r);
		}
		return true;
	}
	// one framed reply, or "<none>" / "<closed>"
	std::string reply(int ms = 2000) const
	{
		std::string h, t;
		if (!read_n(h, 8, ms))
			return "<none>";
		const uint32_t n = (uint32_t)(uint8_t)h[0] << 24 | (uint32_t)(uint8_t)h[1] << 16 | (uint32_t)(uint8_t)h[2] << 8 |
			(uint8_t)h[3];
		if (!read_n(t, n, ms))
			return "<closed>";
		return t;
	}
	std::string ask(const std::string &text, int ms = 2000) const
	{
		if (!raw(frame(text)))
			return "<send failed>";
		return reply(ms);
	}
	// the peer closed: recv gives 0 (or a reset) within ms
	bool closed_by_peer(int ms) const
	{
		for (;;) {
			pollfd p = {fd, POLLIN, 0};
			if (poll(&p, 1, ms) <= 0)
				return false;
			char buf[4096];
			const ssize_t r = recv(fd, buf, sizeof buf, 0);
			if (r <= 0)
				return true;
		}
	}
};

// swell-hm --serve 127.0.0.1:0 with the given extra arguments; its port read from its first line.
struct Server : swell_test::Proc {
	int port = 0;

	Server(const std::string &bin, const std::string &out_path, const std::vector<std::string> &extra)
	{
		std::vector<std::string> args = {bin, "--serve", "127.0.0.1:0", "--quiet"};
		args.insert(args.end(), extra.begin(), extra.end());
		start(args, out_path);
		for (int k = 0; k < 500 && port == 0; k++) {
			const std::string s = swell_test::slurp(out);
			const size_t at = s.find("127.0.0.1:");
			if (at != std::string::npos && s.find(',', at) != std::string::npos)
				port = std::stoi(s.substr(at + 10));
			else
				std::this_thread::sleep_for(std::chrono::milliseconds(10));
		}
	}
};

// A reply's answers, split at ';'.
inline std::vector<std::string> answers(const std::string &reply)
{
	std::vector<std::string> out;
	size_t at = 0;
	for (size_t semi; (semi = reply.find(';', at)) != std::string::npos; at = semi + 1)
		out.push_back(reply.substr(at, semi - at));
	out.push_back(reply.substr(at));
	return out;
}

// The numbers of an answer: "24.5" or "[0,0,1.0125]" (empty when there are none).
inline std::vector<double> numbers(const std::string &answer)
{
	std::vector<double> v;
	const char *p = answer.c_str();
	while (*p) {
		char *end;
		const double x = std::strtod(p, &end);
		if (end == p) {
			p++;
			continue;
		}
		v.push_back(x);
		p = end;
	}
	return v;
}

} // namespace hmtcp
