/* Minimal PNG encoder: 8-bit RGB or RGBA, filter 0 on every row, zlib stream of stored (uncompressed)
 * deflate blocks, CRC-32 from swell_crc32 and Adler-32 computed here. No compression on purpose: it is
 * small, has no dependency and is fast enough for screenshots (a 1024 x 768 RGB image is 2.3 MB). */
#ifndef SWELL_VIEW_PNG_H
#define SWELL_VIEW_PNG_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"

/* Adler-32 of zlib (RFC 1950): start with adler = 1. */
uint32_t swell_adler32(uint32_t adler, const void *data, size_t len);

/* Bytes swell_png_encode writes for a w x h image of `channels` (3 or 4) bytes a pixel; 0 when the
 * image is empty or too large (over 2^31 bytes). */
size_t swell_png_size(uint32_t w, uint32_t h, unsigned channels);

/* Encode rows of `stride` bytes (top row first) into out[cap]. *len gets the byte count.
 * SWELL_EINVAL (null pointer, channels not 3 or 4), SWELL_ESIZE (empty, too large, or cap too small). */
enum swell_err swell_png_encode(uint8_t *out, size_t cap, size_t *len, const uint8_t *pixels, uint32_t w, uint32_t h,
				unsigned channels, size_t stride);

/* Encode and write to a file; SWELL_ESTATE when the file cannot be written. */
enum swell_err swell_png_write(const char *path, const uint8_t *pixels, uint32_t w, uint32_t h, unsigned channels,
			       size_t stride);

#endif
