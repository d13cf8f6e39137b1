// swell-linktest's arguments: every bad one exits 2 with one line naming it before a link is opened;
// --help exits 0 and documents the exit statuses.
#include "swell_test.hpp"

TEST_CASE("swell-linktest: every bad argument exits 2 with one line naming it", "[links][args]")
{
	swell_test::check_bad_args(SWELL_LINKTEST_BIN,
				   {
					   {{"fly"}, "unknown command or wrong arguments: 'fly'"},
					   {{"can-pair", "vcan0"}, "'can-pair'"},
					   {{"replay"}, "'replay'"},
					   {{"udp-pair", "extra"}, "'udp-pair'"},
					   {{"udp-pair", "--count", "0"}, "--count '0' is not a whole number"},
					   {{"udp-pair", "--count", "ten"}, "--count 'ten'"},
					   {{"udp-pair", "--timeout", "0"}, "--timeout '0'"},
					   {{"usb-echo", "--vid", "xyz"}, "--vid 'xyz' is not a hexadecimal number"},
					   {{"usb-echo", "--pid", "10000"}, "--pid '10000'"},
					   {{"usb-echo", "--iface", "256"}, "--iface '256'"},
					   {{"can-pair", "a", "b", "--bitrate", "5"}, "--bitrate '5'"},
					   {{"udp-pair", "--bogus", "1"}, "--bogus"},
					   {{"udp-pair", "--count"}, "--count needs a value"},
					   {{"a", "b", "c", "d"}, "unexpected argument 'd'"},
					   {{"--fd"}, "no command given"},
				   });
}

TEST_CASE("swell-linktest: --help exits 0 and documents the exit statuses", "[links][args]")
{
	swell_test::check_help(SWELL_LINKTEST_BIN);
}
