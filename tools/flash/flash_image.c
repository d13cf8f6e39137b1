/* swell-flash image loading and checks: see flash_image.h. */
#include "flash_image.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/crc.h"

#define EM_ARM 40u
#define PT_LOAD 1u

static int fail(char *why, size_t why_len, const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(why, why_len, fmt, ap);
	va_end(ap);
	return -1;
}

static uint32_t le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint16_t le16(const uint8_t *p)
{
	return (uint16_t)(p[0] | p[1] << 8);
}

void flash_version_str(uint32_t v, char *out, size_t out_len)
{
	snprintf(out, out_len, "%u.%u.%u", (unsigned)(v >> 16), (unsigned)((v >> 8) & 0xFFu), (unsigned)(v & 0xFFu));
}

/* The flash bytes of an ELF32 little-endian ARM executable: every PT_LOAD segment with file bytes,
 * placed at its physical (load) address; gaps are zero as objcopy -O binary leaves them. */
static int elf_to_flash(const uint8_t *f, size_t n, uint8_t **out, size_t *out_len, char *why, size_t why_len)
{
	uint32_t phoff, i, end = 0;
	uint16_t phentsize, phnum;
	uint8_t *buf;

	if (n < 52)
		return fail(why, why_len, "ELF truncated: %zu bytes, header needs 52", n);
	if (f[4] != 1 || f[5] != 1)
		return fail(why, why_len, "foreign ELF: not 32-bit little-endian (class %u, data %u)", f[4], f[5]);
	if (le16(f + 18) != EM_ARM)
		return fail(why, why_len, "foreign ELF: machine %u, not ARM (40)", le16(f + 18));
	phoff = le32(f + 28);
	phentsize = le16(f + 42);
	phnum = le16(f + 44);
	if (phentsize < 32 || phnum == 0 || phoff > n || (size_t)phnum * phentsize > n - phoff)
		return fail(why, why_len, "ELF truncated or malformed: %u program headers at 0x%x", phnum,
			    (unsigned)phoff);
	for (i = 0; i < phnum; i++) {
		const uint8_t *ph = f + phoff + (size_t)i * phentsize;
		uint32_t off = le32(ph + 4), pa = le32(ph + 12), fsz = le32(ph + 16);

		if (le32(ph) != PT_LOAD || fsz == 0)
			continue;
		if (off > n || fsz > n - off)
			return fail(why, why_len, "ELF truncated: segment %u needs bytes to 0x%llx, file has 0x%zx", i,
				    (unsigned long long)off + fsz, n);
		if (pa < FLASH_BASE_ADDR || pa - FLASH_BASE_ADDR > FLASH_MAX_BYTES ||
		    fsz > FLASH_MAX_BYTES - (pa - FLASH_BASE_ADDR))
			return fail(why, why_len,
				    "foreign ELF: segment %u at 0x%08x (%u bytes) outside flash 0x%08x..0x%08x", i,
				    (unsigned)pa, (unsigned)fsz, FLASH_BASE_ADDR, FLASH_BASE_ADDR + FLASH_MAX_BYTES);
		if (pa - FLASH_BASE_ADDR + fsz > end)
			end = pa - FLASH_BASE_ADDR + fsz;
	}
	if (end == 0)
		return fail(why, why_len, "ELF has no loadable bytes");
	buf = calloc(1, end);
	if (!buf)
		return fail(why, why_len, "out of memory");
	for (i = 0; i < phnum; i++) {
		const uint8_t *ph = f + phoff + (size_t)i * phentsize;
		uint32_t fsz = le32(ph + 16);

		if (le32(ph) != PT_LOAD || fsz == 0)
			continue;
		memcpy(buf + (le32(ph + 12) - FLASH_BASE_ADDR), f + le32(ph + 4), fsz);
	}
	*out = buf;
	*out_len = end;
	return 0;
}

int flash_image_check(const uint8_t *file, size_t file_len, uint32_t want_mcu, struct flash_image *img, char *why,
		      size_t why_len)
{
	struct flash_image r = { 0 };
	struct swell_fwimage_hdr hdr = { 0 }; /* apart from r: a pointer into r hides r.bytes from the analyzer */
	enum swell_err err;

	if (file_len >= 4 && !memcmp(file, "\177ELF", 4)) {
		r.fmt = FLASH_FMT_ELF;
		/* r.bytes is set whenever elf_to_flash succeeds; the test is for the analyzer, which does
		 * not follow fail()'s return value through its variadic call */
		if (elf_to_flash(file, file_len, &r.bytes, &r.len, why, why_len) || !r.bytes)
			return -1;
	} else {
		r.fmt = FLASH_FMT_BIN;
		if (file_len > FLASH_MAX_BYTES)
			return fail(why, why_len, "image of %zu bytes is larger than the %u-byte flash", file_len,
				    FLASH_MAX_BYTES);
		r.bytes = malloc(file_len ? file_len : 1);
		if (!r.bytes)
			return fail(why, why_len, "out of memory");
		if (file_len)
			memcpy(r.bytes, file, file_len);
		r.len = file_len;
	}
	/* the length first: the messages below read header fields from the bytes */
	err = r.len < SWELL_FWIMAGE_OFFSET + SWELL_FWIMAGE_HDR_SIZE ? SWELL_ETRUNC
								    : swell_fwimage_read(r.bytes, r.len, &hdr);
	r.hdr = hdr;
	if (err == SWELL_ETRUNC) {
		fail(why, why_len, "truncated: %zu bytes, the header ends at byte %u", r.len,
		     SWELL_FWIMAGE_OFFSET + SWELL_FWIMAGE_HDR_SIZE);
	} else if (err == SWELL_EUNKNOWN) {
		fail(why, why_len, "no swell image header: magic at 0x%x is 0x%08x, want 0x%08x (\"SWIM\")",
		     SWELL_FWIMAGE_OFFSET, (unsigned)le32(r.bytes + SWELL_FWIMAGE_OFFSET), SWELL_FWIMAGE_MAGIC);
	} else if (err != SWELL_OK) {
		fail(why, why_len, "header version %u size %u, this tool reads version %u size %u",
		     le16(r.bytes + SWELL_FWIMAGE_OFFSET + 4), le16(r.bytes + SWELL_FWIMAGE_OFFSET + 6),
		     SWELL_FWIMAGE_HDR_VERSION, SWELL_FWIMAGE_HDR_SIZE);
	} else if (r.hdr.mcu_id != want_mcu) {
		fail(why, why_len, "foreign image: built for MCU 0x%03x, target is 0x%03x%s", (unsigned)r.hdr.mcu_id,
		     (unsigned)want_mcu, want_mcu == SWELL_FWIMAGE_MCU_STM32F405 ? " (STM32F405/407)" : "");
	} else if (r.hdr.length == 0) {
		fail(why, why_len, "not stamped: header length 0 (run swell-fwimage stamp after linking)");
	} else if (r.hdr.length != r.len) {
		fail(why, why_len, "%s: header length %u bytes, image holds %zu bytes",
		     r.hdr.length > r.len ? "truncated" : "length mismatch", (unsigned)r.hdr.length, r.len);
	} else if (swell_fwimage_verify(r.bytes, r.len, want_mcu, &hdr) != SWELL_OK) {
		/* which CRC: a zeroed header CRC was reported as an image CRC "mismatch" of two equal numbers */
		const uint32_t hdr_crc = swell_crc32(0, r.bytes + SWELL_FWIMAGE_OFFSET, 28);

		if (hdr_crc != r.hdr.hdr_crc)
			fail(why, why_len, "corrupted header: header CRC-32 0x%08x, computed 0x%08x",
			     (unsigned)r.hdr.hdr_crc, (unsigned)hdr_crc);
		else
			fail(why, why_len, "corrupted: CRC-32 mismatch (header says image 0x%08x, computed 0x%08x)",
			     (unsigned)r.hdr.crc, (unsigned)swell_fwimage_crc(r.bytes, r.len));
	} else if (hdr.flags != 0) {
		fail(why, why_len, "header flags 0x%08x unknown to this tool (want 0)", (unsigned)hdr.flags);
	} else {
		r.hdr = hdr;
		*img = r;
		return 0;
	}
	free(r.bytes);
	return -1;
}

int flash_read_file(const char *path, size_t max, uint8_t **buf, size_t *len, char *why, size_t why_len)
{
	FILE *f = fopen(path, "rb");
	uint8_t *b;
	size_t n;
	int bad;

	if (!f)
		return fail(why, why_len, "%s: %s", path, strerror(errno));
	b = malloc(max + 1);
	n = b ? fread(b, 1, max + 1, f) : 0;
	bad = b && ferror(f);
	fclose(f);
	if (!b)
		return fail(why, why_len, "out of memory");
	if (bad || n > max) {
		free(b);
		return bad ? fail(why, why_len, "%s: read error", path)
			   : fail(why, why_len, "%s: larger than %zu bytes", path, max);
	}
	*buf = b;
	*len = n;
	return 0;
}

void flash_image_free(struct flash_image *img)
{
	free(img->bytes);
	img->bytes = NULL;
	img->len = 0;
}
