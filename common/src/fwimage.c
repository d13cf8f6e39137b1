/* Controller image header: see fwimage.h for the layout. */
#include "swell/fwimage.h"

#include "swell/crc.h"

#define OFF_CRC (SWELL_FWIMAGE_OFFSET + 20u)
#define OFF_HDR_CRC (SWELL_FWIMAGE_OFFSET + 28u)

static uint32_t get32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put32(uint8_t *p, uint32_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
	p[2] = (uint8_t)(v >> 16);
	p[3] = (uint8_t)(v >> 24);
}

enum swell_err swell_fwimage_read(const uint8_t *img, size_t len, struct swell_fwimage_hdr *h)
{
	const uint8_t *p;
	struct swell_fwimage_hdr r;

	if (!img || !h)
		return SWELL_EINVAL;
	if (len < SWELL_FWIMAGE_OFFSET + SWELL_FWIMAGE_HDR_SIZE)
		return SWELL_ETRUNC;
	p = img + SWELL_FWIMAGE_OFFSET;
	r.magic = get32(p);
	r.hdr_version = (uint16_t)(p[4] | p[5] << 8);
	r.hdr_size = (uint16_t)(p[6] | p[7] << 8);
	r.mcu_id = get32(p + 8);
	r.version = get32(p + 12);
	r.length = get32(p + 16);
	r.crc = get32(p + 20);
	r.flags = get32(p + 24);
	r.hdr_crc = get32(p + 28);
	if (r.magic != SWELL_FWIMAGE_MAGIC)
		return SWELL_EUNKNOWN;
	if (r.hdr_version != SWELL_FWIMAGE_HDR_VERSION || r.hdr_size != SWELL_FWIMAGE_HDR_SIZE)
		return SWELL_EVERSION;
	*h = r;
	return SWELL_OK;
}

uint32_t swell_fwimage_crc(const uint8_t *img, size_t len)
{
	static const uint8_t zero[4];
	uint32_t c;

	c = swell_crc32(0, img, OFF_CRC);
	c = swell_crc32(c, zero, 4);
	c = swell_crc32(c, img + OFF_CRC + 4, OFF_HDR_CRC - (OFF_CRC + 4));
	c = swell_crc32(c, zero, 4);
	return swell_crc32(c, img + OFF_HDR_CRC + 4, len - (OFF_HDR_CRC + 4));
}

enum swell_err swell_fwimage_stamp(uint8_t *img, size_t len)
{
	struct swell_fwimage_hdr h;
	enum swell_err err = swell_fwimage_read(img, len, &h);
	uint8_t *p;

	if (err != SWELL_OK)
		return err;
	if (len > UINT32_MAX)
		return SWELL_ESIZE;
	p = img + SWELL_FWIMAGE_OFFSET;
	put32(p + 16, (uint32_t)len);
	put32(p + 20, swell_fwimage_crc(img, len));
	put32(p + 28, swell_crc32(0, p, 28));
	return SWELL_OK;
}

enum swell_err swell_fwimage_verify(const uint8_t *img, size_t avail, uint32_t want_mcu, struct swell_fwimage_hdr *out)
{
	struct swell_fwimage_hdr h;
	enum swell_err err = swell_fwimage_read(img, avail, &h);

	if (err != SWELL_OK)
		return err;
	if (h.mcu_id != want_mcu)
		return SWELL_EINVAL;
	if (h.length < SWELL_FWIMAGE_OFFSET + SWELL_FWIMAGE_HDR_SIZE || h.length > avail)
		return SWELL_ETRUNC;
	if (swell_crc32(0, img + SWELL_FWIMAGE_OFFSET, 28) != h.hdr_crc || swell_fwimage_crc(img, h.length) != h.crc)
		return SWELL_ECRC;
	if (out)
		*out = h;
	return SWELL_OK;
}
