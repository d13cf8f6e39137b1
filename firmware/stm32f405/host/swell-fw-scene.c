/* swell-fw-scene: the controller self-test scene (logic/scene.h) run on the host build of common/,
 * so the QEMU run of the image can be compared with it bit for bit. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../logic/scene.h"

static const char usage[] =
	"usage: swell-fw-scene [--steps N]\n"
	"Runs the STM32F405 self-test scene on the host: 64x64 pool, dx 6.25 mm, depth 50 mm,\n"
	"dt 4 ms, paper stencil, no damping, Gaussian 2 mm sigma 3 cells at (32,32); N solver steps\n"
	"(default 200). Prints the state checksum (CRC-32 of heights and flows) and the volume.\n";

int main(int argc, char **argv)
{
	static int32_t storage[FW_SCENE_WORDS];
	struct swell_wave w;
	unsigned long steps = 200, n;
	enum swell_err err;
	int i;

	for (i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
			fputs(usage, stdout);
			return 0;
		} else if (!strcmp(argv[i], "--steps") && i + 1 < argc) {
			char *end;

			steps = strtoul(argv[++i], &end, 10);
			if (*end || !*argv[i] || steps > 100000000ul) {
				fprintf(stderr, "swell-fw-scene: --steps '%s' is not a count in [0, 1e8]\n",
					argv[i]);
				return 2;
			}
		} else {
			fprintf(stderr, "swell-fw-scene: unknown argument '%s' (see --help)\n", argv[i]);
			return 2;
		}
	}
	err = fw_scene_init(&w, storage, FW_SCENE_WORDS);
	if (err != SWELL_OK) {
		fprintf(stderr, "swell-fw-scene: scene refused: %s\n", swell_err_str(err));
		return 1;
	}
	for (n = 0; n < steps; n++)
		swell_wave_step(&w);
	printf("steps %lu\n", steps);
	printf("e 0x%08x (Q1.30)\n", (unsigned)w.p.e);
	printf("checksum 0x%08x\n", (unsigned)swell_wave_checksum(&w));
	printf("volume %lld LSB (2^-16 mm per cell)\n", (long long)swell_wave_volume(&w));
	return 0;
}
