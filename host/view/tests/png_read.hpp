// A PNG reader for the tests, independent of the encoder: chunk walk with its own CRC table, stored
// deflate blocks only, Adler-32 by its definition, filter 0 only. Anything else is reported as an error.
#pragma once

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace pngr {


inline uint32_t crc_ref(const uint8_t *p, size_t n)
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

inline uint32_t adler_ref(const uint8_t *p, size_t n)
{
	uint32_t a = 1, b = 0;
	for (size_t i = 0; i < n; i++) {
		a = (a + p[i]) % 65521u;
		b = (b + a) % 65521u;
	}
	return b << 16 | a;
}

inline uint32_t be32(const uint8_t *p) { return uint32_t(p[0]) << 24 | p[1] << 16 | p[2] << 8 | p[3]; }

struct decoded {
	uint32_t w = 0, h = 0;
	unsigned channels = 0;
	std::vector<uint8_t> pixels;
	std::string error;
};

// Reads what swell_png_encode writes: stored blocks only, filter 0 only. Anything else is an error.
inline decoded decode(const std::vector<uint8_t> &f)
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

inline decoded read_file(const std::string &path)
{
	std::ifstream in(path, std::ios::binary);
	std::vector<uint8_t> f((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
	if (f.empty()) {
		decoded d;
		d.error = "cannot read " + path;
		return d;
	}
	return decode(f);
}

} // namespace pngr
