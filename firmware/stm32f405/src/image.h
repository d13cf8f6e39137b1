/* This image's header (in section .image_header, stamped after linking) and its boot check. */
#ifndef SWELL_FW_IMAGE_H
#define SWELL_FW_IMAGE_H

#include <stdint.h>

#include "swell/err.h"

struct image_info {
	uint32_t version, length, crc;
};

/* Verify the header and CRC of the image in flash; the controller refuses to run on any error. */
enum swell_err image_check(struct image_info *out);

/* The header's version field (major << 16 | minor << 8 | patch) as stamped in flash. */
uint32_t image_version(void);

#endif
