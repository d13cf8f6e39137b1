/* swell-bench's arguments: bad ones exit 2 with one line before any measuring, --replot without
 * results exits 1 and writes no plot. */
#include "swell_test.hpp"

#include <dirent.h>
#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace {

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
	const std::vector<swell_test::BadArgs> cases = {
		{{"--bogus"}, "unknown option '--bogus'", 2},
		{{"--steps"}, "--steps needs a value", 2},
		{{"--steps", "5"}, "--steps '5' is not a whole number in [20, 10000000]", 2},
		{{"--grids", "1"}, "--grids '1' is not 1 to 16 comma-separated numbers in [2, 1024] cells", 2},
		{{"--e", "2.5"}, "--e '2.5' is not 1 to 16 comma-separated numbers in [1e-06, 1.999]", 2},
		{{"--grids", "64.5"}, "--grids '64.5' is not whole numbers", 2},
		{{"--reps", "0"}, "--reps '0' is not a whole number in [1, 1000]", 2},
		{{"--out", file}, "is not a writable directory", 2},
		{{"--out", "/proc/swell-bench"}, "cannot create /proc/swell-bench", 2},
		{{"--replot", "--out", empty}, "matrix.csv is missing or empty (no results of a run to plot)", 1},
		{{"--replot", "--out", dir + "/nowhere"}, "is not a writable directory", 2},
	};
	swell_test::check_bad_args(SWELL_BENCH_BIN, cases); /* and nothing ran: stdout empty */
	CHECK(files_in(empty) == 0); /* no 0-byte PNG, no plot script */
	std::system(("rm -rf '" + dir + "'").c_str());
}
