// A HapticMaster TCP client for the tests: the 8-byte header (big-endian length, four zero bytes)
// and the text, both ways; swell-hm --serve started on a free loopback port.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char **environ;

namespace hmtcp {

inline std::string slurp(const std::string &path)
{
	std::ifstream f(path);
	std::stringstream ss;
	ss << f.rdbuf();
	return ss.str();
}

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
// waits up to ms for pid to end: its exit status (128 + signal when killed), and pid set to -1; -1 when
// it is still running
inline int reap(pid_t &pid, int ms)
{
	for (int k = 0; k < ms / 10; k++) {
		int st = 0;
		if (waitpid(pid, &st, WNOHANG) == pid) {
			pid = -1;
			return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
		}
		std::this_thread::sleep_for(std::chrono::milliseconds(10));
	}
	return -1;
}

struct Server {
	pid_t pid = -1;
	int port = 0;
	std::string out;

	Server(const std::string &bin, const std::string &out_path, const std::vector<std::string> &extra) : out(out_path)
	{
		std::vector<std::string> args = {bin, "--serve", "127.0.0.1:0", "--quiet"};
		args.insert(args.end(), extra.begin(), extra.end());
		std::vector<char *> argv;
		for (auto &s : args)
			argv.push_back(&s[0]);
		argv.push_back(nullptr);
		posix_spawn_file_actions_t fa;
		posix_spawn_file_actions_init(&fa);
		posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
		posix_spawn_file_actions_adddup2(&fa, 1, 2);
		if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) != 0)
			pid = -1;
		posix_spawn_file_actions_destroy(&fa);
		for (int k = 0; k < 500 && pid > 0 && port == 0; k++) {
			const std::string s = slurp(out);
			const size_t at = s.find("127.0.0.1:");
			if (at != std::string::npos && s.find(',', at) != std::string::npos)
				port = std::stoi(s.substr(at + 10));
			else
				std::this_thread::sleep_for(std::chrono::milliseconds(10));
		}
	}
	// waits for the exit; the exit status, -1 when it did not end within ms
	int wait(int ms) { return reap(pid, ms); }
	~Server()
	{
		if (pid > 0) {
			kill(pid, SIGKILL);
			waitpid(pid, nullptr, 0);
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

// The whole number just before `label` in text (the summary's counters), -1 when absent.
inline long count_before(const std::string &text, const std::string &label)
{
	const size_t at = text.find(label);
	if (at == std::string::npos || at == 0)
		return -1;
	size_t k = at;
	while (k > 0 && text[k - 1] == ' ')
		k--;
	size_t e = k;
	while (k > 0 && text[k - 1] >= '0' && text[k - 1] <= '9')
		k--;
	return k == e ? -1 : std::stol(text.substr(k, e - k));
}

} // namespace hmtcp
