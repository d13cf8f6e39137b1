/* swell-fw-scene: the controller self-test scene (logic/scene.h) run on the host build of common/,
 * so the QEMU run of the image can be compared with it bit for bit. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../logic/core_run.h"
#include "swell/ctl_pool.h"
#include "swell/cli.h"
#include "swell/scene.h"
#include "../logic/scene.h"

static const char usage[] =
	"usage: swell-fw-scene [--steps N] [--core TICKS] [--core-hz HZ] [--cost]\n"
	"Runs the STM32F405 self-test scene on the host: 64x64 pool, dx 6.25 mm, depth 50 mm,\n"
	"dt 4 ms, paper stencil, no damping, Gaussian 2 mm sigma 3 cells at (32,32); N solver steps\n"
	"(default 200). Prints the state checksum (CRC-32 of heights and momenta) and the volume.\n"
	"--core TICKS: also run the controller core on that scene at 2500 Hz for TICKS ticks with the\n"
	"self-test's scripted device, and print its checksum (FORCE_CMD payloads, then the water).\n"
	"--core-hz HZ: the core's tick rate for --core (default 2500; the image also runs 1000).\n"
	"--pool N: the core on an N x N pool instead, set as the image's self-test sets it (PARAM_SET of\n"
	"  pool.nx and pool.ny through the core's ctl_pool.c; the same bits wherever the buffers are).\n"
	"--cost: also run the three cost scenes (calm, local, agitated; damped, 40 steps) and print\n"
	"  each one's checksum, as the image's self-test does.\n"
	"--kernel ref|fused|avx2: the solver kernel (default: the fastest; all are bit-identical).\n"
	"Exit status: 0 done, 1 a scene or the core refused its set-up, 2 bad arguments or a kernel\n"
	"this machine does not have.\n";

/* A scene bound with err: the kernel chosen, then steps of it; 0 (said why) when either is refused. */
static int run_steps(struct swell_wave *w, enum swell_err err, enum swell_wave_kernel kernel, unsigned long steps,
		     const char *what)
{
	if (err == SWELL_OK)
		err = swell_wave_set_kernel(w, kernel);
	if (err != SWELL_OK) {
		fprintf(stderr, "swell-fw-scene: %s refused: %s\n", what, swell_err_str(err));
		return 0;
	}
	while (steps--)
		swell_wave_step(w);
	return 1;
}

int main(int argc, char **argv)
{
	static int32_t storage[FW_SCENE_WORDS];
	static int32_t arena[FW_CORE_ARENA_WORDS];
	static int32_t pool_arena[SWELL_WAVE_WORDS(SWELL_GRID_MAX, SWELL_GRID_MAX)];
	static int32_t pool_apart[SWELL_GRID_MAX * SWELL_GRID_MAX * 3 / 2];
	const struct fw_mem mem = { pool_arena, sizeof(pool_arena) / 4, pool_apart, sizeof(pool_apart) / 4, "host" };
	static struct swell_ctl ctl;
	struct swell_wave w;
	unsigned long steps = 200, n, core_ticks = 0, core_hz = SWELL_POOL_TICK_HZ, pool = 0;
	enum swell_err err;
	enum swell_wave_kernel kernel = SWELL_KERNEL_AUTO;
	int i, k, cost = 0;

	const struct swell_cli_opt opts[] = {
		SWELL_CLI_WHOLE("--steps", steps, 0, 100000000, ""),
		SWELL_CLI_WHOLE("--core", core_ticks, 0, 100000000, "ticks"),
		SWELL_CLI_WHOLE("--core-hz", core_hz, 500, SWELL_TICK_HZ_MAX, "Hz"),
		SWELL_CLI_WHOLE("--pool", pool, SWELL_WAVE_MIN_SIDE, SWELL_GRID_MAX, "cells"),
		SWELL_CLI_FLAG("--cost", cost),
		SWELL_CLI_CHOICE("--kernel", kernel, "auto|ref|fused|avx2"), /* enum swell_wave_kernel */
	};
	struct swell_cli cli = { .prog = "swell-fw-scene", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts) };

	swell_cli_parse(&cli, argc, argv);
	if (core_hz % SWELL_POOL_SOLVER_HZ != 0)
		swell_cli_die("swell-fw-scene", "--core-hz %lu is not a multiple of the 250 Hz solver rate", core_hz);
	err = fw_scene_init(&w, storage, FW_SCENE_WORDS);
	if (err == SWELL_OK && swell_wave_set_kernel(&w, kernel) != SWELL_OK) {
		fprintf(stderr, "swell-fw-scene: kernel %s is not available here\n", swell_wave_kernel_name(kernel));
		return 2;
	}
	if (!run_steps(&w, err, kernel, steps, "scene"))
		return 1;
	printf("kernel %s\n", swell_wave_kernel_name((enum swell_wave_kernel)w.kernel));
	printf("steps %lu\n", steps);
	printf("e 0x%08x (Q1.30)\n", (unsigned)w.p.e);
	printf("checksum 0x%08x\n", (unsigned)swell_wave_checksum(&w));
	printf("volume %lld LSB (2^-16 mm per cell)\n", (long long)swell_wave_volume(&w));
	for (i = 0; cost && i < FW_COST_SCENES; i++) {
		err = fw_cost_scene_init(&w, storage, FW_SCENE_WORDS, (enum fw_cost_scene)i);
		if (!run_steps(&w, err, kernel, FW_COST_STEPS, "cost scene"))
			return 1;
		printf("cost scene %s checksum 0x%08x\n", fw_cost_scene_name[i], (unsigned)swell_wave_checksum(&w));
	}
	if (core_ticks) {
		struct fw_core_run r;

		err = fw_core_init(&ctl, &r, arena, FW_CORE_ARENA_WORDS, (uint32_t)core_hz);
		for (k = 0; pool && err == SWELL_OK && k < 2; k++) {
			const struct swell_msg set =
				swell_param_request(0, 1, k ? SWELL_SCENE_NY : SWELL_SCENE_NX, (int32_t)pool, 0);
			struct swell_msg ans;
			struct fw_pool_at place;

			(void)fw_pool_param(&ctl, &mem, &set, &ans, &place);
			if (ans.type != SWELL_MSG_PARAM_ACK)
				err = (enum swell_err)ans.u.param_nack.err;
		}
		if (err != SWELL_OK) {
			fprintf(stderr, "swell-fw-scene: core refused: %s\n", swell_err_str(err));
			return 1;
		}
		for (n = 0; n < core_ticks; n++) {
			fw_core_device(&ctl, &r);
			swell_ctl_tick(&ctl);
			fw_core_drain(&ctl, &r);
		}
		printf("core ticks %lu at %lu Hz\n", core_ticks, core_hz);
		printf("core checksum 0x%08x\n", (unsigned)fw_core_checksum(&ctl, &r));
		printf("core: state %s, %u FORCE_CMD, last fz %d uN\n", swell_ctl_state_name(ctl.state),
		       (unsigned)r.force_cmds, (int)r.last_fz_uN);
	}
	return 0;
}
