// swell-flash: image checks, the command lines of every backend, and the program run with stub
// tools on PATH (the stubs record every invocation: a refused image must leave no record).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

extern "C" {
#include "flash_image.h"
#include "swell/link_client.h"
#include "flash_plan.h"
}

extern char **environ;

namespace {

using bytes = std::vector<uint8_t>;

void put32(uint8_t *p, uint32_t v)
{
	for (int i = 0; i < 4; i++)
		p[i] = (uint8_t)(v >> (8 * i));
}

// A stamped image of len bytes: a pseudo-random body and the header at 0x200.
bytes make_image(size_t len, uint32_t version = SWELL_FWIMAGE_VERSION(1, 2, 3), uint32_t mcu = SWELL_FWIMAGE_MCU_STM32F405)
{
	bytes b(len);
	uint32_t x = 12345;
	for (auto &v : b) {
		x = x * 1103515245u + 12345u;
		v = (uint8_t)(x >> 16);
	}
	uint8_t *h = b.data() + SWELL_FWIMAGE_OFFSET;
	std::memset(h, 0, SWELL_FWIMAGE_HDR_SIZE);
	put32(h, SWELL_FWIMAGE_MAGIC);
	h[4] = SWELL_FWIMAGE_HDR_VERSION;
	h[6] = SWELL_FWIMAGE_HDR_SIZE;
	put32(h + 8, mcu);
	put32(h + 12, version);
	REQUIRE(swell_fwimage_stamp(b.data(), b.size()) == SWELL_OK);
	return b;
}

// A minimal ELF32 executable for `machine` with the image in one PT_LOAD segment at paddr and a
// second, file-less segment (.bss-like) in RAM.
bytes make_elf(const bytes &img, uint32_t paddr = FLASH_BASE_ADDR, uint16_t machine = 40)
{
	const uint32_t phoff = 52, off = 52 + 2 * 32;
	bytes e(off + img.size(), 0);
	std::memcpy(e.data(), "\177ELF", 4);
	e[4] = 1; // 32-bit
	e[5] = 1; // little-endian
	e[6] = 1;
	e[16] = 2; // ET_EXEC
	e[18] = (uint8_t)machine;
	e[19] = (uint8_t)(machine >> 8);
	put32(&e[20], 1);
	put32(&e[24], paddr + 0x101);
	put32(&e[28], phoff);
	e[40] = 52;
	e[42] = 32;
	e[44] = 2;
	uint8_t *ph = &e[phoff];
	put32(ph, 1);
	put32(ph + 4, off);
	put32(ph + 8, paddr);
	put32(ph + 12, paddr);
	put32(ph + 16, (uint32_t)img.size());
	put32(ph + 20, (uint32_t)img.size());
	ph += 32;
	put32(ph, 1);
	put32(ph + 8, 0x20000000u);
	put32(ph + 12, 0x20000000u);
	put32(ph + 20, 4096); // memsz only
	std::memcpy(&e[off], img.data(), img.size());
	return e;
}

std::string check(const bytes &f, uint32_t mcu = SWELL_FWIMAGE_MCU_STM32F405)
{
	flash_image img;
	char why[512] = "";
	if (flash_image_check(f.data(), f.size(), mcu, &img, why, sizeof(why)) == 0) {
		flash_image_free(&img);
		return "ok";
	}
	return why;
}

} // namespace

TEST_CASE("a stamped BIN and its ELF pass and give the same flash bytes and header")
{
	bytes bin = make_image(5000);
	bytes elf = make_elf(bin);
	flash_image a, b;
	char why[512] = "";
	REQUIRE(flash_image_check(bin.data(), bin.size(), 0x413, &a, why, sizeof(why)) == 0);
	INFO(why);
	REQUIRE(flash_image_check(elf.data(), elf.size(), 0x413, &b, why, sizeof(why)) == 0);
	CHECK(a.fmt == FLASH_FMT_BIN);
	CHECK(b.fmt == FLASH_FMT_ELF);
	REQUIRE(a.len == bin.size());
	REQUIRE(b.len == bin.size());
	CHECK(std::memcmp(a.bytes, b.bytes, a.len) == 0);
	CHECK(a.hdr.version == SWELL_FWIMAGE_VERSION(1, 2, 3));
	CHECK(b.hdr.crc == a.hdr.crc);
	char v[32];
	flash_version_str(a.hdr.version, v, sizeof(v));
	CHECK(std::string(v) == "1.2.3");
	flash_image_free(&a);
	flash_image_free(&b);
}

TEST_CASE("every flipped byte of a BIN or an ELF image is refused")
{
	bytes bin = make_image(3001);
	size_t refused = 0, tried = 0;
	for (size_t i = 0; i < bin.size(); i += 7) {
		bytes c = bin;
		c[i] ^= 0x5A;
		std::string why = check(c);
		INFO("byte " << i << ": " << why);
		CHECK(why != "ok");
		refused += why != "ok";
		bytes e = make_elf(c);
		CHECK(check(e) != "ok");
		tried++;
	}
	CHECK(refused == tried);
	bytes c = bin;
	c[2000] ^= 1;
	CHECK(check(c).find("CRC-32 mismatch") != std::string::npos);
	// a zeroed header CRC is the header's fault, said with both numbers (was: an image CRC
	// "mismatch" of two equal numbers)
	bytes z = bin;
	for (size_t k = 0x200 + 28; k < 0x200 + 32; k++)
		z.at(k) = 0;
	const std::string why = check(z);
	INFO(why);
	CHECK(why.find("corrupted header: header CRC-32 0x00000000, computed 0x") != std::string::npos);
}

TEST_CASE("truncated images are refused with the length in the reason")
{
	bytes bin = make_image(4096);
	for (size_t n : {size_t(0), size_t(4), size_t(100), size_t(0x21f), size_t(0x220), size_t(4095)}) {
		bytes c(bin.begin(), bin.begin() + (long)n);
		std::string why = check(c);
		INFO("kept " << n << " bytes: " << why);
		CHECK(why.find("truncated") != std::string::npos);
	}
	// A BIN with bytes appended is not the image its header describes either.
	bytes longer = bin;
	longer.push_back(0);
	CHECK(check(longer).find("length mismatch") != std::string::npos);
	// An ELF cut inside its segment.
	bytes elf = make_elf(bin);
	elf.resize(elf.size() - 10);
	CHECK(check(elf).find("ELF truncated") != std::string::npos);
}

TEST_CASE("foreign images are refused: other MCU, other header, other machine, not flash, no header")
{
	CHECK(check(make_image(2048, SWELL_FWIMAGE_VERSION(1, 0, 0), 0x419)).find("foreign image: built for MCU 0x419") !=
	      std::string::npos);
	CHECK(check(make_image(2048), 0x419).find("foreign image") != std::string::npos);
	bytes bin = make_image(2048);
	CHECK(check(make_elf(bin, FLASH_BASE_ADDR, 62)).find("machine 62, not ARM") != std::string::npos);
	CHECK(check(make_elf(bin, 0x20000000u)).find("outside flash") != std::string::npos);
	bytes v2 = bin;
	v2[SWELL_FWIMAGE_OFFSET + 4] = 2;
	CHECK(check(v2).find("header version 2") != std::string::npos);
	bytes nomagic(2048, 0xFF);
	CHECK(check(nomagic).find("no swell image header") != std::string::npos);
	bytes flags = bin;
	put32(&flags[SWELL_FWIMAGE_OFFSET + 24], 1);
	REQUIRE(swell_fwimage_stamp(flags.data(), flags.size()) == SWELL_OK);
	CHECK(check(flags).find("flags") != std::string::npos);
}

namespace {

std::vector<std::string> plan_lines(const flash_opts &o)
{
	flash_plan p;
	char why[256] = "", line[8192];
	REQUIRE(flash_plan_build(&o, &p, why, sizeof(why)) == 0);
	std::vector<std::string> out;
	for (int i = 0; i < p.nsteps; i++) {
		flash_step_format(&p.step[i], line, sizeof(line));
		out.push_back(line);
	}
	return out;
}

flash_opts base_opts(flash_backend b)
{
	flash_opts o{};
	o.backend = b;
	o.bin = "/w/fw.bin";
	o.readback = "/w/rb.bin";
	o.len = 41424;
	o.dfu_device = "0483:df11";
	o.openocd_interface = "interface/stlink.cfg";
	o.serial = "/dev/ttyUSB0";
	o.baud = 115200;
	o.gdb_remote = "localhost:3333";
	return o;
}

} // namespace

TEST_CASE("dry-run command lines: dfu-util DfuSe at 0x08000000, read back, leave only at the end")
{
	auto l = plan_lines(base_opts(FLASH_DFU));
	REQUIRE(l.size() == 3);
	CHECK(l[0] == "dfu-util -d 0483:df11 -a 0 -s 0x08000000 -D /w/fw.bin");
	CHECK(l[1] == "dfu-util -d 0483:df11 -a 0 -s 0x08000000:41424 -U /w/rb.bin");
	CHECK(l[2] == "dfu-util -d 0483:df11 -a 0 -s 0x08000000:4:leave -U /w/rb.bin.leave");
}

TEST_CASE("dry-run command lines: SWD through openocd (ELF and BIN) and st-flash")
{
	flash_opts o = base_opts(FLASH_SWD);
	auto l = plan_lines(o);
	REQUIRE(l.size() == 1);
	CHECK(l[0] ==
	      "openocd -f interface/stlink.cfg -f target/stm32f4x.cfg -c "
	      "'program /w/fw.bin 0x08000000 verify reset exit'");
	o.elf = "/w/fw.elf";
	l = plan_lines(o);
	CHECK(l[0] == "openocd -f interface/stlink.cfg -f target/stm32f4x.cfg -c 'program /w/fw.elf verify reset exit'");
	o.swd_tool = FLASH_SWD_STFLASH;
	l = plan_lines(o);
	REQUIRE(l.size() == 3);
	CHECK(l[0] == "st-flash write /w/fw.bin 0x08000000");
	CHECK(l[1] == "st-flash read /w/rb.bin 0x08000000 41424");
	CHECK(l[2] == "st-flash reset");
}

TEST_CASE("dry-run command lines: stm32flash on the UART ROM bootloader")
{
	flash_opts o = base_opts(FLASH_UART);
	o.serial = "/dev/ttyACM3";
	o.baud = 57600;
	auto l = plan_lines(o);
	REQUIRE(l.size() == 3);
	CHECK(l[0] == "stm32flash -b 57600 -w /w/fw.bin -v -S 0x08000000 /dev/ttyACM3");
	CHECK(l[1] == "stm32flash -b 57600 -r /w/rb.bin -S 0x08000000:41424 /dev/ttyACM3");
	CHECK(l[2] == "stm32flash -b 57600 -g 0x08000000 /dev/ttyACM3");
}

TEST_CASE("dry-run command lines: gdb-multiarch on QEMU, openocd and a Black Magic Probe")
{
	flash_opts o = base_opts(FLASH_GDB);
	o.elf = "/w/fw.elf";
	o.gdb_server = FLASH_GDB_QEMU;
	o.gdb_remote = "127.0.0.1:1234";
	auto l = plan_lines(o);
	REQUIRE(l.size() == 2);
	CHECK(l[0] ==
	      "gdb-multiarch -nx -batch -ex 'set confirm off' -ex 'target remote 127.0.0.1:1234' -ex load "
	      "-ex 'dump binary memory /w/rb.bin 0x08000000 0x0800a1d0' -ex disconnect /w/fw.elf");
	CHECK(l[1] ==
	      "gdb-multiarch -nx -batch -ex 'set confirm off' -ex 'target remote 127.0.0.1:1234' "
	      "-ex 'monitor system_reset' -ex detach");
	o.gdb_server = FLASH_GDB_OPENOCD;
	l = plan_lines(o);
	CHECK(l[0].find("-ex 'monitor reset halt' -ex load") != std::string::npos);
	CHECK(l[1].find("-ex 'monitor reset run' -ex detach") != std::string::npos);
	o.gdb_server = FLASH_GDB_BMP;
	o.gdb_remote = "/dev/ttyACM0";
	l = plan_lines(o);
	CHECK(l[0].find("-ex 'target extended-remote /dev/ttyACM0' -ex 'monitor swdp_scan' -ex 'attach 1' -ex load") !=
	      std::string::npos);
	CHECK(l[1].find("-ex kill") != std::string::npos);
	// A BIN goes to QEMU with restore; openocd and a probe need the ELF.
	o.elf = nullptr;
	o.gdb_server = FLASH_GDB_QEMU;
	l = plan_lines(o);
	CHECK(l[0].find("-ex 'restore /w/fw.bin binary 0x08000000'") != std::string::npos);
	// gdb 13 cuts restore's file name at a blank and does not parse quotes: refused, not mangled
	flash_plan q;
	char qwhy[256] = "";
	o.bin = "/w/my fw.bin";
	CHECK(flash_plan_build(&o, &q, qwhy, sizeof(qwhy)) == -1);
	CHECK(std::string(qwhy).find("cannot hand '/w/my fw.bin' to gdb") != std::string::npos);
	o.bin = "/w/fw\"x.bin";
	CHECK(flash_plan_build(&o, &q, qwhy, sizeof(qwhy)) == -1);
	o.bin = "/w/fw.bin";
	o.gdb_server = FLASH_GDB_OPENOCD;
	flash_plan p;
	char why[256] = "";
	CHECK(flash_plan_build(&o, &p, why, sizeof(why)) == -1);
	CHECK(std::string(why).find("needs the ELF") != std::string::npos);
}

// ---- the program, with stub tools that record their invocation ----

namespace {

std::string slurp(const std::string &path)
{
	std::ifstream f(path);
	std::stringstream ss;
	ss << f.rdbuf();
	return ss.str();
}

struct scratch {
	std::string dir;
	scratch()
	{
		char t[] = "/tmp/swell-flash-test.XXXXXX";
		REQUIRE(mkdtemp(t) != nullptr);
		dir = t;
		mkdir((dir + "/stub").c_str(), 0755);
		// Every tool a backend may run: log the call; st-flash keeps a "flash" file so a
		// full run can be verified, and corrupts its read-back when CORRUPT is set.
		for (const char *tool : {"dfu-util", "openocd", "stm32flash", "gdb-multiarch"})
			stub(tool, "");
		// Its reset starts $ON_RESET in the background when set: "the new image" (a swell-ctl).
		stub("st-flash",
		     "case $1 in write) cp \"$2\" \"$FLASH\";; read) cp \"$FLASH\" \"$2\";"
		     " [ -n \"$CORRUPT\" ] && printf X | dd of=\"$2\" bs=1 seek=1000 conv=notrunc 2>/dev/null;;"
		     " reset) [ -z \"$ON_RESET\" ] || sh -c \"$ON_RESET\" </dev/null >/dev/null 2>&1 & ;; esac\n");
	}
	~scratch() { std::system(("rm -rf '" + dir + "'").c_str()); }
	void stub(const std::string &tool, const std::string &body)
	{
		std::string p = dir + "/stub/" + tool;
		std::ofstream f(p);
		f << "#!/bin/sh\necho \"" << tool << " $*\" >> \"$LOG\"\n" << body << "exit 0\n";
		f.close();
		chmod(p.c_str(), 0755);
	}
	std::string write(const std::string &name, const bytes &b)
	{
		std::string p = dir + "/" + name;
		std::ofstream f(p, std::ios::binary);
		f.write((const char *)b.data(), (std::streamsize)b.size());
		return p;
	}
	std::string log() const { return slurp(dir + "/log"); }
	// Run swell-flash with the stubs first on PATH; returns the exit status, output in *out.
	int run(const std::string &args, std::string *out, const std::string &env = "")
	{
		std::string cmd = "cd '" + dir + "' && PATH='" + dir + "/stub':\"$PATH\" LOG='" + dir + "/log' FLASH='" + dir +
			"/flash' " + env + " '" SWELL_FLASH_BIN "' " + args + " >out.txt 2>&1";
		int st = std::system(cmd.c_str());
		std::ifstream f(dir + "/out.txt");
		std::stringstream s;
		s << f.rdbuf();
		*out = s.str();
		return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
	}
};

} // namespace

TEST_CASE("corrupted, truncated and foreign images are refused with exit 2 before any tool runs")
{
	scratch s;
	bytes good = make_image(6000);
	bytes corrupt = good;
	corrupt[4321] ^= 0x10;
	bytes truncated(good.begin(), good.begin() + 3000);
	bytes foreign = make_image(6000, SWELL_FWIMAGE_VERSION(1, 2, 3), 0x419);
	struct {
		const char *name;
		bytes b;
		const char *reason;
	} bad[] = {{"corrupt.bin", corrupt, "CRC-32 mismatch"}, {"corrupt.elf", make_elf(corrupt), "CRC-32 mismatch"},
		   {"truncated.bin", truncated, "truncated"},   {"truncated.elf", make_elf(truncated), "truncated"},
		   {"foreign.bin", foreign, "foreign image"},   {"x86.elf", make_elf(good, FLASH_BASE_ADDR, 62), "foreign ELF"}};
	const char *backends[] = {"--backend dfu",
				  "--backend swd",
				  "--backend swd --swd-tool st-flash",
				  "--backend uart",
				  "--backend gdb --gdb-server qemu",
				  ""};
	for (auto &b : bad) {
		std::string path = s.write(b.name, b.b);
		for (const char *be : backends) {
			std::string out;
			int rc = s.run(path + " " + be, &out);
			INFO(b.name << " " << be << ": exit " << rc << ", output: " << out);
			CHECK(rc == 2);
			CHECK(out.find("refused") != std::string::npos);
			CHECK(out.find(b.reason) != std::string::npos);
			// One line of reason, nothing else.
			CHECK(std::count(out.begin(), out.end(), '\n') == 1);
		}
	}
	CHECK(s.log().empty());
	// The stubs do record when a tool is reached (positive control): a good image runs them.
	std::string out;
	int rc = s.run(s.write("good.bin", good) + " --backend swd --swd-tool st-flash", &out);
	INFO(out);
	CHECK(rc == 0);
	CHECK(s.log().find("st-flash write") != std::string::npos);
}

TEST_CASE("a full run verifies the read-back and starts only a verified image")
{
	scratch s;
	std::string img = s.write("good.elf", make_elf(make_image(6000)));
	std::string out;
	int rc = s.run(img + " --backend swd --swd-tool st-flash", &out);
	INFO(out);
	REQUIRE(rc == 0);
	CHECK(out.find("verify ok: 6000 bytes") != std::string::npos);
	CHECK(out.find("[3/3] reset") != std::string::npos);
	std::string log = s.log();
	CHECK(log.find("st-flash write") < log.find("st-flash read"));
	CHECK(log.find("st-flash read") < log.find("st-flash reset"));

	scratch t;
	img = t.write("good.elf", make_elf(make_image(6000)));
	rc = t.run(img + " --backend swd --swd-tool st-flash", &out, "CORRUPT=1");
	INFO(out);
	CHECK(rc == 1);
	CHECK(out.find("verify FAILED at 0x080003e8") != std::string::npos);
	CHECK(t.log().find("st-flash reset") == std::string::npos);
}

TEST_CASE("the dry run prints the commands of each backend and runs none")
{
	scratch s;
	std::string img = s.write("good.elf", make_elf(make_image(6000)));
	struct {
		const char *args, *expect;
	} cases[] = {{"--backend dfu", "dfu-util -d 0483:df11 -a 0 -s 0x08000000 -D "},
		     {"--backend swd", "-c 'program "},
		     {"--backend swd --swd-tool st-flash", "st-flash write "},
		     {"--backend uart --serial /dev/ttyS1", "stm32flash -b 115200 -w "},
		     {"--backend gdb --gdb-remote localhost:3333", "-ex 'monitor reset halt' -ex load"},
		     {"--backend gdb --gdb-remote /dev/ttyACM0", "-ex 'monitor swdp_scan'"}};
	for (auto &c : cases) {
		std::string out;
		int rc = s.run(img + " --dry-run --work-dir /w " + c.args, &out);
		INFO(c.args << ": " << out);
		CHECK(rc == 0);
		CHECK(out.find(c.expect) != std::string::npos);
		CHECK(out.find("[1/") != std::string::npos);
	}
	CHECK(s.log().empty());
}

TEST_CASE("bad arguments give one line and exit 2")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	const char *bad[] = {"",
			     "--backend jtag",
			     "--swd-tool jlink",
			     "--baud 12",
			     "--mcu x",
			     "--dfu-device 0483",
			     "--frobnicate",
			     "--gdb-server foo",
			     "--console-timeout 0",
			     "second.bin",
			     "--backend"};
	for (const char *a : bad) {
		std::string out;
		int rc = s.run((*a == '\0' ? std::string() : img + " ") + a, &out);
		INFO("'" << a << "': " << out);
		CHECK(rc == 2);
		CHECK(std::count(out.begin(), out.end(), '\n') == 1);
	}
	std::string out;
	CHECK(s.run("--help", &out) == 0);
	CHECK(out.find("usage: swell-flash") != std::string::npos);
	CHECK(s.run(img + " --expect-version 9.9.9", &out) == 2);
	CHECK(out.find("version 1.2.3, expected 9.9.9") != std::string::npos);
	CHECK(s.log().empty());
}

TEST_CASE("auto-detection reads USB ids from sysfs and refuses to guess")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	auto dev = [&](const std::string &name, const char *vid, const char *pid) {
		std::string d = s.dir + "/sys/bus/usb/devices/" + name;
		std::system(("mkdir -p '" + d + "'").c_str());
		std::ofstream(d + "/idVendor") << vid << "\n";
		std::ofstream(d + "/idProduct") << pid << "\n";
	};
	std::string env = "SWELL_FLASH_SYSFS='" + s.dir + "/sys'", out;
	dev("1-1", "1d6b", "0002"); // a root hub: not a target
	CHECK(s.run(img + " --dry-run", &out, env) == 2);
	CHECK(out.find("no DfuSe device") != std::string::npos);
	dev("1-2", "0483", "df11");
	CHECK(s.run(img + " --dry-run", &out, env) == 0);
	CHECK(out.find("auto-detected a DfuSe bootloader") != std::string::npos);
	CHECK(out.find("dfu-util -d 0483:df11") != std::string::npos);
	dev("1-3", "0483", "374b");
	CHECK(s.run(img + " --dry-run", &out, env) == 2);
	CHECK(out.find("choose one") != std::string::npos);
	CHECK(s.log().empty());
}

// ---- enter-bootloader over the UDP host link, against a scripted controller ----

#include <atomic>
#include <thread>

extern "C" {
#include "swell/link.h"
}

namespace {

// A controller as seen on its host link: it listens on `port` (its clients' port) and sends to the
// last sender, heartbeats every 50 ms in `state`, and CTL_INFO with `version` with every 4th; a
// client's HEARTBEAT is its keep-alive and nothing else; PARAM_SET COMMAND=STOP leaves RUNNING;
// ENTER_BOOTLOADER stops the heartbeat when `reboots`, for `back_ms` (then it beats again: "the new
// image"). A `twin` is a second controller (another node) on the same port, served by this one's
// thread.
struct fake_ctl {
	uint16_t port = 0;
	std::atomic<int> state{1}, got_stop{0}, got_autorun_off{0}, got_boot{0}, boot_key_ok{0}, other{0};
	uint8_t node = 0;
	bool reboots = true;
	uint64_t back_ms = 1400;
	uint8_t version[3] = {1, 2, 3};
	fake_ctl *twin = nullptr;
	std::atomic<bool> quit{false};
	std::thread th;
	swell_link *l = nullptr;
	uint8_t seq = 0;
	bool silent = false;
	uint64_t next = 0, silent_since = 0;

	static uint16_t free_port()
	{
		swell_link *l;
		REQUIRE(swell_link_open_udp(&l, "127.0.0.1", 0, "127.0.0.1", 9) == 0);
		uint16_t p = swell_link_udp_port(l);
		swell_link_close(l);
		return p;
	}
	void start(int st, bool reb)
	{
		state = st;
		reboots = reb;
		REQUIRE(swell_link_open_udp(&l, "127.0.0.1", 0, nullptr, 0) == 0); // bound before swell-flash runs
		port = swell_link_udp_port(l);
		th = std::thread([this] { loop(); });
	}
	void beat(swell_link *to, uint64_t now)
	{
		if (silent && now - silent_since > back_ms * 1000000u) {
			silent = false; // rebooted into "the new image"
			state = 1;
		}
		if (silent || now < next)
			return;
		swell_msg hb[2]{};
		hb[0].type = SWELL_MSG_HEARTBEAT;
		hb[0].node = hb[1].node = node;
		hb[0].u.heartbeat.state = (uint8_t)state.load();
		hb[0].u.heartbeat.version = SWELL_PROTO_VERSION;
		hb[0].u.heartbeat.seq = seq;
		hb[1].type = SWELL_MSG_CTL_INFO;
		hb[1].u.ctl_info.fw_major = version[0];
		hb[1].u.ctl_info.fw_minor = version[1];
		hb[1].u.ctl_info.fw_patch = version[2];
		hb[1].u.ctl_info.obj_a_100um = hb[1].u.ctl_info.obj_b_100um = 500;
		hb[1].u.ctl_info.obj_h_100um = 500;
		swell_frame f;
		size_t used;
		if (swell_link_encode(SWELL_CARRIER_PKT, node, seq, hb, seq % 4 == 0 ? 2 : 1, &f, &used) == SWELL_OK)
			swell_link_send(to, &f); // no client yet: nowhere to go
		seq++;
		next = now + 50000000u;
	}
	void take(const swell_msg &m)
	{
		if (m.type == SWELL_MSG_HEARTBEAT) {
			return; // a client's keep-alive
		} else if (m.node != node) {
			other++; // addressed to another controller
		} else if (m.type == SWELL_MSG_PARAM_SET && m.u.param_set.id == 31 && m.u.param_set.value == 0) {
			got_autorun_off++; // AUTORUN=0: older controllers let autorun override STOP
		} else if (m.type == SWELL_MSG_PARAM_SET && m.u.param_set.id == 40 && m.u.param_set.value == 0) {
			got_stop++;
			state = 1;
		} else if (m.type == SWELL_MSG_ENTER_BOOTLOADER) {
			got_boot++;
			boot_key_ok = m.u.enter_bootloader.key == SWELL_PROTO_BOOT_KEY;
			if (state.load() == 3)
				other++; // the controller refuses it while RUNNING: must not happen
			silent = reboots;
			silent_since = swell_link_now_ns();
		} else {
			other++;
		}
	}
	void loop()
	{
		while (!quit) {
			uint64_t now = swell_link_now_ns();
			beat(l, now);
			if (twin)
				twin->beat(l, now);
			swell_frame f;
			if (swell_link_recv(l, &f, 10) != 0)
				continue;
			swell_msg m[SWELL_PKT_MSGS_MAX];
			size_t n;
			if (swell_link_decode(SWELL_CARRIER_PKT, &f, m, SWELL_PKT_MSGS_MAX, &n, NULL, NULL) != SWELL_OK)
				continue;
			for (size_t i = 0; i < n; i++)
				(twin && m[i].node == twin->node ? *twin : *this).take(m[i]);
		}
	}
	~fake_ctl()
	{
		quit = true;
		if (th.joinable())
			th.join();
		if (l)
			swell_link_close(l);
	}
};

} // namespace

TEST_CASE("enter-bootloader: refused while the controller is RUNNING, nothing sent, no tool runs")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	fake_ctl c;
	c.start(3, true);
	std::string out;
	int rc = s.run(img + " --backend swd --swd-tool st-flash --enter-bootloader udp:" + std::to_string(c.port), &out);
	INFO(out);
	CHECK(rc == 2);
	CHECK(out.find("controller is RUNNING") != std::string::npos);
	CHECK(c.got_boot == 0);
	CHECK(c.got_stop == 0);
	CHECK(c.other == 0);
	CHECK(s.log().empty());
}

TEST_CASE("enter-bootloader with force sends COMMAND=STOP first, then the key, and flashing follows the silence")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	fake_ctl c;
	c.start(3, true);
	std::string out;
	int rc = s.run(img + " --backend swd --swd-tool st-flash --force --enter-bootloader udp:" + std::to_string(c.port), &out);
	INFO(out);
	CHECK(rc == 0);
	CHECK(c.got_autorun_off == 1);
	CHECK(c.got_stop == 1);
	CHECK(c.got_boot == 1);
	CHECK(c.boot_key_ok == 1);
	CHECK(c.other == 0);
	CHECK(out.find("it reboots into its bootloader") != std::string::npos);
	CHECK(s.log().find("st-flash write") != std::string::npos);
	// then, on the same port, the controller is found again with the image's version
	CHECK(out.find("controller back, running version 1.2.3") != std::string::npos);
}

TEST_CASE("enter-bootloader: a controller that keeps beating (ignores the request) stops the flash with exit 1")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	fake_ctl c;
	c.start(1, false);
	std::string out;
	int rc = s.run(img + " --backend swd --swd-tool st-flash --enter-bootloader udp:" + std::to_string(c.port), &out);
	INFO(out);
	CHECK(rc == 1);
	CHECK(c.got_boot == 1);
	CHECK(out.find("still sends heartbeats") != std::string::npos);
	CHECK(s.log().empty());
	// Nobody there: exit 1, nothing run.
	rc = s.run(img + " --backend swd --enter-bootloader udp:" + std::to_string(fake_ctl::free_port()), &out);
	CHECK(rc == 1);
	CHECK(out.find("no controller heartbeat") != std::string::npos);
	CHECK(s.log().empty());
}

namespace {

// swell-ctl on UDP as the controller: its exit status goes to DIR/NAME.rc. Its host link takes clients
// on port `host`; the viewer and device ports are free ones.
std::string ctl_cmd(const scratch &s, const std::string &name, const std::string &host, const std::string &version,
		    double seconds)
{
	std::string dev = std::to_string(fake_ctl::free_port());
	return "'" SWELL_CTL_BIN "' --no-rt --quiet --seconds " + std::to_string(seconds) + " --fw-version " + version +
		" --host udp:" + std::to_string(fake_ctl::free_port()) + ",listen=" + host + " --device udp:" + dev + " > '" +
		s.dir + "/" + name + ".out' 2>&1; echo $? > '" + s.dir + "/" + name + ".rc'";
}

} // namespace

TEST_CASE("after flashing, swell-ctl is found again and its CTL_INFO version is checked against the image")
{
	// The old controller (swell-ctl --fw-version 0.0.9) accepts ENTER_BOOTLOADER in IDLE and exits 3;
	// the stub st-flash's reset starts "the new image": swell-ctl with the version under test.
	scratch s;
	std::string img = s.write("good.bin", make_image(2048)); // header version 1.2.3
	for (const char *next : {"1.2.3", "0.0.9"}) {
		INFO("the restarted controller reports " << next);
		std::string host = std::to_string(fake_ctl::free_port());
		std::string old_ctl = ctl_cmd(s, "old", host, "0.0.9", 8);
		std::string new_ctl = ctl_cmd(s, "new", host, next, 2);
		REQUIRE(std::system(("(" + old_ctl + ") &").c_str()) == 0);
		std::string quoted;
		for (char ch : new_ctl) { // into double quotes for the shell that starts swell-flash
			if (ch == '$' || ch == '"' || ch == '\\')
				quoted += '\\';
			quoted += ch;
		}
		std::string out, env = "ON_RESET=\"" + quoted + "\"";
		int rc = s.run(img + " --backend swd --swd-tool st-flash --find-timeout 5 --enter-bootloader udp:" + host, &out,
			       env);
		INFO(out);
		CHECK(out.find("state IDLE") != std::string::npos);
		CHECK(out.find("controller silent after ENTER_BOOTLOADER") != std::string::npos);
		CHECK(s.log().find("st-flash write") != std::string::npos);
		CHECK(out.find(std::string("controller back, running version ") + next) != std::string::npos);
		CHECK(slurp(s.dir + "/old.rc") == "3\n"); // swell-ctl's "bootloader requested" status
		INFO(slurp(s.dir + "/old.out"));
		CHECK(slurp(s.dir + "/old.out").find("enter-bootloader accepted in state idle") != std::string::npos);
		if (std::string(next) == "1.2.3") {
			CHECK(rc == 0);
			CHECK(out.find("the controller runs the image's version 1.2.3") != std::string::npos);
		} else {
			CHECK(rc == 1);
			CHECK(out.find("runs version 0.0.9, but the image's header says 1.2.3") != std::string::npos);
		}
		for (int k = 0; k < 100 && slurp(s.dir + "/new.rc").empty(); k++)
			usleep(100000); // the new swell-ctl ends by itself (--seconds 2)
		CHECK(slurp(s.dir + "/new.rc") == "0\n");
		for (const char *f : {"log", "old.rc", "old.out", "new.rc", "new.out"})
			std::remove((s.dir + "/" + f).c_str());
	}
}

TEST_CASE("find: nobody there is exit 1 within the time limit, and --check-only --find checks a running controller")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	std::string out, port = std::to_string(fake_ctl::free_port());
	int rc = s.run(img + " --check-only --find udp:" + port + " --find-timeout 0.4", &out);
	INFO(out);
	CHECK(rc == 1);
	CHECK(out.find("controller not heard on udp 127.0.0.1:" + port + " within 0.4 s") != std::string::npos);
	fake_ctl c;
	c.start(1, true);
	rc = s.run(img + " --check-only --find udp:" + std::to_string(c.port), &out);
	CHECK(rc == 0);
	CHECK(out.find("controller back, running version 1.2.3") != std::string::npos);
	CHECK(s.log().empty());
	rc = s.run(img + " --find tcp:1", &out);
	CHECK(rc == 2);
	CHECK(out.find("--find 'tcp:1': not a link: udp[:PORT], can:IFACE, usb[:VID:PID]") != std::string::npos);
}

TEST_CASE("enter-bootloader then dfu: flashing waits for the DfuSe device and starts only when it is there")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	std::string env = "SWELL_FLASH_SYSFS='" + s.dir + "/sys'", out;
	{
		fake_ctl c;
		c.start(1, true);
		int rc = s.run(img + " --backend dfu --dfu-wait 0.3 --enter-bootloader udp:" + std::to_string(c.port), &out, env);
		INFO(out);
		CHECK(rc == 1);
		CHECK(c.got_boot == 1);
		CHECK(out.find("no DfuSe device 0483:df11 on USB within 0.3 s") != std::string::npos);
		CHECK(s.log().empty());
	}
	std::string d = s.dir + "/sys/bus/usb/devices/1-1";
	std::system(("mkdir -p '" + d + "'").c_str());
	std::ofstream(d + "/idVendor") << "0483\n";
	std::ofstream(d + "/idProduct") << "df11\n";
	fake_ctl c;
	c.start(1, true);
	int rc = s.run(img + " --backend dfu --dfu-wait 0.3 --enter-bootloader udp:" + std::to_string(c.port), &out, env);
	INFO(out);
	// The stub dfu-util uploads nothing, so the verify fails: but the write was reached.
	CHECK(rc == 1);
	CHECK(out.find("DfuSe device 0483:df11 on USB after") != std::string::npos);
	CHECK(s.log().find("dfu-util -d 0483:df11 -a 0 -s 0x08000000 -D ") == 0);
	CHECK(out.find("verify FAILED") != std::string::npos);
}

// ---- host link options: one line for a bad one, nothing runs ----

TEST_CASE("link options: bad specs, --node and --iface give one line and exit 2, nothing runs")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	struct {
		const char *args, *reason;
	} bad[] = {{"--enter-bootloader can:", "--enter-bootloader 'can:': give the CAN interface, e.g. can:can0"},
		   {"--enter-bootloader usb:1:2:3", "not usb:VID:PID in hex"},
		   {"--find canfd:can0", "--find 'canfd:can0': swell's controller links are classic CAN"},
		   {"--find udp --node 16", "--node '16' is not a whole number in [0, 15]"},
		   {"--find udp --node x", "--node 'x' is not a whole number"},
		   {"--node 3", "--node is for --enter-bootloader or --find"},
		   {"--find usb --iface 256", "--iface '256' is not a whole number in [0, 255]"},
		   {"--find can:can0 --iface 1", "--iface is for a usb link"}};
	for (auto &b : bad) {
		std::string out;
		int rc = s.run(img + " --backend swd --swd-tool st-flash " + b.args, &out);
		INFO(b.args << ": " << out);
		CHECK(rc == 2);
		CHECK(std::count(out.begin(), out.end(), '\n') == 1);
		CHECK(out.find(b.reason) != std::string::npos);
	}
	CHECK(s.log().empty());
}

TEST_CASE("enter-bootloader: several controllers heard and no --node is refused, nothing sent, and --node picks one")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	fake_ctl b, a; // a serves b: a goes first
	a.node = 2;
	a.version[0] = 9;
	b.node = 5;
	a.twin = &b; // both on the one port swell-flash sends to
	a.start(1, true);
	std::string out;
	int rc = s.run(img + " --backend swd --swd-tool st-flash --enter-bootloader udp:" + std::to_string(a.port), &out);
	INFO(out);
	CHECK(rc == 2);
	CHECK(out.find("several controllers on udp 127.0.0.1:" + std::to_string(a.port) +
		       " (nodes 2, 5): choose one "
		       "with --node; nothing sent") != std::string::npos);
	CHECK(a.got_boot + b.got_boot == 0);
	CHECK(a.other + b.other == 0);
	CHECK(s.log().empty());
	// --find on a bus with two: --node takes the one asked for (node 2 says 9.2.3, node 5 1.2.3)
	rc = s.run(img + " --check-only --node 5 --find udp:" + std::to_string(a.port), &out);
	INFO(out);
	CHECK(rc == 0);
	CHECK(out.find("controller back, running version 1.2.3 (node 5,") != std::string::npos);
	rc = s.run(img + " --check-only --node 2 --find udp:" + std::to_string(a.port), &out);
	CHECK(rc == 1);
	CHECK(out.find("runs version 9.2.3, but the image's header says 1.2.3") != std::string::npos);
}

TEST_CASE("enter-bootloader --node: the request carries the chosen node, and another node is not heard")
{
	scratch s;
	std::string img = s.write("good.bin", make_image(2048));
	fake_ctl c;
	c.node = 5;
	c.start(1, true);
	std::string out;
	int rc = s.run(
		img + " --backend swd --swd-tool st-flash --node 4 --no-find --enter-bootloader udp:" + std::to_string(c.port),
		&out);
	INFO(out);
	CHECK(rc == 1);
	CHECK(out.find("no heartbeat of controller node 4 on udp 127.0.0.1:" + std::to_string(c.port) +
		       " within 1.5 s (other nodes heard)") != std::string::npos);
	CHECK(c.got_boot == 0);
	rc = s.run(img + " --backend swd --swd-tool st-flash --node 5 --no-find --enter-bootloader udp:" + std::to_string(c.port),
		   &out);
	INFO(out);
	CHECK(rc == 0);
	CHECK(c.got_boot == 1);
	CHECK(c.boot_key_ok == 1);
	CHECK(c.other == 0); // everything it got was addressed to node 5
	CHECK(out.find("controller node 5 on udp") != std::string::npos);
	CHECK(out.find("(no heartbeat after the request)") != std::string::npos); // the fake sends no last one
}

// ---- one controller, every host program at once (UDP): the viewer on the telemetry port, the
// console and the flasher as clients of the host link ----

namespace {

pid_t spawn_sh(const std::string &cmd)
{
	std::string c = "exec " + cmd;
	const char *argv[] = {"sh", "-c", c.c_str(), nullptr};
	pid_t pid = -1;
	REQUIRE(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char **>(argv), environ) == 0);
	return pid;
}

// Exit status of pid, waiting at most ms (-1: still running).
int wait_exit(pid_t pid, int ms)
{
	int st = 0;
	for (int k = 0; k < ms / 10; k++) {
		if (waitpid(pid, &st, WNOHANG) == pid)
			return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
		usleep(10000);
	}
	return -1;
}

void end(pid_t &pid)
{
	if (pid <= 0)
		return;
	kill(pid, SIGTERM);
	if (wait_exit(pid, 3000) < 0) {
		kill(pid, SIGKILL);
		wait_exit(pid, 3000);
	}
	pid = -1;
}

} // namespace

TEST_CASE("one swell-ctl on UDP serves swell-view, swell-tool and swell-flash at once: the viewer's telemetry goes on "
	  "while the tool watches and sets, enter-bootloader is refused while RUNNING and accepted outside it")
{
	scratch s;
	const std::string img = s.write("good.bin", make_image(2048)), d = s.dir;
	const std::string view_port = std::to_string(fake_ctl::free_port()), port = std::to_string(fake_ctl::free_port()),
			  dev = std::to_string(fake_ctl::free_port());
	const std::string link = " --link udp:" + port + " ";
	pid_t ctl = spawn_sh("'" SWELL_CTL_BIN "' --no-rt --quiet --silent-ticks 2500 --seconds 60 --host udp:" + view_port +
			     ",listen=" + port + " --device udp:" + dev + " >'" + d + "/ctl.out' 2>&1");
	pid_t hm = spawn_sh("'" SWELL_HM_BIN "' --port " + dev + " --quiet --seconds 60 --hand drop >'" + d + "/hm.out' 2>&1");
	// the viewer on the telemetry port, headless in its own X server, 10 frames a second for 20 s, with
	// the leak checker on: Mesa's software driver preloaded (its dlclose at exit would make the blocks
	// it holds leaks of an unknown module), what GL, X11 and GLFW keep suppressed by library name
	const std::string gl = *SWELL_GL_DRIVER ? std::string(" LD_PRELOAD=" SWELL_GL_DRIVER) : std::string();
	pid_t view =
		spawn_sh("env ASAN_OPTIONS=detect_leaks=1:verify_asan_link_order=0 LSAN_OPTIONS=suppressions=" SWELL_LSAN_SUPP
			 ":print_suppressions=0" +
			 gl +
			 " xvfb-run -a '" SWELL_VIEW_BIN "' --headless --fps 10 --frames 200 --size 320x240 --msaa 0 "
			 "--source udp:" +
			 view_port + " --csv '" + d + "/view.csv' >'" + d + "/view.out' 2>&1");
	auto tool = [&](const std::string &args) {
		const int st = std::system(("'" SWELL_TOOL_BIN "'" + link + args + " >'" + d + "/tool.out' 2>&1").c_str());
		const std::string out = slurp(d + "/tool.out");
		UNSCOPED_INFO("swell-tool " << args << " -> " << WEXITSTATUS(st) << ":\n" << out);
		return std::make_pair(WIFEXITED(st) ? WEXITSTATUS(st) : -1, out);
	};

	int armed = -1;
	for (int k = 0; k < 20 && armed != 0; k++) // until the controller has heard the device
		armed = tool("arm").first;
	REQUIRE(armed == 0);
	pid_t watch = spawn_sh("'" SWELL_TOOL_BIN "'" + link + "watch --seconds 5 >'" + d + "/watch.out' 2>&1");
	auto st = tool("status");
	CHECK(st.first == 0);
	CHECK(st.second.find("on udp 127.0.0.1:" + port + ", state armed") != std::string::npos);
	auto set = tool("set wave.damping 0.02");
	CHECK(set.first == 0);
	CHECK(set.second.find("wave.damping = 0.02 (was 0.001)") != std::string::npos);
	REQUIRE(tool("run").first == 0);

	std::string out;
	int rc = s.run(img + " --backend swd --swd-tool st-flash --no-find --enter-bootloader udp:" + port, &out);
	INFO("swell-flash while RUNNING:\n" << out);
	CHECK(rc == 2);
	CHECK(out.find("controller is RUNNING") != std::string::npos);
	CHECK(s.log().empty());
	CHECK(tool("get wave.damping").second.find("wave.damping = 0.02 ") != std::string::npos);

	const int watched = wait_exit(watch, 15000);
	INFO("swell-tool watch:\n" << slurp(d + "/watch.out"));
	CHECK(watched == 0);
	CHECK(slurp(d + "/watch.out").find("running  z") != std::string::npos);

	REQUIRE(tool("stop").first == 0);
	rc = s.run(img + " --backend swd --swd-tool st-flash --no-find --enter-bootloader udp:" + port, &out);
	INFO("swell-flash while ARMED:\n" << out);
	CHECK(rc == 0);
	CHECK(out.find("state ARMED") != std::string::npos);
	CHECK(s.log().find("st-flash write") != std::string::npos);
	const int ctl_rc = wait_exit(ctl, 5000);
	INFO(slurp(d + "/ctl.out"));
	CHECK(ctl_rc == 3); // swell-ctl's "bootloader requested"
	CHECK(slurp(d + "/ctl.out").find("enter-bootloader accepted in state armed") != std::string::npos);
	if (ctl_rc >= 0)
		ctl = -1;

	// The viewer: a pose sample at least every 0.5 s from the controller's first to its last (it
	// draws at 10 Hz and takes what came in between), at 100 Hz on the whole. Poses come while the
	// object moves: from run to stop (the 5 s of watch, the get and the refused flash within them).
	const int viewed = wait_exit(view, 40000);
	INFO("swell-view:\n" << slurp(d + "/view.out"));
	CHECK(viewed == 0);
	if (viewed >= 0)
		view = -1;
	std::ifstream csv(d + "/view.csv");
	std::string line;
	std::vector<double> t;
	std::getline(csv, line); // the header
	while (std::getline(csv, line)) {
		const size_t c1 = line.find(','), c2 = line.find(',', c1 + 1);
		if (c1 != std::string::npos && c2 != c1 + 1) // a pose row: its sequence number is there
			t.push_back(std::atof(line.c_str()));
	}
	REQUIRE(t.size() > 10);
	double gap = 0;
	for (size_t k = 1; k < t.size(); k++)
		gap = std::max(gap, t[k] - t[k - 1]);
	const double span = t.back() - t.front();
	INFO(t.size() << " pose samples over " << span << " s, longest gap " << gap << " s");
	CHECK(span > 4.0);
	CHECK(gap < 0.5);
	CHECK(t.size() > 50 * span);
	end(watch);
	end(hm);
	end(ctl);
	end(view);
}
