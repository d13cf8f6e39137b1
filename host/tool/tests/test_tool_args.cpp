// swell-tool's arguments: every bad one exits 2 with one line naming it before the link is opened
// (no controller is needed, nothing waits for one); --help exits 0 and documents the exit statuses.
#include "swell_test.hpp"

TEST_CASE("swell-tool: every bad argument and conflicting pair exits 2 with one line naming it", "[tool][args]")
{
	swell_test::check_bad_args(
		SWELL_TOOL_BIN,
		{
			{{}, "no command given"},
			{{"fly"}, "unknown command 'fly'"},
			{{"get"}, "get takes one parameter name"},
			{{"get", "a", "b"}, "get takes one parameter name"},
			{{"get", "body.nothing"}, "no parameter 'body.nothing'"},
			{{"set", "body.mass"}, "set takes a parameter name and a value"},
			{{"set", "body.nothing", "1"}, "no parameter 'body.nothing'"},
			{{"set", "body.mass", "80parsec"}, "body.mass: unit 'parsec' is not g"},
			{{"status", "now"}, "status takes no words after it"},
			{{"run", "fast"}, "run takes no words after it"},
			{{"log"}, "log takes one file name"},
			{{"plot"}, "plot takes one CSV file"},
			{{"scene", "load"}, "scene takes load FILE or save FILE"},
			{{"scene", "drop", "x.scene"}, "scene takes load FILE or save FILE"},
			{{"run", "--json"}, "--json is an option of status, not of run"},
			{{"status", "--seconds", "2"}, "--seconds is an option of watch and log"},
			{{"status", "--out", "x.png"}, "--out is an option of plot"},
			{{"watch", "--seconds", "0"}, "--seconds '0' is not a number in (0, 86400] s"},
			{{"status", "--node", "16"}, "--node '16' is not a whole number in [0, 15]"},
			{{"status", "--timeout-ms", "0"}, "--timeout-ms '0' is not a whole number in [1, 600000] ms"},
			{{"status", "--link", "tcp:1"}, "tcp:1"},
			{{"status", "--link", "udp:70000"}, "udp:70000"},
			{{"status", "--link", "can:"}, "can:"},
			{{"status", "--link", "usb:1209"}, "usb:1209"},
			{{"status", "--bogus", "1"}, "unknown option '--bogus'"},
			{{"status", "--node"}, "--node needs a value"},
			{{"status", "--hm", "127.0.0.1"}, "--hm, --max-force, --max-rate and --max-rtt-ms are options of check"},
			{{"check", "--max-force", "abc"}, "--max-force 'abc' is not a number in (0, 1000000] N"},
			{{"check", "--max-rate", "0"}, "--max-rate '0' is not a number in (0, 1000000] N/s"},
			{{"check", "now"}, "check takes no words after it"},
			{{"set", "dev.rate", "5"}, "dev.rate is read only"},
		});
}

TEST_CASE("swell-tool: --help exits 0 and documents the exit statuses", "[tool][args]")
{
	swell_test::check_help(SWELL_TOOL_BIN);
}
