/* Minimal PNG encoder, see png.h. Layout: signature, IHDR, one IDAT holding the whole zlib stream,
 * IEND. The zlib stream is a 2-byte header (CM 8, 32 K window, no dictionary), stored deflate blocks
 * of at most 65535 bytes, and the Adler-32 of the raw scanlines (filter byte + pixels). */
#include "png.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/crc.h"

#define STORED_MAX 65535u

uint32_t swell_adler32(uint32_t adler, const void *data, size_t len)
{
	const uint8_t *p = data;
	uint32_t a = adler & 0xffffu, b = adler >> 16;

	while (len > 0) {
		/* 5552 is the largest run for which b cannot overflow 32 bits before the modulo. */
		size_t n = len < 5552 ? len : 5552;

		len -= n;
		while (n--) {
			a += *p++;
			b += a;
		}
		a %= 65521u;
		b %= 65521u;
	}
	return (b << 16) | a;
}

static size_t raw_size(uint32_t w, uint32_t h, unsigned channels)
{
	return (size_t)h * (1u + (size_t)w * channels);
}

size_t swell_png_size(uint32_t w, uint32_t h, unsigned channels)
{
	if (w == 0 || h == 0 || (channels != 3 && channels != 4))
		return 0;
	if ((uint64_t)w * channels + 1u > (1u << 30) / h)
		return 0;
	size_t raw = raw_size(w, h, channels);
	size_t blocks = (raw + STORED_MAX - 1) / STORED_MAX;
	size_t zlib = 2 + blocks * 5 + raw + 4;

	/* signature + IHDR chunk (25) + IDAT header/CRC (12) + IEND (12) */
	return 8 + 25 + 12 + zlib + 12;
}

static uint8_t *put32(uint8_t *p, uint32_t v)
{
	p[0] = (uint8_t)(v >> 24);
	p[1] = (uint8_t)(v >> 16);
	p[2] = (uint8_t)(v >> 8);
	p[3] = (uint8_t)v;
	return p + 4;
}

/* Close a chunk whose type starts at `type`: append the CRC of type + data. */
static uint8_t *end_chunk(uint8_t *type, uint8_t *end)
{
	return put32(end, swell_crc32(0, type, (size_t)(end - type)));
}

enum swell_err swell_png_encode(uint8_t *out, size_t cap, size_t *len, const uint8_t *pixels, uint32_t w, uint32_t h,
				unsigned channels, size_t stride)
{
	static const uint8_t sig[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };

	if (!out || !len || !pixels || (channels != 3 && channels != 4))
		return SWELL_EINVAL;
	size_t need = swell_png_size(w, h, channels);
	if (need == 0 || cap < need || stride < (size_t)w * channels)
		return SWELL_ESIZE;

	uint8_t *p = out, *type;
	memcpy(p, sig, 8);
	p += 8;

	p = put32(p, 13);
	type = p;
	memcpy(p, "IHDR", 4);
	p = put32(p + 4, w);
	p = put32(p, h);
	*p++ = 8; /* bit depth */
	*p++ = channels == 4 ? 6 : 2; /* colour type: RGBA or RGB */
	*p++ = 0; /* deflate */
	*p++ = 0; /* adaptive filtering (we use filter 0 only) */
	*p++ = 0; /* no interlace */
	p = end_chunk(type, p);

	size_t raw = raw_size(w, h, channels);
	size_t blocks = (raw + STORED_MAX - 1) / STORED_MAX;
	p = put32(p, (uint32_t)(2 + blocks * 5 + raw + 4));
	type = p;
	memcpy(p, "IDAT", 4);
	p += 4;
	*p++ = 0x78; /* CMF: deflate, 32 K window */
	*p++ = 0x01; /* FLG: no dictionary, fastest; (0x78 << 8 | 0x01) % 31 == 0 */

	/* Stream the scanlines through stored blocks: a block may end in the middle of a row. */
	size_t row_bytes = 1 + (size_t)w * channels, left = raw, in_block = 0;
	uint32_t adler = 1;
	for (uint32_t y = 0; y < h; y++) {
		const uint8_t *row = pixels + (size_t)y * stride;
		for (size_t k = 0; k < row_bytes;) {
			if (in_block == 0) {
				size_t n = left < STORED_MAX ? left : STORED_MAX;
				*p++ = n == left ? 1 : 0; /* BFINAL on the last block, BTYPE 00 */
				*p++ = (uint8_t)n;
				*p++ = (uint8_t)(n >> 8);
				*p++ = (uint8_t)~n;
				*p++ = (uint8_t)(~n >> 8);
				in_block = n;
			}
			size_t n = row_bytes - k < in_block ? row_bytes - k : in_block;
			if (k == 0) {
				*p = 0; /* filter type None */
				adler = swell_adler32(adler, p, 1);
				p++;
				k++;
				n--;
				in_block--;
				left--;
			}
			memcpy(p, row + (k - 1), n);
			adler = swell_adler32(adler, p, n);
			p += n;
			k += n;
			in_block -= n;
			left -= n;
		}
	}
	p = put32(p, adler);
	p = end_chunk(type, p);

	p = put32(p, 0);
	type = p;
	memcpy(p, "IEND", 4);
	p = end_chunk(type, p + 4);

	*len = (size_t)(p - out);
	return SWELL_OK;
}

enum swell_err swell_png_write(const char *path, const uint8_t *pixels, uint32_t w, uint32_t h, unsigned channels,
			       size_t stride)
{
	if (!path)
		return SWELL_EINVAL;
	size_t cap = swell_png_size(w, h, channels), len = 0;
	if (cap == 0)
		return SWELL_ESIZE;
	uint8_t *buf = malloc(cap);
	if (!buf)
		return SWELL_ESIZE;
	enum swell_err err = swell_png_encode(buf, cap, &len, pixels, w, h, channels, stride);
	if (err == SWELL_OK) {
		FILE *f = fopen(path, "wb");
		if (!f || fwrite(buf, 1, len, f) != len)
			err = SWELL_ESTATE;
		if (f && fclose(f) != 0)
			err = SWELL_ESTATE;
	}
	free(buf);
	return err;
}
