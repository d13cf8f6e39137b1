/* swell-bench's arguments: bad ones exit 2 with one line before any measuring, --replot without
 * results exits 1 and writes no plot. */
#include <catch2/catch.hpp>

#include <dirent.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

extern char **environ;

namespace {

std::string slurp(const std::string &path)
{
	std::ifstream f(path);
	return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

struct Run {
	int code = -1;
	std::string out, err;
};

Run run(std::vector<std::string> args, const std::string &log)
{
	args.insert(args.begin(), SWELL_BENCH_BIN);
	std::vector<char *> argv;
	for (auto &a : args)
		argv.push_back(&a[0]);
	argv.push_back(nullptr);
	posix_spawn_file_actions_t fa;
	posix_spawn_file_actions_init(&fa);
	posix_spawn_file_actions_addopen(&fa, 1, (log + ".out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	posix_spawn_file_actions_addopen(&fa, 2, (log + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	pid_t pid = -1;
	const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
	posix_spawn_file_actions_destroy(&fa);
	REQUIRE(rc == 0);
	int st = 0;
	waitpid(pid, &st, 0);
	Run r;
	r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
	r.out = slurp(log + ".out");
	r.err = slurp(log + ".err");
	return r;
}

int files_in(const std::string &dir)
{
	int n = 0;
	DIR *d = opendir(dir.c_str());
	if (!d)
		return -1;
	while (dirent *e = readdir(d))
		n += e->d_name[0] != '.';
	closedir(d);
	return n;
}

} // namespace

TEST_CASE("swell-bench: bad arguments exit 2 with one line before any run, --replot without results exits 1 "
	  "and writes nothing",
	  "[bench][args]")
{
	char t[] = "/tmp/swell-bench-args-XXXXXX";
	REQUIRE(mkdtemp(t) != nullptr);
	const std::string dir = t, file = dir + "/a-file", empty = dir + "/empty", log = dir + "/log";
	std::ofstream(file) << "not a directory\n";
	REQUIRE(mkdir(empty.c_str(), 0777) == 0);
	const struct {
		std::vector<std::string> args;
		int code;
		const char *says;
	} cases[] = {
		{{"--bogus"}, 2, "unknown option --bogus"},
		{{"--steps"}, 2, "option --steps needs a value"},
		{{"--steps", "5"}, 2, "bad --steps '5'"},
		{{"--grids", "1"}, 2, "bad --grids list '1'"},
		{{"--e", "2.5"}, 2, "bad --e list '2.5'"},
		{{"--reps", "0"}, 2, "bad --reps '0'"},
		{{"--out", file}, 2, "is not a writable directory"},
		{{"--out", "/proc/swell-bench"}, 2, "cannot create /proc/swell-bench"},
		{{"--replot", "--out", empty}, 1, "matrix.csv is missing or empty (no results of a run to plot)"},
		{{"--replot", "--out", dir + "/nowhere"}, 2, "is not a writable directory"},
	};
	for (const auto &c : cases) {
		const Run r = run(c.args, log);
		std::string joined;
		for (const auto &a : c.args)
			joined += a + " ";
		INFO(joined << "-> exit " << r.code << ", stderr '" << r.err << "', stdout '" << r.out << "'");
		CHECK(r.code == c.code);
		CHECK(r.err.find(c.says) != std::string::npos);
		CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
		CHECK(r.out.empty()); /* nothing ran */
	}
	CHECK(files_in(empty) == 0); /* no 0-byte PNG, no plot script */
	std::system(("rm -rf '" + dir + "'").c_str());
}
