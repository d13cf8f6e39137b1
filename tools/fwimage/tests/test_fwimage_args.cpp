/* swell-fwimage: bad arguments exit 2, refused images and unreadable files exit 1, each with one line
 * that says why with the figures, nothing leaked (the test build runs it under AddressSanitizer). */
#include "swell_test.hpp"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

extern "C" {
#include "swell/fwimage.h"
}

namespace {

void put(const std::string &path, const std::vector<uint8_t> &b)
{
	std::ofstream f(path, std::ios::binary);
	f.write(reinterpret_cast<const char *>(b.data()), (std::streamsize)b.size());
}

/* An unstamped image of n bytes: a header with magic, version, size, MCU 0x413, version 0.1.0. */
std::vector<uint8_t> image(size_t n)
{
	std::vector<uint8_t> b(n);
	for (size_t k = 0; k < n; k++)
		b[k] = (uint8_t)(k * 7 + 3);
	uint8_t *h = b.data() + SWELL_FWIMAGE_OFFSET;
	std::fill(h, h + SWELL_FWIMAGE_HDR_SIZE, 0);
	const uint32_t v[] = {SWELL_FWIMAGE_MAGIC, SWELL_FWIMAGE_HDR_VERSION | SWELL_FWIMAGE_HDR_SIZE << 16,
			      SWELL_FWIMAGE_MCU_STM32F405, SWELL_FWIMAGE_VERSION(0, 1, 0)};
	for (int w = 0; w < 4; w++)
		for (int k = 0; k < 4; k++)
			h[4 * w + k] = (uint8_t)(v[w] >> (8 * k));
	return b;
}

} // namespace

TEST_CASE("swell-fwimage: bad arguments exit 2, refused images and unreadable files exit 1, with the figures", "[fwimage][args]")
{
	char t[] = "/tmp/swell-fwimage-test-XXXXXX";
	REQUIRE(mkdtemp(t) != nullptr);
	const std::string dir = t, good = dir + "/good.bin";
	std::vector<uint8_t> img = image(3000);
	REQUIRE(swell_fwimage_stamp(img.data(), img.size()) == SWELL_OK);
	put(good, img);
	auto variant = [&](const char *name, std::vector<uint8_t> b) {
		put(dir + "/" + name, b);
		return dir + "/" + name;
	};
	std::vector<uint8_t> z = img, c = img, m = img;
	for (size_t k = 28; k < 32; k++) /* the header CRC zeroed */
		z.at(SWELL_FWIMAGE_OFFSET + k) = 0;
	c[2000] ^= 1;
	const std::string zeroed = variant("zeroed-hdr-crc.bin", z), flipped = variant("flipped.bin", c),
			  truncated = variant("truncated.bin", std::vector<uint8_t>(img.begin(), img.begin() + 2500)),
			  small = variant("small.bin", std::vector<uint8_t>(100, 0)),
			  noheader = variant("noheader.bin", std::vector<uint8_t>(1024, 0)),
			  unstamped = variant("unstamped.bin", image(3000));

	std::vector<swell_test::BadArgs> cases = {
		{{}, "need a command and an image", 2},
		{{"check"}, "need a command and an image", 2},
		{{"frob", good}, "unknown command (stamp or check): frob", 2},
		{{"check", good, "--mcu"}, "unknown or misplaced argument: --mcu", 2},
		{{"check", good, "--mcu", "zz"}, "--mcu is not a number: zz", 2},
		{{"check", good, "--header-out", "x"}, "unknown or misplaced argument: --header-out", 2},
		{{"stamp", good, "--mcu", "0x413"}, "unknown or misplaced argument: --mcu", 2},
		{{"check", good, "extra"}, "unknown or misplaced argument: extra", 2},
		{{"check", dir + "/missing.bin"}, "missing.bin: No such file or directory", 1},
		{{"check", dir}, "read error", 1},
		{{"check", zeroed}, "refused: corrupted header: header CRC-32 0x00000000, computed 0x", 1},
		{{"check", flipped}, "refused: corrupted image: image CRC-32 0x", 1},
		{{"check", truncated}, "refused: truncated: header length 3000 bytes, file holds 2500 bytes", 1},
		{{"check", small}, "refused: 100 bytes cannot hold the header (it ends at byte 544)", 1},
		{{"check", noheader}, "refused: no swell image header at 0x200", 1},
		{{"check", unstamped}, "refused: not stamped: header length 0", 1},
		{{"check", good, "--mcu", "0x419"}, "refused: foreign image: built for MCU 0x413, expected 0x419", 1},
		{{"stamp", noheader}, "cannot stamp: no swell image header at 0x200", 1},
		{{"stamp", good, "--header-out", "/nonexistent/h.bin"}, "/nonexistent/h.bin: No such file or directory", 1},
	};
	swell_test::check_bad_args(SWELL_FWIMAGE_BIN, cases);
	/* the positive control */
	const swell_test::Run ok = swell_test::run({SWELL_FWIMAGE_BIN, "check", good});
	CHECK(ok.code == 0);
	CHECK(ok.out.find("ok " + good + ": 3000 bytes, version 0.1.0, mcu 0x413") != std::string::npos);
	std::system(("rm -rf '" + dir + "'").c_str());
}
