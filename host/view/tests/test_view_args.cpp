// swell-view's arguments: every bad one exits 2 with one line naming it, before any window opens
// (no display is needed); --help exits 0 and documents the exit statuses.
#include "swell_test.hpp"

TEST_CASE("swell-view: every bad argument and conflicting pair exits 2 with one line naming it", "[view][args]")
{
	swell_test::check_bad_args(SWELL_VIEW_BIN,
				   {
					   {{"--size", "10x10"}, "--size '10x10' is not WxH"},
					   {{"--size", "1024"}, "--size '1024' is not WxH"},
					   {{"--size", "1024x768x3"}, "--size '1024x768x3' is not WxH"},
					   {{"--view", "side"}, "--view 'side' is not orbit, top or map"},
					   {{"--object", "50x50"}, "--object '50x50' is not AxBxH"},
					   {{"--object", "0x50x50"}, "--object '0x50x50' is not AxBxH"},
					   {{"--node", "16"}, "--node"},
					   {{"--node", "-1"}, "--node"},
					   {{"--iface", "256"}, "--iface"},
					   {{"--after", "x"}, "--after"},
					   {{"--frames", "-3"}, "--frames"},
					   {{"--fps", "0"}, "--fps"},
					   {{"--msaa", "17"}, "--msaa"},
					   {{"--range", "0"}, "--range"},
					   {{"--zscale", "nan"}, "--zscale"},
					   {{"--force-limit", "-1"}, "--force-limit"},
					   {{"--stale-ms", "0"}, "--stale-ms"},
					   {{"--source", "tcp:1"}, "'tcp:1': not a link: udp[:PORT]"},
					   {{"--source", "udp:99999"}, "'udp:99999': UDP port not in 1..65535"},
					   {{"--source", "udp:port"}, "'udp:port': UDP port not in 1..65535"},
					   {{"--source", "can:"}, "'can:': give the CAN interface"},
					   {{"--source", "usb:12"}, "'usb:12': not usb:VID:PID in hex"},
					   {{"--source", "usb:zzzz:0001"}, "'usb:zzzz:0001': not usb:VID:PID"},
					   {{"--source", "replay:"}, "'replay:': give the recording"},
					   {{"--source", "replay:/nonexistent/rec"}, "/nonexistent/rec"},
					   {{"--source", "pattern:waves"}, "unknown pattern 'waves'"},
					   {{"--source", "pattern:bump:3"}, "pattern"},
					   {{"--faults", "drop", "--source", "udp"}, "--faults applies to pattern sources only"},
					   {{"--source", "pattern:bump", "--faults", "fire"}, "fire"},
					   {{"--record", "x.rec", "--source", "pattern:bump"}, "--record"},
					   {{"--bogus"}, "unknown option '--bogus'"},
					   {{"stray"}, "stray"},
					   {{"--size"}, "--size needs a value"},
				   });
}

TEST_CASE("swell-view: --help exits 0 and documents the exit statuses", "[view][args]")
{
	swell_test::check_help(SWELL_VIEW_BIN);
}
