/* swell-fwimage: stamp and check the controller image header (swell/fwimage.h). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/crc.h"
#include "swell/fwimage.h"

#define MAX_IMAGE (16u * 1024u * 1024u)

static const char usage[] =
	"usage: swell-fwimage stamp IMAGE.bin [--header-out FILE]\n"
	"       swell-fwimage check IMAGE.bin [--mcu ID]\n"
	"Controller image header (32 bytes at offset 0x200: magic, MCU id, version, length, CRC-32).\n"
	"  stamp   fill length and CRCs in IMAGE.bin in place after linking; --header-out also writes\n"
	"          the 32 header bytes to FILE (for objcopy --update-section into the ELF)\n"
	"  check   verify header and CRC; --mcu expects that MCU id (default 0x413, STM32F405)\n"
	"Exit status: 0 ok, 1 image refused or a file that cannot be read or written (the reason on one\n"
	"line), 2 bad arguments.\n";

_Noreturn static void die(const char *what, const char *arg)
{
	fprintf(stderr, "swell-fwimage: %s%s%s\n", what, arg ? ": " : "", arg ? arg : "");
	exit(2);
}

/* A runtime failure (a file): the reason, exit 1. */
_Noreturn static void fail(const char *path, const char *why)
{
	fprintf(stderr, "swell-fwimage: %s: %s\n", path, why);
	exit(1);
}

/* Why a header or image is refused, with the figures (what swell_fwimage_verify only names). */
static void explain(const uint8_t *img, size_t len, uint32_t want_mcu, enum swell_err err, char *why, size_t n)
{
	struct swell_fwimage_hdr h = { 0 };
	const int hdr_ok = swell_fwimage_read(img, len, &h) == SWELL_OK;
	/* the CRCs only of a header that is there, for this MCU and as long as the file */
	const int sized = hdr_ok && h.mcu_id == want_mcu && h.length == len;
	const uint32_t hdr_crc = sized ? swell_crc32(0, img + SWELL_FWIMAGE_OFFSET, 28) : 0;
	const uint32_t crc = sized ? swell_fwimage_crc(img, len) : 0;

	if (!hdr_ok && err == SWELL_ETRUNC)
		snprintf(why, n, "%zu bytes cannot hold the header (it ends at byte %u)", len,
			 SWELL_FWIMAGE_OFFSET + SWELL_FWIMAGE_HDR_SIZE);
	else if (!hdr_ok && err == SWELL_EUNKNOWN)
		snprintf(why, n, "no swell image header at 0x%x (magic is not \"SWIM\")", SWELL_FWIMAGE_OFFSET);
	else if (!hdr_ok)
		snprintf(why, n, "header version or size unknown to this tool (want version %u, %u bytes)",
			 SWELL_FWIMAGE_HDR_VERSION, SWELL_FWIMAGE_HDR_SIZE);
	else if (h.mcu_id != want_mcu)
		snprintf(why, n, "foreign image: built for MCU 0x%03x, expected 0x%03x", (unsigned)h.mcu_id,
			 (unsigned)want_mcu);
	else if (h.length == 0)
		snprintf(why, n, "not stamped: header length 0 (run swell-fwimage stamp after linking)");
	else if (h.length != len)
		snprintf(why, n, "%s: header length %u bytes, file holds %zu bytes",
			 h.length > len ? "truncated" : "length mismatch", (unsigned)h.length, len);
	else if (hdr_crc != h.hdr_crc)
		snprintf(why, n, "corrupted header: header CRC-32 0x%08x, computed 0x%08x", (unsigned)h.hdr_crc,
			 (unsigned)hdr_crc);
	else if (crc != h.crc)
		snprintf(why, n, "corrupted image: image CRC-32 0x%08x in the header, computed 0x%08x", (unsigned)h.crc,
			 (unsigned)crc);
	else
		snprintf(why, n, "%s", swell_err_str(err));
}

/* The whole file (at most MAX_IMAGE bytes), or NULL with the reason said. */
static uint8_t *load(const char *path, size_t *len)
{
	uint8_t *buf = malloc(MAX_IMAGE + 1);
	const char *why = NULL;
	size_t n = 0;
	FILE *f;

	if (!buf)
		fail(path, "out of memory");
	f = fopen(path, "rb");
	if (!f) {
		why = strerror(errno);
	} else {
		n = fread(buf, 1, MAX_IMAGE + 1, f);
		if (ferror(f))
			why = "read error";
		else if (n > MAX_IMAGE)
			why = "image larger than 16 MiB";
		fclose(f);
	}
	if (why) { /* said here, the caller exits 1 */
		fprintf(stderr, "swell-fwimage: %s: %s\n", path, why);
		free(buf);
		return NULL;
	}
	*len = n;
	return buf;
}

/* A runtime failure the caller cleans up after: the reason, -1. */
static int fail_soft(const char *path, const char *why)
{
	fprintf(stderr, "swell-fwimage: %s: %s\n", path, why);
	return -1;
}

static int save(const char *path, const uint8_t *buf, size_t len)
{
	FILE *f = fopen(path, "wb");

	if (!f)
		return fail_soft(path, strerror(errno));
	if ((fwrite(buf, 1, len, f) != len) | (fclose(f) != 0))
		return fail_soft(path, strerror(errno));
	return 0;
}

static void print_hdr(const char *verb, const char *path, const struct swell_fwimage_hdr *h)
{
	printf("%s %s: %u bytes, version %u.%u.%u, mcu 0x%03x, crc32 0x%08x\n", verb, path, (unsigned)h->length,
	       (unsigned)(h->version >> 16), (unsigned)((h->version >> 8) & 0xFF), (unsigned)(h->version & 0xFF),
	       (unsigned)h->mcu_id, (unsigned)h->crc);
}

int main(int argc, char **argv)
{
	const char *cmd, *path, *hdr_out = NULL;
	unsigned long mcu = SWELL_FWIMAGE_MCU_STM32F405;
	struct swell_fwimage_hdr h = { 0 };
	enum swell_err err;
	uint8_t *img;
	size_t len;
	char why[160];
	int i, rc = 0;

	for (i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
			fputs(usage, stdout);
			return 0;
		}
	}
	if (argc < 3)
		die("need a command and an image (see --help)", NULL);
	cmd = argv[1];
	path = argv[2];
	for (i = 3; i < argc; i++) {
		if (!strcmp(argv[i], "--header-out") && i + 1 < argc && !strcmp(cmd, "stamp")) {
			hdr_out = argv[++i];
		} else if (!strcmp(argv[i], "--mcu") && i + 1 < argc && !strcmp(cmd, "check")) {
			char *end;

			mcu = strtoul(argv[++i], &end, 0);
			if (*end || mcu > 0xFFFFFFFFul)
				die("--mcu is not a number", argv[i]);
		} else {
			die("unknown or misplaced argument", argv[i]);
		}
	}
	if (strcmp(cmd, "stamp") && strcmp(cmd, "check"))
		die("unknown command (stamp or check)", cmd);

	img = load(path, &len);
	if (!img)
		return 1;
	if (!strcmp(cmd, "stamp")) {
		err = swell_fwimage_stamp(img, len);
		if (err != SWELL_OK) {
			explain(img, len, SWELL_FWIMAGE_MCU_STM32F405, err, why, sizeof(why));
			fprintf(stderr, "swell-fwimage: %s: cannot stamp: %s\n", path, why);
			rc = 1;
		} else if (save(path, img, len) != 0 ||
			   (hdr_out && save(hdr_out, img + SWELL_FWIMAGE_OFFSET, SWELL_FWIMAGE_HDR_SIZE) != 0)) {
			rc = 1;
		} else {
			(void)swell_fwimage_read(img, len, &h);
			print_hdr("stamped", path, &h);
		}
	} else {
		err = swell_fwimage_verify(img, len, (uint32_t)mcu, &h);
		if (err == SWELL_OK && h.length != len)
			err = SWELL_ETRUNC;
		if (err != SWELL_OK) {
			explain(img, len, (uint32_t)mcu, err, why, sizeof(why));
			fprintf(stderr, "swell-fwimage: %s: refused: %s\n", path, why);
			rc = 1;
		} else {
			print_hdr("ok", path, &h);
		}
	}
	free(img);
	return rc;
}
