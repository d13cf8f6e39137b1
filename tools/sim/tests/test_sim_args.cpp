/* swell-sim's arguments: every bad value and conflicting pair exits 2 with one line that names it and
 * nothing on stdout; and a drop that never settles is not reported with a settling time. */
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

extern char **environ;

namespace {

std::string slurp(const std::string &path)
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

struct Run {
	int code = -1;
	std::string out, err;
};

Run run(std::vector<std::string> args)
{
	const std::string base = "/tmp/swell-sim-args-" + std::to_string(getpid());
	args.insert(args.begin(), SWELL_SIM_BIN);
	std::vector<char *> argv;
	for (auto &a : args)
		argv.push_back(&a[0]);
	argv.push_back(nullptr);
	posix_spawn_file_actions_t fa;
	posix_spawn_file_actions_init(&fa);
	posix_spawn_file_actions_addopen(&fa, 1, (base + ".out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	posix_spawn_file_actions_addopen(&fa, 2, (base + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	pid_t pid = -1;
	const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
	posix_spawn_file_actions_destroy(&fa);
	REQUIRE(rc == 0);
	int st = 0;
	waitpid(pid, &st, 0);
	Run r;
	r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
	r.out = slurp(base + ".out");
	r.err = slurp(base + ".err");
	std::remove((base + ".out").c_str());
	std::remove((base + ".err").c_str());
	return r;
}

} // namespace

TEST_CASE("swell-sim: every bad argument and conflicting pair exits 2 with one line naming it", "[sim][args]")
{
	const struct {
		std::vector<std::string> args;
		const char *says;
	} cases[] = {
		{{"--e", "-0.1"}, "--e -0.1 is outside (0, 2)"},
		{{"--e", "0"}, "--e 0 is outside (0, 2)"},
		{{"--e", "0.5"}, "stability limit"},
		{{"--dt", "-0.004", "--depth", "0.05", "--dx", "0.00625"}, "--dt -0.004 s is outside"},
		{{"--dt", "0.004", "--depth", "-0.05", "--dx", "0.00625"}, "--depth -0.05 m is outside"},
		{{"--dt", "0.004", "--depth", "0.05", "--dx", "-0.00625"}, "--dx -0.00625 m is outside"},
		{{"--dt", "0.004", "--depth", "0.05", "--dx", "0.00625", "--g", "-9.81"}, "--g -9.81 m/s^2 is outside"},
		{{"--dt", "-1"}, "--dt -1 s is outside"},
		{{"--dt", "0.004"}, "needs all of --dt, --depth and --dx (missing --depth)"},
		{{"--dt", "0.004", "--depth", "0.05"}, "(missing --dx)"},
		{{"--e", "0.2", "--depth", "0.05"}, "--e and --depth both set e"},
		{{"--damping", "1"}, "--damping 1 is outside [0, 1)"},
		{{"--damping", "-0.1"}, "--damping -0.1 is outside [0, 1)"},
		{{"--grid", "1x64"}, "--grid 1x64: each side must be in"},
		{{"--grid", "64y64"}, "--grid: '64y64' is not NXxNY"},
		{{"--steps", "-1"}, "--steps: '-1' is not a whole number"},
		{{"--steps", "1.5"}, "--steps: '1.5' is not a whole number"},
		{{"--stencil", "fancy"}, "--stencil: 'fancy' is neither paper nor calibrated"},
		{{"--init", "wave"}, "--init: 'wave' is not zero"},
		{{"--impl", "double"}, "--impl: 'double' is neither fixed nor float64"},
		{{"--e", "abc"}, "--e: 'abc' is not a number"},
		{{"--bogus", "1"}, "unknown option '--bogus'"},
		{{"stray"}, "unexpected argument 'stray'"},
		{{"--steps"}, "--steps needs a value"},
		{{"--bogus"}, "unknown option '--bogus'"}, // no value after it: still unknown, not "needs a value"
		{{"--damper"}, "--damper needs a value"}, // an option of --object's
		{{"--motion", "drop:0.02"}, "--motion is an option of the floating object: give --object too"},
		{{"--at", "0.1,0.1"}, "--at is an option of the floating object"},
		{{"--trace", "x.csv"}, "--trace is an option of the floating object"},
		{{"--object", "0.06,0.06,0.04"}, "too few values"},
	};
	for (const auto &c : cases) {
		std::vector<std::string> args = c.args;
		if (c.args.size() == 1 && c.args[0].rfind("--", 0) == 0)
			args = c.args; /* a value-less option stands last */
		else
			args.insert(args.end(), {"--steps", "1"});
		const Run r = run(args);
		std::string joined;
		for (const auto &a : c.args)
			joined += a + " ";
		INFO(joined << "-> exit " << r.code << ", stderr '" << r.err << "', stdout '" << r.out << "'");
		CHECK(r.code == 2);
		CHECK(r.err.find(c.says) != std::string::npos);
		CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
		CHECK(r.out.empty());
	}
}

TEST_CASE("swell-sim: a drop that has not settled by the end of the run gives no settling time", "[sim][object]")
{
	/* 0.2 s: the box is still falling through the surface at the end */
	const Run r = run({"--init", "zero", "--steps", "50", "--object", "0.06,0.06,0.04,0.06", "--motion", "drop:0.02"});
	INFO(r.out << r.err);
	CHECK(r.code == 0);
	CHECK(r.out.find("settling        none: still outside 2 % of m g / k at the end") != std::string::npos);
	CHECK(r.out.find("s to stay within 2 %") == std::string::npos);
}
