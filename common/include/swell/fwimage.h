/* Controller image header: 32 bytes, little-endian, at byte offset SWELL_FWIMAGE_OFFSET of the
 * image (right after the Cortex-M vector table). The linker leaves length and both CRCs zero; a host
 * tool stamps them after linking; the firmware checks them at boot and a flasher before writing.
 *
 *   off  size  field
 *    0    4    magic        "SWIM" (0x4D495753)
 *    4    2    hdr_version  1
 *    6    2    hdr_size     32
 *    8    4    mcu_id       target MCU (DBGMCU_IDCODE.DEV_ID: 0x413 for STM32F405/407)
 *   12    4    version      firmware version, major << 16 | minor << 8 | patch
 *   16    4    length       image bytes from offset 0 (header included)
 *   20    4    crc          swell_crc32 of the whole image with bytes 20..23 and 28..31 read as 0
 *   24    4    flags        0
 *   28    4    hdr_crc      swell_crc32 of bytes 0..27 (after crc is filled in)
 */
#ifndef SWELL_FWIMAGE_H
#define SWELL_FWIMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"

#define SWELL_FWIMAGE_MAGIC 0x4D495753u
#define SWELL_FWIMAGE_OFFSET 0x200u
#define SWELL_FWIMAGE_HDR_VERSION 1u
#define SWELL_FWIMAGE_HDR_SIZE 32u
#define SWELL_FWIMAGE_MCU_STM32F405 0x413u
#define SWELL_FWIMAGE_VERSION(maj, min, pat) (((uint32_t)(maj) << 16) | ((min) << 8) | (pat))

struct swell_fwimage_hdr {
	uint32_t magic;
	uint16_t hdr_version, hdr_size;
	uint32_t mcu_id, version, length, crc, flags, hdr_crc;
};

/* Decode the header fields of img (no CRC check). SWELL_ETRUNC when len cannot hold a header,
 * SWELL_EUNKNOWN for a bad magic, SWELL_EVERSION for another header version or size. */
enum swell_err swell_fwimage_read(const uint8_t *img, size_t len, struct swell_fwimage_hdr *h);

/* The image CRC as defined above, over img[0, len); len must cover the header. */
uint32_t swell_fwimage_crc(const uint8_t *img, size_t len);

/* Fill length = len, crc and hdr_crc in place. Errors as swell_fwimage_read; SWELL_ESIZE when len
 * does not fit 32 bits. Nothing written on error. */
enum swell_err swell_fwimage_stamp(uint8_t *img, size_t len);

/* Full check of an image of which avail bytes are readable (the flash size on target):
 * header as swell_fwimage_read, then SWELL_EINVAL when mcu_id differs from want_mcu,
 * SWELL_ETRUNC when length is below the header end or beyond avail, SWELL_ECRC when either CRC
 * differs. On success *h (if not null) holds the header. */
enum swell_err swell_fwimage_verify(const uint8_t *img, size_t avail, uint32_t want_mcu, struct swell_fwimage_hdr *h);

#endif
