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

namespace {

uint32_t crc_ref(const uint8_t *p, size_t n)
{
	static uint32_t table[256];
	if (!table[1])
		for (uint32_t i = 0; i < 256; i++) {
			uint32_t c = i;
			for (int k = 0; k < 8; k++)
				c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
			table[i] = c;
		}
	uint32_t c = 0xffffffffu;
	for (size_t i = 0; i < n; i++)
		c = table[(c ^ p[i]) & 0xff] ^ (c >> 8);
	return c ^ 0xffffffffu;
}

uint32_t adler_ref(const uint8_t *p, size_t n)
{
	uint32_t a = 1, b = 0;
	for (size_t i = 0; i < n; i++) {
		a = (a + p[i]) % 65521u;
		b = (b + a) % 65521u;
	}
	return b << 16 | a;
}

uint32_t be32(const uint8_t *p) { return uint32_t(p[0]) << 24 | p[1] << 16 | p[2] << 8 | p[3]; }

struct decoded {
	uint32_t w = 0, h = 0;
	unsigned channels = 0;
	std::vector<uint8_t> pixels;
	std::string error;
};

// Reads what swell_png_encode writes: stored blocks only, filter 0 only. Anything else is an error.
decoded decode(const std::vector<uint8_t> &f)
{
	decoded d;
	static const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
	if (f.size() < 8 || memcmp(f.data(), sig, 8) != 0) { d.error = "signature"; return d; }
	std::vector<uint8_t> z;
	size_t at = 8;
	bool end = false;
	while (!end) {
		if (at + 12 > f.size()) { d.error = "chunk runs past the end"; return d; }
		uint32_t len = be32(&f[at]);
		std::string type(reinterpret_cast<const char *>(&f[at + 4]), 4);
		if (at + 12 + len > f.size()) { d.error = "chunk data past the end"; return d; }
		if (crc_ref(&f[at + 4], 4 + len) != be32(&f[at + 8 + len])) { d.error = "CRC of " + type; return d; }
		const uint8_t *p = &f[at + 8];
		if (type == "IHDR") {
			d.w = be32(p);
			d.h = be32(p + 4);
			if (p[8] != 8 || (p[9] != 2 && p[9] != 6) || p[10] || p[11] || p[12]) { d.error = "IHDR"; return d; }
			d.channels = p[9] == 6 ? 4 : 3;
		} else if (type == "IDAT") {
			z.insert(z.end(), p, p + len);
		} else if (type == "IEND") {
			end = true;
		}
		at += 12 + len;
	}
	if (z.size() < 6 || ((z[0] << 8) | z[1]) % 31 != 0 || (z[0] & 15) != 8) { d.error = "zlib header"; return d; }
	std::vector<uint8_t> raw;
	size_t k = 2;
	for (bool last = false; !last;) {
		if (k + 5 > z.size()) { d.error = "block header past the end"; return d; }
		if ((z[k] >> 1) != 0) { d.error = "not a stored block"; return d; }
		last = z[k] & 1;
		uint32_t n = z[k + 1] | z[k + 2] << 8, nn = z[k + 3] | z[k + 4] << 8;
		if ((n ^ 0xffffu) != nn) { d.error = "LEN/NLEN"; return d; }
		k += 5;
		if (k + n > z.size()) { d.error = "block data past the end"; return d; }
		raw.insert(raw.end(), &z[k], &z[k] + n);
		k += n;
	}
	if (k + 4 != z.size() || be32(&z[k]) != adler_ref(raw.data(), raw.size())) { d.error = "Adler-32"; return d; }
	size_t row = 1 + size_t(d.w) * d.channels;
	if (raw.size() != row * d.h) { d.error = "raw size"; return d; }
	for (uint32_t y = 0; y < d.h; y++) {
		if (raw[y * row] != 0) { d.error = "filter"; return d; }
		d.pixels.insert(d.pixels.end(), &raw[y * row + 1], &raw[y * row] + row);
	}
	return d;
}

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
	struct { uint32_t w, h; unsigned ch; size_t pad; } cases[] = {
		{1, 1, 3, 0}, {200, 120, 3, 0}, {97, 300, 4, 5}, {16384, 2, 4, 0}, {3, 7, 3, 1}};
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
