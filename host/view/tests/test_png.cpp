// PNG encoder: decoded by an independent reader written here (chunk walk, its own CRC table, stored
// deflate blocks, Adler-32 by definition), so the encoder is checked against the format, not itself.
#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

extern "C" {
#include "png.h"
}

#include "png_read.hpp"

using namespace pngr;

namespace {

std::vector<uint8_t> pattern(uint32_t h, size_t stride)
{
	std::vector<uint8_t> px(stride * h);
	uint32_t s = 12345;
	for (auto &b : px) {
		s = s * 1103515245u + 12345u;
		b = uint8_t(s >> 16);
	}
	return px;
}

} // namespace

TEST_CASE("Adler-32 matches its definition, including runs longer than the 5552-byte block")
{
	const char *w = "Wikipedia";
	CHECK(swell_adler32(1, w, strlen(w)) == 0x11E60398u);
	std::vector<uint8_t> big(100000, 0xff);
	CHECK(swell_adler32(1, big.data(), big.size()) == adler_ref(big.data(), big.size()));
	// feeding in pieces gives the same value
	uint32_t a = swell_adler32(1, big.data(), 7000);
	a = swell_adler32(a, big.data() + 7000, big.size() - 7000);
	CHECK(a == adler_ref(big.data(), big.size()));
}

TEST_CASE("PNG round-trips through an independent reader, stored blocks split inside rows")
{
	// 200 x 120 RGB is 72 120 raw bytes: two stored blocks, the split falls inside a row.
	struct {
		uint32_t w, h;
		unsigned ch;
		size_t pad;
	} cases[] = {{1, 1, 3, 0}, {200, 120, 3, 0}, {97, 300, 4, 5}, {16384, 2, 4, 0}, {3, 7, 3, 1}};
	for (auto c : cases) {
		size_t stride = size_t(c.w) * c.ch + c.pad;
		auto px = pattern(c.h, stride);
		std::vector<uint8_t> out(swell_png_size(c.w, c.h, c.ch));
		size_t len = 0;
		INFO("image " << c.w << " x " << c.h << " x " << c.ch << ", stride " << stride);
		REQUIRE(swell_png_encode(out.data(), out.size(), &len, px.data(), c.w, c.h, c.ch, stride) == SWELL_OK);
		CHECK(len == out.size());
		out.resize(len);
		decoded d = decode(out);
		REQUIRE(d.error == "");
		CHECK(d.w == c.w);
		CHECK(d.h == c.h);
		CHECK(d.channels == c.ch);
		size_t mismatches = 0;
		for (uint32_t y = 0; y < c.h; y++)
			mismatches += memcmp(&d.pixels[y * c.w * c.ch], &px[y * stride], size_t(c.w) * c.ch) != 0;
		CHECK(mismatches == 0);
	}
}

TEST_CASE("PNG encoder rejects bad arguments and leaves the buffer untouched")
{
	uint8_t px[12] = {0};
	std::vector<uint8_t> out(swell_png_size(2, 2, 3), 0xaa);
	size_t len = 99;
	CHECK(swell_png_encode(out.data(), out.size(), &len, px, 2, 2, 2, 6) == SWELL_EINVAL);
	CHECK(swell_png_encode(out.data(), out.size() - 1, &len, px, 2, 2, 3, 6) == SWELL_ESIZE);
	CHECK(swell_png_encode(out.data(), out.size(), &len, px, 0, 2, 3, 6) == SWELL_ESIZE);
	CHECK(swell_png_encode(out.data(), out.size(), &len, px, 2, 2, 3, 5) == SWELL_ESIZE);
	CHECK(swell_png_encode(out.data(), out.size(), nullptr, px, 2, 2, 3, 6) == SWELL_EINVAL);
	CHECK(len == 99);
	size_t touched = 0;
	for (uint8_t b : out)
		touched += b != 0xaa;
	CHECK(touched == 0);
	CHECK(swell_png_size(1u << 20, 1u << 20, 4) == 0);
}
