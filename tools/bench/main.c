/* swell-bench: run time against error, stability maps and stress runs of the wave solver variants.
 * Host-only. Writes CSV files and gnuplot PNGs into --out; figures and progress on the terminal.
 * Exit status: 0 all correctness checks passed, 1 a check failed, 2 bad arguments. Wall-clock
 * figures are reported, never checked. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdarg.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "bench.h"
#include "bench_loop.h"
#include "swell/cli.h"

static int failures;
double f405_instr[BENCH_IMPL_COUNT];
double f405_cost[FW_COST_SCENES], f405_cost_awake[FW_COST_SCENES];
double f405_naive;

static void vsay(const char *what, const char *fmt, va_list ap)
{
	fprintf(stderr, "swell-bench: %s", what);
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
}

void check(int ok, const char *fmt, ...)
{
	va_list ap;

	if (ok)
		return;
	failures++;
	va_start(ap, fmt);
	vsay("CHECK FAILED: ", fmt, ap);
	va_end(ap);
}

void progress(const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	vsay("", fmt, ap);
	va_end(ap);
}

void *xmalloc(size_t n)
{
	void *p = malloc(n ? n : 1);

	if (!p) {
		fprintf(stderr, "swell-bench: out of memory (%zu bytes)\n", n);
		exit(1);
	}
	return p;
}

double now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

const char *stencil_name(enum swell_stencil st)
{
	return st == SWELL_STENCIL_CALIBRATED ? "calibrated" : "paper";
}

FILE *open_out_in(const char *dir, const char *name)
{
	char path[4096];
	FILE *fp;

	snprintf(path, sizeof(path), "%s/%s", dir, name);
	fp = fopen(path, "w");
	if (!fp) {
		fprintf(stderr, "swell-bench: cannot write %s: %s\n", path, strerror(errno));
		exit(1);
	}
	return fp;
}

FILE *open_out(const struct opts *o, const char *name)
{
	return open_out_in(o->out, name);
}

void init_or_die(struct bench_field *f, enum bench_impl impl, int nx, double e, double t, enum swell_stencil st)
{
	enum swell_err err = bench_field_init(f, impl, nx, nx, e, t, st);

	if (err != SWELL_OK) {
		fprintf(stderr, "swell-bench: %s %dx%d e=%.3f t=%.3f refused: %s\n", bench_impl_name(impl), nx, nx, e,
			t, swell_err_str(err));
		exit(1);
	}
}

/* ---- arguments -------------------------------------------------------------------------- */

static const char usage[] = "usage: swell-bench [--quick | --full] [--out DIR] [options]\n"
			    "       swell-bench loop [options]   (the coupled loop's stability map, below)\n"
			    "Benchmarks the wave solver variants: host ns per cell-step against error (CSV + PNG),\n"
			    "a stability map over (e, t) against the analytic limit e < (1+q)/(4q), and stress runs.\n"
			    "  --quick            CI preset: 64x64, e in {0.05, 0.2, 0.45}, short runs (default)\n"
			    "  --full             64, 128, 256; e in {0.05, 0.1, 0.2, 0.3, 0.45}; long stress runs\n"
			    "  --out DIR          output directory (created; default bench-out)\n"
			    "  --grids N,N,...    square grid sides (2..1024), overrides the preset\n"
			    "  --e X,X,...        solver rates e (eq. 2), overrides the preset\n"
			    "  --steps N          steps of each matrix error run\n"
			    "  --reps N           timing repetitions (best of N)\n"
			    "  --stress-cells X   cell-steps of each edge-of-stability run (e.g. 1e8)\n"
			    "  --f405 FILE        'impl instructions-per-cell-step' lines from the STM32F405 image\n"
			    "  --no-plots         CSV only\n"
			    "  --replot           only redraw the PNGs from the CSV files already in --out\n"
			    "  --help             this text\n"
			    "Files: matrix.csv, error_steps.csv, stability.csv, boundary.csv, stress.csv, plots.gp,\n"
			    "pareto.png, error_steps.png, stability.png. Exit 1 when a correctness check fails\n"
			    "(never on time), 2 on bad arguments.\n\n";

/* --grids: whole sides 2..1024 */
static int grids_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	double side[MAX_LIST];
	int j, n = swell_cli_numbers(c, opt, v, 1, MAX_LIST, 2, 1024, "cells", side);

	if (n < 0)
		return -1;
	for (j = 0; j < n; j++)
		if (side[j] != (int)side[j])
			return swell_cli_refuse(c, "%s '%s' is not whole numbers", opt, v);
	for (j = 0; j < n; j++)
		o->grids[j] = (int)side[j];
	o->ngrids = n;
	return 0;
}

static int e_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	const int n = swell_cli_numbers(c, opt, v, 1, MAX_LIST, 1e-6, 1.999, "", o->es);

	o->nes = n < 0 ? o->nes : n;
	return n < 0 ? -1 : 0;
}

/* Instructions per cell-step on the STM32F405 image: lines 'impl value', or the image's self-test
 * output under QEMU (-icount shift=0), whose 'solver cell-step: X instructions ...' line is the
 * solver's (velocity) and 'naive int32 9-point cell-step: X' a plain loop, printed for reference. */

static void load_f405(const char *path)
{
	FILE *fp = fopen(path, "r");
	char line[512], name[64];
	double v;

	if (!fp) {
		fprintf(stderr, "swell-bench: cannot read --f405 file %s: %s\n", path, strerror(errno));
		exit(2);
	}
	while (fgets(line, sizeof(line), fp)) {
		int sc;

		for (sc = 0; sc < FW_COST_SCENES; sc++) {
			char want[128];
			double aw;

			snprintf(want, sizeof(want), "cost scene %s: %%lf instructions per cell-step, %%lf",
				 fw_cost_scene_name[sc]);
			if (sscanf(line, want, &v, &aw) == 2) {
				f405_cost[sc] = v;
				f405_cost_awake[sc] = aw;
			}
		}
		if (sscanf(line, "solver cell-step: %lf", &v) == 1) {
			f405_instr[BENCH_VELOCITY] = v;
		} else if (sscanf(line, "naive int32 9-point cell-step: %lf", &v) == 1) {
			f405_naive = v;
		} else if (sscanf(line, "%63s %lf", name, &v) == 2) {
			enum bench_impl k = bench_impl_parse(name);

			if (k != BENCH_IMPL_COUNT)
				f405_instr[k] = v;
		}
	}
	fclose(fp);
	if (f405_instr[BENCH_VELOCITY] > 0 || f405_naive > 0)
		printf("STM32F405 (QEMU -icount shift=0): the solver (velocity, undamped) %.2f, naive int32 9-point "
		       "loop %.2f instructions per cell-step\n",
		       f405_instr[BENCH_VELOCITY], f405_naive);
}

static void preset(struct opts *o, int full)
{
	static const double e_quick[] = { 0.05, 0.2, 0.45 }, e_full[] = { 0.05, 0.1, 0.2, 0.3, 0.45 };
	int k;

	o->preset = full ? "full" : "quick";
	o->ngrids = full ? 3 : 1;
	for (k = 0; k < 3; k++)
		o->grids[k] = 64 << k; /* 64, 128, 256 */
	o->nes = full ? 5 : 3;
	for (k = 0; k < o->nes; k++)
		o->es[k] = full ? e_full[k] : e_quick[k];
	o->steps = full ? 2000 : 500;
	o->long_steps = full ? 100000 : 2000;
	o->reps = full ? 31 : 11;
	o->map_ne = full ? 41 : 21;
	o->map_nt = full ? 31 : 16;
	o->map_steps = full ? 4000 : 1000;
	o->bnd_nt = full ? 16 : 4;
	o->stress_cells = full ? 1e9 : 1e7;
}

int main(int argc, char **argv)
{
	struct opts o;
	struct stat st;
	int k, full = 0, replot = 0, preset_given = 0;
	double t0 = now_s();

	if (argc > 1 && !strcmp(argv[1], "loop"))
		return bench_loop_main(argc - 1, argv + 1);
	for (k = 1; k < argc; k++)
		if (!strcmp(argv[k], "--help") || !strcmp(argv[k], "-h")) {
			fputs(usage, stdout);
			fputs(bench_loop_usage(), stdout);
			return 0;
		}
	memset(&o, 0, sizeof(o));
	o.out = "bench-out";
	o.plots = 1;
	for (k = 1; k < argc; k++)
		if (!strcmp(argv[k], "--full"))
			full = 1;
	preset(&o, full);
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_FLAG("--quick", preset_given), /* the preset is read above, before the others */
		SWELL_CLI_FLAG("--full", preset_given),
		SWELL_CLI_SET("--no-plots", o.plots, 0),
		SWELL_CLI_FLAG("--replot", replot),
		SWELL_CLI_STR("--out", o.out),
		SWELL_CLI_HOOK("--grids", grids_opt, 1),
		SWELL_CLI_HOOK("--e", e_opt, 1),
		SWELL_CLI_WHOLE("--steps", o.steps, 20, 10000000, ""),
		SWELL_CLI_WHOLE("--reps", o.reps, 1, 1000, ""),
		SWELL_CLI_NUM("--stress-cells", o.stress_cells, 1e4, 1e12, ""),
		SWELL_CLI_STR("--f405", o.f405),
	};
	struct swell_cli cli = {
		.prog = "swell-bench", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts), .ctx = &o
	};

	swell_cli_parse(&cli, argc, argv);
	if (!replot && mkdir(o.out, 0777) != 0 && errno != EEXIST) {
		fprintf(stderr, "swell-bench: cannot create %s: %s\n", o.out, strerror(errno));
		return 2;
	}
	/* before the run, not when its first CSV file is written */
	if (stat(o.out, &st) != 0 || !S_ISDIR(st.st_mode) || access(o.out, W_OK | X_OK) != 0) {
		fprintf(stderr, "swell-bench: --out %s is not a writable directory\n", o.out);
		return 2;
	}
	if (replot) { /* the CSV files of an earlier run in --out: plots only */
		const char *miss = missing_results(&o);

		if (miss) {
			fprintf(stderr,
				"swell-bench: --replot: %s/%s is missing or empty (no results of a run to plot)\n",
				o.out, miss);
			return 1;
		}
		return write_plots(&o) == 0 ? 0 : 1;
	}
	if (o.f405)
		load_f405(o.f405);

	printf("swell-bench %s preset: grids", o.preset);
	for (k = 0; k < o.ngrids; k++)
		printf(" %dx%d", o.grids[k], o.grids[k]);
	printf(", e");
	for (k = 0; k < o.nes; k++)
		printf(" %.3f", o.es[k]);
	printf(", output in %s/\n", o.out);

	run_matrix(&o);
	printf("\n== error against steps ==\n");
	run_error_steps(&o);
	run_scenes(&o);
	run_stability(&o);
	run_stress(&o);
	if (o.plots)
		write_plots(&o);
	printf("\nswell-bench: %s preset done in %.1f s; %d correctness check%s failed\n", o.preset, now_s() - t0,
	       failures, failures == 1 ? "" : "s");
	return failures ? 1 : 0;
}
