/* swell-mcu-replay: the emulated STM32F405 (swell-mcu's CPU and peripheral models) running the product
 * image on a recorded bus, deterministically: a recording fed into CAN1 tick by tick, every frame the
 * image sends logged with its virtual time, bus faults at virtual times (mcu_replay.h,
 * docs/stm32f405-emulator.md "Scenarios and the force identity"). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "mcu_replay.h"
#include "swell/cli.h"

static const char usage[] =
	"usage: swell-mcu-replay --image ELF [--replay FILE.rec] [--tx-log FILE] [--fault 'AT KIND [ARG]']...\n"
	"                        [--seconds S] [--tick-us US] [--console FILE] [--quiet]\n"
	"Runs the STM32F405 image ELF (swell-fw.elf, unmodified) on swell-mcu's emulated Cortex-M4 with the\n"
	"bxCAN model on CAN1 and a recorded bus, in virtual time: a run repeats bit for bit.\n"
	"  --image ELF        the image\n"
	"  --replay FILE      a recording of classic CAN frames (SWELLREC, carrier CAN, docs/links.md): the\n"
	"                     frames of recorded tick k (times in [k, k+1) x --tick-us) reach CAN1 back to\n"
	"                     back before the image's k-th tick (TIM2 update), the last 150 us before it\n"
	"  --tx-log FILE      every frame CAN1 sent: 'T_NS ID DLC DATA' (virtual ns of its EOF, hex id\n"
	"                     and bytes); at every tick 'T_NS force FX FY FZ', the image's record of the\n"
	"                     force it last commanded (cN); 'T_NS fault N on|off'\n"
	"  --fault 'AT KIND [ARG]'  a bus fault at AT virtual seconds (repeatable, up to 16): busoff,\n"
	"                     tx-errors N (the next N attempts fail), no-ack S (nobody acknowledges for S\n"
	"                     seconds), dominant S (the bus stuck dominant), arb-lost N (the next N\n"
	"                     attempts lose arbitration: the mailboxes fill), rx-burst N (N frames at\n"
	"                     once: the 3-deep RX FIFO overruns)\n"
	"  --seconds S        virtual seconds to run (default 1)\n"
	"  --tick-us US       the recording's tick period (default 1000: the image's 1000 Hz on CAN)\n"
	"  --console FILE     the image's console (default: stdout)\n"
	"  --quiet            no summary on stderr\n"
	"Exit status: as swell-mcu's: 0 the virtual time ran out, 1 set-up error, 2 bad arguments,\n"
	"3 watchdog reset, 4 the CPU stopped, 5 the image asked for a system reset.\n";

struct run {
	struct mcu_replay r;
	struct mcu_can1_dev can;
};

static int hook(struct mcu *m, void *ctx)
{
	struct run *run = ctx;

	mcu_replay_step(&run->r, m, &run->can);
	return 0;
}

static struct {
	const char *image, *replay, *txlog, *console;
	const char *faults[MCU_FAULTS_MAX];
	unsigned n_faults;
	double seconds, tick_us;
	int quiet;
} o = { .seconds = 1.0, .tick_us = 1000.0 };

static int fault_opt(struct swell_cli *c, const char *opt, const char *val)
{
	(void)opt;
	if (o.n_faults == MCU_FAULTS_MAX)
		return swell_cli_refuse(c, "--fault: at most %d", MCU_FAULTS_MAX);
	o.faults[o.n_faults++] = val;
	return 0;
}

int main(int argc, char **argv)
{
	const struct swell_cli_opt table[] = {
		SWELL_CLI_STR("--image", o.image),
		SWELL_CLI_STR("--replay", o.replay),
		SWELL_CLI_STR("--tx-log", o.txlog),
		SWELL_CLI_HOOK("--fault", fault_opt, 1),
		SWELL_CLI_NUM_ABOVE("--seconds", o.seconds, 0, 86400, "s"),
		SWELL_CLI_NUM("--tick-us", o.tick_us, 10, 1000000, "us"),
		SWELL_CLI_STR("--console", o.console),
		SWELL_CLI_FLAG("--quiet", o.quiet),
	};
	struct swell_cli cli = {
		.prog = "swell-mcu-replay", .usage = usage, .opt = table, .n_opt = SWELL_CLI_N(table)
	};
	static struct run run;
	struct mcu *m;
	struct mcu_stm32_opts so;
	FILE *con = stdout, *log = NULL;
	char why[256];
	int rc;

	swell_cli_parse(&cli, argc, argv);
	if (!o.image)
		swell_cli_die("swell-mcu-replay", "--image ELF is needed (see --help)");
	for (unsigned i = 0; i < o.n_faults; i++)
		if (mcu_replay_fault(&run.r, o.faults[i], why, sizeof(why)) != 0)
			swell_cli_die("swell-mcu-replay", "%s", why);
	if (mcu_replay_load(&run.r, o.replay, (uint64_t)(o.tick_us * 1000.0 + 0.5), why, sizeof(why)) != 0) {
		fprintf(stderr, "swell-mcu-replay: %s\n", why);
		return MCU_EXIT_ERROR;
	}
	m = calloc(1, sizeof(*m));
	if (!m)
		return MCU_EXIT_ERROR;
	if ((o.console && strcmp(o.console, "-") != 0 && !(con = fopen(o.console, "w"))) ||
	    (o.txlog && !(log = fopen(o.txlog, "w")))) {
		fprintf(stderr, "swell-mcu-replay: %s: %s\n", log || !o.txlog ? o.console : o.txlog, strerror(errno));
		return MCU_EXIT_ERROR;
	}
	so = (struct mcu_stm32_opts){ con, 8000000u, 1000u };
	why[0] = 0;
	m->tim2_stop_at = MCU_NEVER; /* TIM2 runs (swell-mcu --stop-tim2 stops it) */
	if (mcu_init(m, 1000u, why, sizeof(why)) != 0 || mcu_load_elf(m, o.image, why, sizeof(why)) != 0 ||
	    mcu_reset(m, why, sizeof(why)) != 0 || mcu_scs_add(m) != 0 || mcu_stm32_add(m, &so) != 0 ||
	    mcu_can1_add(m, &run.can) != 0 || mcu_replay_start(&run.r, m, &run.can, log, why, sizeof(why)) != 0) {
		fprintf(stderr, "swell-mcu-replay: %s\n", why[0] ? why : "the peripheral models could not be mapped");
		mcu_free(m);
		return MCU_EXIT_ERROR;
	}
	rc = mcu_run(m, (uint64_t)(o.seconds * (double)MCU_TIME_HZ + 0.5), MCU_TIME_HZ / 100000u, hook, &run);
	fflush(con);
	if (!o.quiet)
		fprintf(stderr,
			"swell-mcu-replay: %.6f s virtual, %llu ticks, %u of %u recorded ticks fed (%u frames late), "
			"%llu frames sent, exit %d\n",
			mcu_seconds(m->now), (unsigned long long)run.r.ticks_seen, run.r.tick, run.r.n_ticks,
			run.r.late, (unsigned long long)run.r.tx_frames, rc);
	if (con != stdout)
		fclose(con);
	if (log)
		fclose(log);
	mcu_replay_free(&run.r);
	mcu_free(m);
	free(m);
	return rc;
}
