// swell-flash's arguments: every bad one exits 2 with one line naming it before any tool runs or any
// link is opened; --help exits 0 and documents the exit statuses.
#include "swell_test.hpp"

TEST_CASE("swell-flash: every bad argument and conflicting pair exits 2 with one line naming it", "[flash][args]")
{
	swell_test::check_bad_args(
		SWELL_FLASH_BIN,
		{
			{{}, "no image"},
			{{"a.elf", "b.elf"}, "b.elf"},
			{{"x.elf", "--backend", "jtag"}, "--backend 'jtag' is not dfu, swd, uart or gdb"},
			{{"x.elf", "--mcu", "f405"}, "--mcu 'f405' is not a whole number"},
			{{"x.elf", "--dfu-device", "0483"}, "--dfu-device '0483' is not VID:PID"},
			{{"x.elf", "--swd-tool", "jlink"}, "--swd-tool 'jlink' is not openocd or st-flash"},
			{{"x.elf", "--baud", "12"}, "--baud '12' is not a whole number in [1200, 4000000] bit/s"},
			{{"x.elf", "--gdb-server", "lldb"}, "--gdb-server 'lldb' is not openocd, qemu or bmp"},
			{{"x.elf", "--console-timeout", "0"}, "--console-timeout '0' is not a number in (0, 600] s"},
			{{"x.elf", "--node", "16"}, "--node '16' is not a whole number in [0, 15]"},
			{{"x.elf", "--iface", "300"}, "--iface '300' is not a whole number in [0, 255]"},
			{{"x.elf", "--find-timeout", "-1"}, "--find-timeout '-1' is not a number in (0, 600] s"},
			{{"x.elf", "--dfu-wait", "61"}, "--dfu-wait '61' is not a number in [0, 60] s"},
			{{"x.elf", "--enter-bootloader", "tcp:1"}, "tcp:1"},
			{{"x.elf", "--enter-bootloader", "udp:70000"}, "udp:70000"},
			{{"x.elf", "--enter-bootloader", "can:"}, "can:"},
			{{"x.elf", "--find", "usb:xyz"}, "usb:xyz"},
			{{"x.elf", "--iface", "1", "--enter-bootloader", "udp"}, "--iface is for a usb link"},
			{{"x.elf", "--node", "3"}, "--node is for --enter-bootloader or --find"},
			{{"x.elf", "--bogus"}, "--bogus"},
			{{"x.elf", "--backend"}, "--backend"},
			{{"/nonexistent/image.elf"}, "/nonexistent/image.elf"},
		});
}

TEST_CASE("swell-flash: --help exits 0 and documents the exit statuses", "[flash][args]")
{
	swell_test::check_help(SWELL_FLASH_BIN);
}
