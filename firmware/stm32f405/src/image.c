#include "image.h"

#include "swell/fwimage.h"

#define FLASH_BASE 0x08000000u
#define FLASH_SIZE (1024u * 1024u)

#ifndef SWELL_FW_VERSION
#define SWELL_FW_VERSION SWELL_FWIMAGE_VERSION(0, 0, 0)
#endif

_Static_assert(sizeof(struct swell_fwimage_hdr) == SWELL_FWIMAGE_HDR_SIZE, "header layout");

/* length and CRCs are zero here; the stamping tool fills them in the ELF and the BIN. */
__attribute__((section(".image_header"), used)) static const struct swell_fwimage_hdr header = {
	.magic = SWELL_FWIMAGE_MAGIC,
	.hdr_version = SWELL_FWIMAGE_HDR_VERSION,
	.hdr_size = SWELL_FWIMAGE_HDR_SIZE,
	.mcu_id = SWELL_FWIMAGE_MCU_STM32F405,
	.version = SWELL_FW_VERSION,
};

enum swell_err image_check(struct image_info *out)
{
	struct swell_fwimage_hdr h;
	/* Read the flash through a volatile-free alias of the linked header's address: the compiler
	 * must not constant-fold the zero fields of `header` (they are changed after linking). */
	const uint8_t *img = (const uint8_t *)(uintptr_t)FLASH_BASE;
	enum swell_err err;

	__asm__ volatile("" : "+r"(img));
	err = swell_fwimage_verify(img, FLASH_SIZE, SWELL_FWIMAGE_MCU_STM32F405, &h);
	if (err != SWELL_OK)
		return err;
	out->version = h.version;
	out->length = h.length;
	out->crc = h.crc;
	return SWELL_OK;
}

uint32_t image_version(void)
{
	const uint8_t *hdr = (const uint8_t *)(uintptr_t)(FLASH_BASE + SWELL_FWIMAGE_OFFSET);

	__asm__ volatile("" : "+r"(hdr)); /* the stamped flash, not the linked constant */
	return (uint32_t)hdr[12] | (uint32_t)hdr[13] << 8 | (uint32_t)hdr[14] << 16 | (uint32_t)hdr[15] << 24;
}
