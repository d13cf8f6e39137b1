/* swell-fwimage: stamp and check the controller image header (swell/fwimage.h). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/fwimage.h"

#define MAX_IMAGE (16u * 1024u * 1024u)

static const char usage[] =
	"usage: swell-fwimage stamp IMAGE.bin [--header-out FILE]\n"
	"       swell-fwimage check IMAGE.bin [--mcu ID]\n"
	"Controller image header (32 bytes at offset 0x200: magic, MCU id, version, length, CRC-32).\n"
	"  stamp   fill length and CRCs in IMAGE.bin in place after linking; --header-out also writes\n"
	"          the 32 header bytes to FILE (for objcopy --update-section into the ELF)\n"
	"  check   verify header and CRC; --mcu expects that MCU id (default 0x413, STM32F405)\n"
	"Exit status: 0 ok, 1 image refused, 2 bad arguments or I/O error.\n";

static void die(const char *what, const char *arg)
{
	fprintf(stderr, "swell-fwimage: %s%s%s\n", what, arg ? ": " : "", arg ? arg : "");
	exit(2);
}

static uint8_t *load(const char *path, size_t *len)
{
	FILE *f = fopen(path, "rb");
	uint8_t *buf;
	size_t n;

	if (!f)
		die(strerror(errno), path);
	buf = malloc(MAX_IMAGE + 1);
	if (!buf)
		die("out of memory", NULL);
	n = fread(buf, 1, MAX_IMAGE + 1, f);
	if (ferror(f))
		die("read error", path);
	fclose(f);
	if (n > MAX_IMAGE)
		die("image larger than 16 MiB", path);
	*len = n;
	return buf;
}

static void save(const char *path, const uint8_t *buf, size_t len)
{
	FILE *f = fopen(path, "wb");

	if (!f)
		die(strerror(errno), path);
	if (fwrite(buf, 1, len, f) != len || fclose(f) != 0)
		die("write error", path);
}

static void print_hdr(const char *verb, const char *path, const struct swell_fwimage_hdr *h)
{
	printf("%s %s: %u bytes, version %u.%u.%u, mcu 0x%03x, crc32 0x%08x\n", verb, path,
	       (unsigned)h->length, (unsigned)(h->version >> 16), (unsigned)((h->version >> 8) & 0xFF),
	       (unsigned)(h->version & 0xFF), (unsigned)h->mcu_id, (unsigned)h->crc);
}

int main(int argc, char **argv)
{
	const char *cmd, *path, *hdr_out = NULL;
	unsigned long mcu = SWELL_FWIMAGE_MCU_STM32F405;
	struct swell_fwimage_hdr h;
	enum swell_err err;
	uint8_t *img;
	size_t len;
	int i;

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
	if (!strcmp(cmd, "stamp")) {
		err = swell_fwimage_stamp(img, len);
		if (err != SWELL_OK) {
			fprintf(stderr, "swell-fwimage: %s: cannot stamp: %s\n", path, swell_err_str(err));
			return 1;
		}
		save(path, img, len);
		if (hdr_out)
			save(hdr_out, img + SWELL_FWIMAGE_OFFSET, SWELL_FWIMAGE_HDR_SIZE);
		(void)swell_fwimage_read(img, len, &h);
		print_hdr("stamped", path, &h);
	} else {
		err = swell_fwimage_verify(img, len, (uint32_t)mcu, &h);
		if (err != SWELL_OK) {
			fprintf(stderr, "swell-fwimage: %s: refused: %s\n", path, swell_err_str(err));
			return 1;
		}
		if (h.length != len) {
			fprintf(stderr, "swell-fwimage: %s: refused: header length %u != file size %zu bytes\n",
				path, (unsigned)h.length, len);
			return 1;
		}
		print_hdr("ok", path, &h);
	}
	free(img);
	return 0;
}
