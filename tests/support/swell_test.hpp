// Helpers every Catch2 test of a program shares: run it and capture what it says, start, stop and
// reap it, check a table of bad arguments, loopback sockets on free ports, a whole file as text,
// swell-hm's log. The messages tests build are in swell_msgs.hpp.
// CMake puts this folder on every test's include path (swell_catch_test).
#ifndef SWELL_TEST_SUPPORT_HPP
#define SWELL_TEST_SUPPORT_HPP

#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <dirent.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

extern char **environ;

namespace swell_test {

// The whole file as text ("" when it cannot be read).
inline std::string slurp(const std::string &path)
{
	std::string s;
	FILE *f = fopen(path.c_str(), "r");
	if (!f)
		return s;
	char buf[4096];
	size_t n;
	while ((n = fread(buf, 1, sizeof buf, f)) > 0)
		s.append(buf, n);
	fclose(f);
	return s;
}

// Starts argv[0] (a path) with argv; does not wait. out: the file stdout goes to; err: the file
// stderr goes to, "&1" together with stdout; "" for either: this process's.
inline pid_t spawn(std::vector<std::string> argv, const std::string &out = "", const std::string &err = "&1")
{
	std::vector<char *> v;
	for (auto &a : argv)
		v.push_back(&a[0]);
	v.push_back(nullptr);
	posix_spawn_file_actions_t fa;
	posix_spawn_file_actions_init(&fa);
	if (!out.empty())
		posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	if (err == "&1" && !out.empty())
		posix_spawn_file_actions_adddup2(&fa, 1, 2);
	else if (!err.empty() && err != "&1")
		posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	pid_t pid = -1;
	const int rc = posix_spawn(&pid, v[0], &fa, nullptr, v.data(), environ);
	posix_spawn_file_actions_destroy(&fa);
	INFO("spawning " << argv[0]);
	REQUIRE(rc == 0);
	return pid;
}

struct Run {
	int code = -1; // the exit code; -1 when it was killed by a signal
	std::string out, err;
};

// Runs argv[0] (a path) with argv and waits for it: its exit code, stdout and stderr. log: where the
// two go meanwhile (log.out, log.err; removed after unless keep); by default a name of this process.
inline Run run(std::vector<std::string> argv, std::string log = "", bool keep = false)
{
	if (log.empty())
		log = "/tmp/swell-test-" + std::to_string(getpid());
	const pid_t pid = spawn(std::move(argv), log + ".out", log + ".err");
	int st = 0;
	waitpid(pid, &st, 0);
	Run r;
	r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
	r.out = slurp(log + ".out");
	r.err = slurp(log + ".err");
	if (!keep) {
		std::remove((log + ".out").c_str());
		std::remove((log + ".err").c_str());
	}
	return r;
}

// Waits up to ms for pid to end: its exit status (128 + signal when killed), and pid set to -1; -1
// when it is still running.
inline int reap(pid_t &pid, int ms)
{
	if (pid <= 0)
		return -1;
	for (int k = 0; k <= ms / 10; k++) {
		int st = 0;
		if (waitpid(pid, &st, WNOHANG) == pid) {
			pid = -1;
			return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
		}
		usleep(10000);
	}
	return -1;
}

// Sends sig and waits up to ms for the end: the exit status (128 + signal when killed); -1 when it
// did not end (it is then killed).
inline int stop(pid_t &pid, int sig = SIGTERM, int ms = 60000)
{
	if (pid <= 0)
		return -1;
	kill(pid, sig);
	const int rc = reap(pid, ms);
	if (rc < 0 && pid > 0) {
		kill(pid, SIGKILL);
		waitpid(pid, nullptr, 0);
		pid = -1;
	}
	return rc;
}

// A program started with stdout and stderr together into the file out, killed should the test end
// before it does.
struct Proc {
	pid_t pid = -1;
	std::string out;
	Proc() = default;
	Proc(const std::vector<std::string> &argv, const std::string &out_path) { start(argv, out_path); }
	Proc(const Proc &) = delete;
	Proc &operator=(const Proc &) = delete;
	void start(const std::vector<std::string> &argv, const std::string &out_path)
	{
		out = out_path;
		pid = spawn(argv, out);
	}
	// waits up to ms for the end: the exit status; -1 when it did not end (it is then killed)
	int wait(int ms) { return stop(0, ms); }
	int stop(int sig = SIGTERM, int ms = 60000) { return swell_test::stop(pid, sig, ms); }
	~Proc()
	{
		if (pid > 0) {
			kill(pid, SIGKILL);
			waitpid(pid, nullptr, 0);
		}
	}
};

// One row of a bad-argument table: the arguments, what the one line on stderr must say, and the
// exit status (2, bad arguments, unless the row is about a runtime failure).
struct BadArgs {
	std::vector<std::string> args;
	const char *says;
	int code = 2;
};

// Every row: its exit status, one line on stderr that contains `says`, nothing on stdout. extra:
// arguments put after each row's own (e.g. a short run, should a row be taken).
inline void check_bad_args(const std::string &bin, const std::vector<BadArgs> &table,
			   const std::vector<std::string> &extra = {})
{
	for (const auto &c : table) {
		std::vector<std::string> argv = { bin };
		argv.insert(argv.end(), c.args.begin(), c.args.end());
		argv.insert(argv.end(), extra.begin(), extra.end());
		const Run r = run(argv);
		std::string joined;
		for (const auto &a : c.args)
			joined += a + " ";
		INFO(joined << "-> exit " << r.code << ", stderr '" << r.err << "', stdout '" << r.out << "'");
		CHECK(r.code == c.code);
		CHECK(r.err.find(c.says) != std::string::npos);
		CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
		CHECK(r.out.empty());
	}
}

// --help: exit 0, on stdout, and the text documents the exit statuses ("Exit status: 0 ..., 1 ...,
// 2 bad arguments").
inline void check_help(const std::string &bin)
{
	const Run r = run({ bin, "--help" });
	INFO(bin << " --help -> exit " << r.code << "\n" << r.out << r.err);
	CHECK(r.code == 0);
	CHECK(r.out.find("Exit status: 0 ") != std::string::npos);
	CHECK(r.out.find("1 ") != std::string::npos);
	CHECK(r.out.find("2 bad arguments") != std::string::npos);
}

// Files this process has open now (to see that a failed open left none behind).
inline int open_fds()
{
	int n = 0;
	DIR *d = opendir("/proc/self/fd");
	REQUIRE(d);
	while (readdir(d))
		n++;
	closedir(d);
	return n;
}

// A socket of type (SOCK_DGRAM, SOCK_STREAM) bound to loopback on a port of the kernel's choosing;
// the port in *port. A TCP socket listens.
inline int loopback_socket(int type, int *port)
{
	const int fd = socket(AF_INET, type | SOCK_CLOEXEC, 0);
	REQUIRE(fd >= 0);
	sockaddr_in a{};
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	socklen_t al = sizeof a;
	REQUIRE(bind(fd, reinterpret_cast<sockaddr *>(&a), sizeof a) == 0);
	REQUIRE(getsockname(fd, reinterpret_cast<sockaddr *>(&a), &al) == 0);
	REQUIRE((type != SOCK_STREAM || listen(fd, 4) == 0));
	*port = ntohs(a.sin_port);
	return fd;
}

// A UDP socket on loopback, its port as text in *port.
inline int udp_loopback(std::string *port)
{
	int p = 0;
	const int fd = loopback_socket(SOCK_DGRAM, &p);
	*port = std::to_string(p);
	return fd;
}

// A loopback UDP port that was free a moment ago (nobody listens there).
inline uint16_t free_udp_port()
{
	int port = 0;
	close(loopback_socket(SOCK_DGRAM, &port));
	return (uint16_t)port;
}

// The whole number just before `label` in text (a summary's counters), -1 when absent.
inline long count_before(const std::string &text, const std::string &label)
{
	const size_t at = text.find(label);
	if (at == std::string::npos || at == 0)
		return -1;
	size_t k = at;
	while (k > 0 && text[k - 1] == ' ')
		k--;
	const size_t e = k;
	while (k > 0 && text[k - 1] >= '0' && text[k - 1] <= '9')
		k--;
	return k == e ? -1 : std::stol(text.substr(k, e - k));
}

// One row of swell-hm's --log (docs/hm.md): time s, position mm, velocity mm/s, commanded and hand
// force N, then five whole columns: enable, cmd_age, applied, ctl_state, holding; with --serve
// req_age, clients, applied, dev_state, holding (named by the accessors).
struct HmLogRow {
	double t, x[3], v[3], fcmd[3], fhand[3];
	int enable, age, applied, state, holding;
	int req_age() const { return enable; }
	int clients() const { return age; }
};

// Every complete row of the log at path (the header and a cut last line are skipped).
inline std::vector<HmLogRow> read_hm_log(const std::string &path)
{
	std::ifstream f(path);
	std::string line;
	std::vector<HmLogRow> rows;
	std::getline(f, line); // the header
	while (std::getline(f, line)) {
		HmLogRow r{};
		if (std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%d,%d,%d,%d,%d", &r.t,
				&r.x[0], &r.x[1], &r.x[2], &r.v[0], &r.v[1], &r.v[2], &r.fcmd[0], &r.fcmd[1], &r.fcmd[2],
				&r.fhand[0], &r.fhand[1], &r.fhand[2], &r.enable, &r.age, &r.applied, &r.state,
				&r.holding) == 18)
			rows.push_back(r);
	}
	return rows;
}

} // namespace swell_test

#endif
