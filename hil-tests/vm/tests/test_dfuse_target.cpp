// The DfuSe state machine of the emulated STM32F405 ROM bootloader (hil-tests/vm/dfuse_target.c),
// driven with the request sequences dfu-util sends.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <functional>
#include <memory>
#include <vector>

extern "C" {
#include "dfuse_target.h"
}

namespace {

const uint32_t BASE = SWELL_DFUSE_FLASH_BASE;

struct Target {
	std::unique_ptr<swell_dfuse> t{new swell_dfuse};
	std::vector<uint8_t> in = std::vector<uint8_t>(SWELL_DFUSE_XFER_MAX);
	size_t in_len = 0;
	unsigned xfer;

	explicit Target(unsigned x = 2048) : xfer(x) { REQUIRE(swell_dfuse_init(t.get(), 3, x) == SWELL_OK); }

	swell_dfuse_reply out(uint8_t req, uint16_t value, const std::vector<uint8_t> &data)
	{
		swell_dfuse_setup s{0x21, req, value, 0, (uint16_t)data.size()};
		return swell_dfuse_request(t.get(), &s, data.data(), data.size(), in.data(), in.size(), &in_len);
	}
	swell_dfuse_reply get(uint8_t req, uint16_t value, uint16_t len)
	{
		swell_dfuse_setup s{0xA1, req, value, 0, len};
		return swell_dfuse_request(t.get(), &s, nullptr, 0, in.data(), in.size(), &in_len);
	}
	// GETSTATUS: returns bState, sets status/poll.
	unsigned status = 0, poll = 0;
	unsigned getstatus()
	{
		REQUIRE(get(SWELL_DFU_GETSTATUS, 0, 6) == SWELL_DFUSE_DATA);
		REQUIRE(in_len == 6);
		status = in[0];
		poll = in[1] | in[2] << 8 | in[3] << 16;
		return in[4];
	}
	// DNLOAD then the GETSTATUS pair dfu-util polls with: busy, then the result.
	unsigned dnload(uint16_t block, const std::vector<uint8_t> &data)
	{
		REQUIRE(out(SWELL_DFU_DNLOAD, block, data) == SWELL_DFUSE_ACK);
		CHECK(t->state == SWELL_DFU_DNLOAD_SYNC);
		unsigned busy = getstatus();
		INFO("first GETSTATUS after DNLOAD gave state " << busy << " (" << swell_dfu_state_name(busy) << ")");
		CHECK(busy == SWELL_DFU_DNBUSY);
		CHECK(poll == 3);
		return getstatus();
	}
	static std::vector<uint8_t> cmd(uint8_t c, uint32_t a)
	{
		return {c, (uint8_t)a, (uint8_t)(a >> 8), (uint8_t)(a >> 16), (uint8_t)(a >> 24)};
	}
};

std::vector<uint8_t> pattern(size_t n, unsigned seed)
{
	std::vector<uint8_t> v(n);
	for (size_t i = 0; i < n; i++)
		v[i] = (uint8_t)((i * 131u + seed * 7u + (i >> 8)) & 0xFFu);
	return v;
}

} // namespace

TEST_CASE("DfuSe: data blocks land at (wBlockNum-2)*wTransferSize + pointer and UPLOAD reads them back")
{
	const unsigned xfer = GENERATE(2048u, 256u); // the F405 ROM's, and what GadgetFS carries
	Target d(xfer);
	INFO("wTransferSize " << xfer);
	const std::vector<uint8_t> img = pattern(5000, 1); // 2 full blocks and a short one
	// As dfu-util downloads: per 2048-byte chunk erase, set address, block 2.
	for (size_t off = 0; off < img.size(); off += d.xfer) {
		if (off == 0)
			REQUIRE(d.dnload(0, Target::cmd(0x41, BASE)) == SWELL_DFU_DNLOAD_IDLE);
		REQUIRE(d.dnload(0, Target::cmd(0x21, BASE + (uint32_t)off)) == SWELL_DFU_DNLOAD_IDLE);
		size_t n = std::min<size_t>(d.xfer, img.size() - off);
		std::vector<uint8_t> chunk(img.begin() + (long)off, img.begin() + (long)(off + n));
		REQUIRE(d.dnload(2, chunk) == SWELL_DFU_DNLOAD_IDLE);
		CHECK(d.status == SWELL_DFU_OK);
	}
	CHECK(std::memcmp(d.t->flash, img.data(), img.size()) == 0);
	CHECK(d.t->bytes_written == img.size());
	// Blocks above 2 count from the pointer: block 4 is 2 transfer sizes above it.
	REQUIRE(d.dnload(0, Target::cmd(0x21, BASE + 0x20000)) == SWELL_DFU_DNLOAD_IDLE);
	REQUIRE(d.dnload(4, pattern(16, 2)) == SWELL_DFU_DNLOAD_IDLE);
	CHECK(std::memcmp(d.t->flash + 0x20000 + 2 * d.xfer, pattern(16, 2).data(), 16) == 0);
	CHECK(d.t->flash[0x20000 + 2 * d.xfer - 1] == 0xFF);
	CHECK(d.t->flash[0x20000 + 2 * d.xfer + 16] == 0xFF);

	// Upload as dfu-util does: abort to idle, set address, blocks 2, 3, ... of 2048 bytes.
	REQUIRE(d.out(SWELL_DFU_ABORT, 0, {}) == SWELL_DFUSE_ACK);
	REQUIRE(d.getstatus() == SWELL_DFU_IDLE);
	REQUIRE(d.dnload(0, Target::cmd(0x21, BASE)) == SWELL_DFU_DNLOAD_IDLE);
	REQUIRE(d.out(SWELL_DFU_ABORT, 0, {}) == SWELL_DFUSE_ACK);
	std::vector<uint8_t> back;
	for (uint16_t b = 2; back.size() < img.size(); b++) {
		uint16_t len = (uint16_t)std::min<size_t>(d.xfer, img.size() - back.size());
		REQUIRE(d.get(SWELL_DFU_UPLOAD, b, len) == SWELL_DFUSE_DATA);
		REQUIRE(d.in_len == len);
		back.insert(back.end(), d.in.begin(), d.in.begin() + (long)d.in_len);
	}
	CHECK(back == img);
	CHECK(d.t->state == SWELL_DFU_UPLOAD_IDLE);
	// The block at the end of flash is short, which ends the upload (dfuIDLE).
	REQUIRE(d.out(SWELL_DFU_ABORT, 0, {}) == SWELL_DFUSE_ACK);
	REQUIRE(d.dnload(0, Target::cmd(0x21, BASE + SWELL_DFUSE_FLASH_SIZE - 100)) == SWELL_DFU_DNLOAD_IDLE);
	REQUIRE(d.out(SWELL_DFU_ABORT, 0, {}) == SWELL_DFUSE_ACK);
	REQUIRE(d.get(SWELL_DFU_UPLOAD, 2, (uint16_t)d.xfer) == SWELL_DFUSE_DATA);
	CHECK(d.in_len == 100);
	CHECK(d.t->state == SWELL_DFU_IDLE);
}

TEST_CASE("DfuSe: a write outside the flash or to bytes not erased is refused with dfuERROR and changes nothing")
{
	Target d;
	REQUIRE(d.dnload(0, Target::cmd(0x21, BASE)) == SWELL_DFU_DNLOAD_IDLE);
	REQUIRE(d.dnload(2, pattern(64, 3)) == SWELL_DFU_DNLOAD_IDLE);
	std::vector<uint8_t> before(d.t->flash, d.t->flash + SWELL_DFUSE_FLASH_SIZE);
	uint32_t lo, hi;
	swell_dfuse_take_dirty(d.t.get(), &lo, &hi);
	CHECK(lo == 0);
	CHECK(hi == 64);

	SECTION("the same bytes again, not erased: errCHECK_ERASED")
	{
		CHECK(d.dnload(2, pattern(64, 4)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_CHECK_ERASED);
	}
	SECTION("one byte overlapping written flash: errCHECK_ERASED")
	{
		REQUIRE(d.dnload(0, Target::cmd(0x21, BASE + 63)) == SWELL_DFU_DNLOAD_IDLE);
		CHECK(d.dnload(2, pattern(32, 4)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_CHECK_ERASED);
	}
	SECTION("a block crossing the end of the 1 MiB flash: errADDRESS")
	{
		REQUIRE(d.dnload(0, Target::cmd(0x21, BASE + SWELL_DFUSE_FLASH_SIZE - 16)) == SWELL_DFU_DNLOAD_IDLE);
		CHECK(d.dnload(2, pattern(32, 5)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_ADDRESS);
	}
	SECTION("a block number that puts the address past the end: errADDRESS")
	{
		CHECK(d.dnload(2 + SWELL_DFUSE_FLASH_SIZE / d.xfer, pattern(8, 5)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_ADDRESS);
	}
	SECTION("set address and erase outside flash: errADDRESS")
	{
		CHECK(d.dnload(0, Target::cmd(0x21, BASE - 4)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_ADDRESS);
		CHECK(d.t->pointer == BASE);
		REQUIRE(d.out(SWELL_DFU_CLRSTATUS, 0, {}) == SWELL_DFUSE_ACK);
		CHECK(d.dnload(0, Target::cmd(0x41, 0x1FFF0000)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_ADDRESS);
	}
	SECTION("unknown DfuSe command and block 1: errUNKNOWN")
	{
		CHECK(d.dnload(0, {0x92}) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_UNKNOWN);
		REQUIRE(d.out(SWELL_DFU_CLRSTATUS, 0, {}) == SWELL_DFUSE_ACK);
		CHECK(d.dnload(1, pattern(8, 6)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_UNKNOWN);
	}
	SECTION("a write with alternate setting 1 (option bytes, not emulated): errTARGET")
	{
		REQUIRE(swell_dfuse_set_alt(d.t.get(), 1) == 0);
		CHECK(d.dnload(2, pattern(8, 7)) == SWELL_DFU_ERROR);
		CHECK(d.status == SWELL_DFU_ERR_TARGET);
		CHECK(swell_dfuse_set_alt(d.t.get(), 4) == -1);
		CHECK(d.t->alt == 1);
	}
	CHECK(d.t->state == SWELL_DFU_ERROR);
	CHECK(std::memcmp(d.t->flash, before.data(), before.size()) == 0);
	swell_dfuse_take_dirty(d.t.get(), &lo, &hi);
	CHECK(lo == hi);
	CHECK(d.t->refused >= 1);
	// CLRSTATUS brings it back to dfuIDLE with status OK.
	REQUIRE(d.out(SWELL_DFU_CLRSTATUS, 0, {}) == SWELL_DFUSE_ACK);
	CHECK(d.getstatus() == SWELL_DFU_IDLE);
	CHECK(d.status == SWELL_DFU_OK);
}

TEST_CASE("DfuSe: sectors are 4 x 16 KiB, 1 x 64 KiB, 7 x 128 KiB and an erase clears exactly its sector")
{
	const uint32_t want_start[] = {0,       0x4000,  0x8000,  0xC000,  0x10000, 0x20000,
				       0x40000, 0x60000, 0x80000, 0xA0000, 0xC0000, 0xE0000};
	unsigned seen = 0;
	uint32_t start, size, prev_start = 0xFFFFFFFF;
	for (uint32_t off = 0; off < SWELL_DFUSE_FLASH_SIZE; off += 0x400) {
		REQUIRE(swell_dfuse_sector(off, &start, &size) == 0);
		INFO("offset 0x" << std::hex << off << " in sector 0x" << start << " size 0x" << size);
		REQUIRE(off >= start);
		REQUIRE(off < start + size);
		if (start != prev_start) {
			REQUIRE(seen < 12);
			CHECK(start == want_start[seen]);
			seen++;
			prev_start = start;
		}
	}
	CHECK(seen == 12);
	CHECK(swell_dfuse_sector(SWELL_DFUSE_FLASH_SIZE, &start, &size) == -1);

	Target d;
	std::memset(d.t->flash, 0x00, SWELL_DFUSE_FLASH_SIZE); // fully programmed
	// Any address inside sector 5 (0x08020000-0x0803FFFF) erases all of it and nothing else.
	REQUIRE(d.dnload(0, Target::cmd(0x41, BASE + 0x2ABCD)) == SWELL_DFU_DNLOAD_IDLE);
	size_t ff = 0, first = SWELL_DFUSE_FLASH_SIZE, last = 0;
	for (size_t i = 0; i < SWELL_DFUSE_FLASH_SIZE; i++) {
		if (d.t->flash[i] == 0xFF) {
			ff++;
			first = std::min(first, i);
			last = std::max(last, i);
		}
	}
	CHECK(ff == 0x20000);
	CHECK(first == 0x20000);
	CHECK(last == 0x3FFFF);
	REQUIRE(d.dnload(0, {0x41}) == SWELL_DFU_DNLOAD_IDLE); // mass erase
	CHECK(std::count(d.t->flash, d.t->flash + SWELL_DFUSE_FLASH_SIZE, 0xFF) == (long)SWELL_DFUSE_FLASH_SIZE);
}

TEST_CASE("DfuSe: requests not valid in the state are stalled with dfuERROR errSTALLEDPKT")
{
	struct Case {
		const char *what;
		std::function<swell_dfuse_reply(Target &)> run;
	};
	const std::vector<Case> cases = {
		{"CLRSTATUS in dfuIDLE", [](Target &d) { return d.out(SWELL_DFU_CLRSTATUS, 0, {}); }},
		{"zero-length DNLOAD in dfuIDLE", [](Target &d) { return d.out(SWELL_DFU_DNLOAD, 0, {}); }},
		{"DNLOAD longer than wTransferSize",
		 [](Target &d) { return d.out(SWELL_DFU_DNLOAD, 2, std::vector<uint8_t>(2049, 0)); }},
		{"UPLOAD longer than wTransferSize", [](Target &d) { return d.get(SWELL_DFU_UPLOAD, 2, 2049); }},
		{"UPLOAD block 1", [](Target &d) { return d.get(SWELL_DFU_UPLOAD, 1, 64); }},
		{"DETACH in DFU mode", [](Target &d) { return d.out(SWELL_DFU_DETACH, 1000, {}); }},
		{"unknown request 7", [](Target &d) { return d.out(7, 0, {}); }},
		{"GETSTATUS with 5 bytes", [](Target &d) { return d.get(SWELL_DFU_GETSTATUS, 0, 5); }},
		{"UPLOAD while a download is pending",
		 [](Target &d) {
			 d.out(SWELL_DFU_DNLOAD, 0, Target::cmd(0x21, BASE));
			 return d.get(SWELL_DFU_UPLOAD, 2, 64);
		 }},
		{"ABORT in dfuDNBUSY",
		 [](Target &d) {
			 d.out(SWELL_DFU_DNLOAD, 0, Target::cmd(0x21, BASE));
			 d.getstatus();
			 return d.out(SWELL_DFU_ABORT, 0, {});
		 }},
	};
	for (const auto &c : cases) {
		Target d;
		INFO(c.what);
		CHECK(c.run(d) == SWELL_DFUSE_STALL);
		CHECK(d.t->state == SWELL_DFU_ERROR);
		CHECK(d.t->status == SWELL_DFU_ERR_STALLEDPKT);
		CHECK(std::count(d.t->flash, d.t->flash + SWELL_DFUSE_FLASH_SIZE, 0xFF) == (long)SWELL_DFUSE_FLASH_SIZE);
		// GETSTATE still answers, and CLRSTATUS recovers.
		REQUIRE(d.get(SWELL_DFU_GETSTATE, 0, 1) == SWELL_DFUSE_DATA);
		CHECK(d.in[0] == SWELL_DFU_ERROR);
		CHECK(d.out(SWELL_DFU_CLRSTATUS, 0, {}) == SWELL_DFUSE_ACK);
		CHECK(d.t->state == SWELL_DFU_IDLE);
	}
}

TEST_CASE("DfuSe: a transfer size outside 1..2048 is refused and changes nothing")
{
	Target d;
	d.t->pointer = BASE + 0x1234;
	CHECK(swell_dfuse_init(d.t.get(), 3, 0) == SWELL_ERANGE);
	CHECK(swell_dfuse_init(d.t.get(), 3, 2049) == SWELL_ERANGE);
	CHECK(d.t->pointer == BASE + 0x1234);
	CHECK(d.t->xfer == 2048);
}

TEST_CASE("DfuSe: the leave request (zero-length DNLOAD after set address) reports dfuMANIFEST and the start address")
{
	Target d;
	CHECK(d.t->leave == 0);
	REQUIRE(d.dnload(0, Target::cmd(0x21, BASE)) == SWELL_DFU_DNLOAD_IDLE);
	REQUIRE(d.out(SWELL_DFU_DNLOAD, 0, {}) == SWELL_DFUSE_ACK);
	CHECK(d.t->state == SWELL_DFU_MANIFEST_SYNC);
	CHECK(d.getstatus() == SWELL_DFU_MANIFEST);
	CHECK(d.status == SWELL_DFU_OK);
	CHECK(d.t->leave == 1);
	CHECK(d.t->leave_address == BASE);
	// Gone: nothing more is served.
	CHECK(d.get(SWELL_DFU_UPLOAD, 2, 64) == SWELL_DFUSE_STALL);
	CHECK(d.t->state == SWELL_DFU_MANIFEST_WAIT_RESET);
}
