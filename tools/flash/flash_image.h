/* swell-flash image loading and checks (host only). An image is a BIN (the bytes written at the
 * flash base) or an ARM ELF whose loadable segments (by physical address) are turned into the same
 * bytes. Every check runs before any tool touches a target. */
#ifndef SWELL_FLASH_IMAGE_H
#define SWELL_FLASH_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "swell/fwimage.h"

#define FLASH_BASE_ADDR 0x08000000u
#define FLASH_MAX_BYTES (1024u * 1024u) /* STM32F405 flash */

enum flash_fmt {
	FLASH_FMT_BIN,
	FLASH_FMT_ELF
};

struct flash_image {
	enum flash_fmt fmt;
	uint8_t *bytes; /* flash contents from FLASH_BASE_ADDR, len bytes (malloc'd) */
	size_t len;
	struct swell_fwimage_hdr hdr;
};

/* Check a file's bytes: ELF or BIN, header magic/version, MCU want_mcu, length, both CRCs, flags,
 * and for a BIN that the file is exactly the header's length. On success fills *img (free with
 * flash_image_free) and returns 0; otherwise returns -1 and writes a one-line reason (no newline)
 * into why. */
int flash_image_check(const uint8_t *file, size_t file_len, uint32_t want_mcu, struct flash_image *img, char *why,
		      size_t why_len);

/* Read path into a malloc'd buffer (at most max bytes; more is an error). 0 or -1 with why. */
int flash_read_file(const char *path, size_t max, uint8_t **buf, size_t *len, char *why, size_t why_len);

void flash_image_free(struct flash_image *img);

/* "major.minor.patch" of a header version word. */
void flash_version_str(uint32_t version, char *out, size_t out_len);

#endif
