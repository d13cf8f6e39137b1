// swell-hmbridge's arguments: every bad one exits 2 with one line naming it before anything is
// connected; --help exits 0 and documents the exit statuses.
#include "swell_test.hpp"

TEST_CASE("swell-hmbridge: every bad argument exits 2 with one line naming it", "[hmbridge][args]")
{
	swell_test::check_bad_args(SWELL_HMBRIDGE_BIN,
				   {
					   {{}, "--hm HOST[:PORT] is required"},
					   {{"--hm", "host:99999"}, "host:99999"},
					   {{"--hm", "127.0.0.1:port"}, "127.0.0.1:port"},
					   {{"--hm", ""}, "--hm needs HOST[:PORT], not an empty word"},
					   {{"--hm", "127.0.0.1", "--link", "tcp"},
					    "--link 'tcp': not a link: udp[:PORT], can:IFACE, usb[:VID:PID]"},
					   {{"--hm", "127.0.0.1", "--link", "can:"}, "--link 'can:': give the CAN interface"},
					   {{"--hm", "127.0.0.1", "--host", "localhost"}, "--host 'localhost' is not a dotted"},
					   {{"--hm", "127.0.0.1", "--port", "0"}, "--port '0' is not a whole number"},
					   {{"--hm", "127.0.0.1", "--bind-port", "65536"}, "--bind-port '65536'"},
					   {{"--hm", "127.0.0.1", "--node", "16"}, "--node '16'"},
					   {{"--hm", "127.0.0.1", "--rate", "50"}, "--rate '50'"},
					   {{"--hm", "127.0.0.1", "--watchdog", "1.5"}, "--watchdog '1.5'"},
					   {{"--hm", "127.0.0.1", "--effect-fresh", "0"}, "--effect-fresh '0'"},
					   {{"--hm", "127.0.0.1", "--seconds", "x"}, "--seconds 'x'"},
					   {{"--hm", "127.0.0.1", "--bogus", "1"}, "unknown option '--bogus'"},
					   {{"--hm", "127.0.0.1", "stray"}, "unexpected argument 'stray'"},
					   {{"--hm", "127.0.0.1", "--port"}, "--port"},
				   });
}

TEST_CASE("swell-hmbridge: --help exits 0 and documents the exit statuses", "[hmbridge][args]")
{
	swell_test::check_help(SWELL_HMBRIDGE_BIN);
}
