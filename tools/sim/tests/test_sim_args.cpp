/* swell-sim's arguments: every bad value and conflicting pair exits 2 with one line that names it and
 * nothing on stdout; and a drop that never settles is not reported with a settling time. */
#include "swell_test.hpp"

#include <string>
#include <vector>

TEST_CASE("swell-sim: every bad argument and conflicting pair exits 2 with one line naming it", "[sim][args]")
{
	const std::vector<swell_test::BadArgs> cases = {
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
		{{"--steps", "-1"}, "--steps '-1' is not a whole number"},
		{{"--steps", "1.5"}, "--steps '1.5' is not a whole number"},
		{{"--stencil", "fancy"}, "--stencil 'fancy' is not paper or calibrated"},
		{{"--init", "wave"}, "--init: 'wave' is not zero"},
		{{"--impl", "double"}, "--impl 'double' is not fixed or float64"},
		{{"--e", "abc"}, "--e 'abc' is not a number"},
		{{"--bogus", "1"}, "unknown option '--bogus'"},
		{{"stray"}, "unexpected argument 'stray'"},
		{{"--steps"}, "--steps needs a value"},
		{{"--bogus"}, "unknown option '--bogus'"}, // no value after it: still unknown, not "needs a value"
		{{"--damper"}, "--damper needs a value"}, // an option of --object's
		{{"--motion", "drop:0.02"}, "--motion is an option of the floating object: give --object too"},
		{{"--at", "0.1,0.1"}, "--at is an option of the floating object"},
		{{"--trace", "x.csv"}, "--trace is an option of the floating object"},
		{{"--object", "0.06,0.06,0.04"}, "--object '0.06,0.06,0.04' is not 4 comma-separated numbers"},
	};
	/* each with a short run after it, but a value-less option stands last */
	std::vector<swell_test::BadArgs> with_steps, last;
	for (const auto &c : cases)
		(c.args.size() == 1 && c.args[0].rfind("--", 0) == 0 ? last : with_steps).push_back(c);
	swell_test::check_bad_args(SWELL_SIM_BIN, with_steps, {"--steps", "1"});
	swell_test::check_bad_args(SWELL_SIM_BIN, last);
}

TEST_CASE("swell-sim: a drop that has not settled by the end of the run gives no settling time", "[sim][object]")
{
	/* 0.2 s: the box is still falling through the surface at the end */
	const swell_test::Run r = swell_test::run(
		{SWELL_SIM_BIN, "--init", "zero", "--steps", "50", "--object", "0.06,0.06,0.04,0.06", "--motion", "drop:0.02"});
	INFO(r.out << r.err);
	CHECK(r.code == 0);
	CHECK(r.out.find("settling        none: still outside 2 % of m g / k at the end") != std::string::npos);
	CHECK(r.out.find("s to stay within 2 %") == std::string::npos);
}
