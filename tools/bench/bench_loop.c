/* swell-bench loop: the coupled loop's stability map over stiffness, damping, device mass and
 * damping, delay, rate and force mode, with and without the passivity controller; the critical
 * stiffness by bisection against the theory (loop.h). loop.csv, loop_critical.csv,
 * loop_theory.csv, loop.gp, loop-stream.png and loop-effect.png in --out. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "bench_loop.h"
#include "loop.h"
#include "swell/cli.h"

#define LIST SWELL_CLI_LIST_MAX
#define THEORY_K_HI 1e5 /* N/m: the theory's search ends here */
#define BISECT_STEPS 5 /* halvings of the bracket in log2 k: 1/32 of an octave, 2 % */
#define PASSIVE_MJ 1.0 /* the quick map's claim: with the controller no stream point creates more */

struct lopts {
	const char *out;
	const char *preset;
	const char *trace;
	double k[LIST], damper[LIST], mass[LIST], damping[LIST], delay[LIST], rate[LIST];
	int nk, ndamper, nmass, ndamping, ndelay, nrate;
	int mode; /* 0 stream, 1 effect, 2 both */
	int passivity; /* 0 off, 1 on, 2 both */
	double seconds;
	int jobs;
	int plots;
	int bisect;
	int water_energy;
	double pc_damping; /* force.pc_damping N s/m; 0 the controller's default */
	int pc_delay_given, pc_delay; /* force.pc_delay ticks, else the point's link delay */
};

static const char loop_usage[] =
	"usage: swell-bench loop [--quick | --full] [--out DIR] [options]\n"
	"The coupled hand-device-controller-water loop's stability map: the controller core against the\n"
	"HapticMaster model in lockstep, one process, deterministic. Each point lowers the object from 5 mm\n"
	"above the water to 5 mm below its floating depth in 1 s, holds it there until 2 s and lets go. Over\n"
	"windows of one period of the spring on the device's mass, the swing after the release is: divergent\n"
	"when 30 mm from the floating depth, at the force limit, or larger than the release's swing and\n"
	"growing by more than 3 %/s; a limit cycle when larger than the release's swing, or at least half of\n"
	"it and not falling by 3 %/s; else stable. The delay is on the controller -> device path. Stiffness:\n"
	"multiples of rho g a b of the 50 mm cube (24.5 N/m; the object a = b = 50 mm x sqrt(multiple),\n"
	"floating half submerged, in a 128 x 128 pool).\n"
	"  --quick            CI preset: 1000 Hz, 2 kg, 2 N s/m, no b_max; k 2,8,16,32,64; delays 0-4 (default)\n"
	"  --full             1000 and 2500 Hz; 0.5, 2, 4 kg; 0.5, 2 N s/m; b_max 0, 15; k 0.25 to 64\n"
	"  --out DIR          output directory (created; default bench-out)\n"
	"  --k X,...          stiffness multiples of rho g a b, in [0.25, 64]\n"
	"  --damper X,...     the force law's damper b_max at full submersion, N s/m\n"
	"  --mass X,...       the device's virtual mass, kg in [0.5, 4]\n"
	"  --damping X,...    the device's virtual damping, N s/m\n"
	"  --delays N,...     link delay, ticks in [0, 4]\n"
	"  --rates X,...      device and controller rate, Hz (1000, 2500)\n"
	"  --modes WHICH      stream, effect or both (force.mode)\n"
	"  --passivity WHICH  off, on or both (the controller's time-domain passivity controller)\n"
	"  --pc-damping X     force.pc_damping, the passivity controller's damping at most, N s/m (default: the\n"
	"                     controller's)\n"
	"  --pc-delay N       force.pc_delay, the link delay the controller's account assumes, ticks in [0, 7]\n"
	"                     (default: each point's own delay, as a lab sets it for its link)\n"
	"  --water-energy     the controller's energy account keeps the water's energy (a pass over the field\n"
	"                     each solver step, about 9/10 of the run time; off: weight and springs only)\n"
	"  --seconds S        free response after the release (at least 6 periods of the spring on the mass)\n"
	"  --jobs N           points run at once (threads; default 2)\n"
	"  --no-bisect        the map only, no critical stiffness\n"
	"  --no-plots         CSV only\n"
	"  --trace FILE       one point only: its ticks (t, z, v, force, hand force, state) into FILE\n"
	"  --help             this text\n"
	"Files: loop.csv (a row a point), loop_critical.csv, loop_theory.csv, loop.gp, loop-stream.png,\n"
	"loop-effect.png. Exit 0 done, 1 a correctness check failed, 2 bad arguments.\n";

const char *bench_loop_usage(void)
{
	return loop_usage;
}

static void lpreset(struct lopts *o, int full)
{
	static const double kq[] = { 2, 8, 16, 32, 64 }, kf[] = { 0.25, 0.5, 1, 2, 4, 8, 16, 32, 64 };
	int j;

	o->preset = full ? "full" : "quick";
	o->nk = full ? 9 : 5;
	for (j = 0; j < o->nk; j++)
		o->k[j] = full ? kf[j] : kq[j];
	o->ndelay = 5;
	for (j = 0; j < 5; j++)
		o->delay[j] = j;
	o->nrate = full ? 2 : 1;
	o->rate[0] = 1000;
	o->rate[1] = 2500;
	o->nmass = full ? 3 : 1;
	o->mass[0] = 2;
	o->mass[1] = 0.5;
	o->mass[2] = 4;
	o->ndamping = full ? 2 : 1;
	o->damping[0] = 2;
	o->damping[1] = 0.5;
	o->ndamper = full ? 2 : 1;
	o->damper[0] = 0;
	o->damper[1] = 15;
	o->mode = 2;
	o->passivity = 2;
	o->seconds = 3;
	o->jobs = 2;
	o->plots = 1;
	o->bisect = 1;
}

/* 1 when o runs the quick preset's map as it is (any points, both controller settings the
 * controller's own): the map the passivity claim is made for */
static int quick_map(const struct lopts *o)
{
	struct lopts q;

	memset(&q, 0, sizeof(q));
	lpreset(&q, 0);
	return !strcmp(o->preset, "quick") && o->nk == q.nk && !memcmp(o->k, q.k, sizeof(q.k[0]) * (size_t)q.nk) &&
		o->ndamper == q.ndamper && !memcmp(o->damper, q.damper, sizeof(q.damper[0]) * (size_t)q.ndamper) &&
		o->nmass == q.nmass && !memcmp(o->mass, q.mass, sizeof(q.mass[0]) * (size_t)q.nmass) &&
		o->ndamping == q.ndamping &&
		!memcmp(o->damping, q.damping, sizeof(q.damping[0]) * (size_t)q.ndamping) && o->ndelay == q.ndelay &&
		!memcmp(o->delay, q.delay, sizeof(q.delay[0]) * (size_t)q.ndelay) && o->nrate == q.nrate &&
		!memcmp(o->rate, q.rate, sizeof(q.rate[0]) * (size_t)q.nrate) && o->seconds == q.seconds &&
		o->pc_damping <= 0 && !o->pc_delay_given;
}

static int list_hook(struct swell_cli *c, const char *opt, const char *v, double lo, double hi, const char *unit,
		     double *dst, int *n)
{
	double tmp[LIST];
	const int k = swell_cli_numbers(c, opt, v, 1, LIST, lo, hi, unit, tmp);

	if (k < 0)
		return -1;
	memcpy(dst, tmp, sizeof(double) * (size_t)k);
	*n = k;
	return 0;
}

#define LOPT(c) ((struct lopts *)(c)->ctx)
static int k_opt(struct swell_cli *c, const char *opt, const char *v)
{
	return list_hook(c, opt, v, 0.25, 64, "", LOPT(c)->k, &LOPT(c)->nk);
}
static int damper_opt(struct swell_cli *c, const char *opt, const char *v)
{
	return list_hook(c, opt, v, 0, 1000, "N s/m", LOPT(c)->damper, &LOPT(c)->ndamper);
}
static int mass_opt(struct swell_cli *c, const char *opt, const char *v)
{
	return list_hook(c, opt, v, 0.5, 4, "kg", LOPT(c)->mass, &LOPT(c)->nmass);
}
static int damping_opt(struct swell_cli *c, const char *opt, const char *v)
{
	return list_hook(c, opt, v, 0, 100, "N s/m", LOPT(c)->damping, &LOPT(c)->ndamping);
}
static int rate_opt(struct swell_cli *c, const char *opt, const char *v)
{
	int j;

	if (list_hook(c, opt, v, 1000, 2500, "Hz", LOPT(c)->rate, &LOPT(c)->nrate) < 0)
		return -1;
	for (j = 0; j < LOPT(c)->nrate; j++)
		if (LOPT(c)->rate[j] != 1000 && LOPT(c)->rate[j] != 2500)
			return swell_cli_refuse(c, "%s '%s' is not 1000 and/or 2500 Hz", opt, v);
	return 0;
}
static int delay_opt(struct swell_cli *c, const char *opt, const char *v)
{
	int j;

	if (list_hook(c, opt, v, 0, 4, "ticks", LOPT(c)->delay, &LOPT(c)->ndelay) < 0)
		return -1;
	for (j = 0; j < LOPT(c)->ndelay; j++)
		if (LOPT(c)->delay[j] != (int)LOPT(c)->delay[j])
			return swell_cli_refuse(c, "%s '%s' is not whole numbers", opt, v);
	return 0;
}

/* ---- the runs: a point list, run by --jobs threads, results in list order ---- */

struct job {
	struct loop_point *pt;
	struct loop_result *res;
	long n, next, done;
	pthread_mutex_t mu;
	double t0;
	const char *what;
};

static double now(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static void *worker(void *arg)
{
	struct job *j = arg;

	for (;;) {
		long i;

		pthread_mutex_lock(&j->mu);
		i = j->next < j->n ? j->next++ : -1;
		pthread_mutex_unlock(&j->mu);
		if (i < 0)
			return NULL;
		loop_run(&j->pt[i], &j->res[i]);
		pthread_mutex_lock(&j->mu);
		j->done++;
		if (j->done == j->n || j->done % 20 == 0)
			fprintf(stderr, "swell-bench: loop %s %ld/%ld (%.1f s)\n", j->what, j->done, j->n,
				now() - j->t0);
		pthread_mutex_unlock(&j->mu);
	}
}

static void run_all(struct loop_point *pt, struct loop_result *res, long n, int jobs, const char *what)
{
	struct job j = { pt, res, n, 0, 0, PTHREAD_MUTEX_INITIALIZER, now(), what };
	pthread_t th[16];
	int k, started = 0;

	for (k = 0; k < jobs && k < 16; k++)
		if (pthread_create(&th[k], NULL, worker, &j) == 0)
			started++;
	if (!started)
		worker(&j);
	for (k = 0; k < started; k++)
		pthread_join(th[k], NULL);
}

/* calloc, or the run ends (a host bench: nothing to save) */
static void *zalloc(size_t n, size_t size)
{
	void *p = calloc(n ? n : 1, size);

	if (!p) {
		fprintf(stderr, "swell-bench: out of memory\n");
		exit(1);
	}
	return p;
}

static const char *mode_name(int mode)
{
	return mode ? "effect" : "stream";
}

static FILE *lopen(const struct lopts *o, const char *name)
{
	return open_out_in(o->out, name);
}

/* the theory's critical multiple for a point's loop: stream mode has the link's delay in the force
 * law's path, effect mode renders the springs and the damper on the device (d = 0); the force law's
 * damper linearised at half submersion (b_max / 2); the static stiffness with the pool's level rise,
 * k / (1 - r), r = a b / A_pool = multiple / 256 */
static double theory_mult(int mode, double rate, double mass, double damping, double damper, int delay)
{
	const double T = 1.0 / rate, c = 1.0 / ((double)LOOP_POOL_N * LOOP_POOL_N / 64.0) /* r per multiple */;
	const double k_hi = THEORY_K_HI;
	const double K = loop_theory_k_crit(mass, damping, damper / 2.0, mode ? 0 : delay, T, k_hi);

	if (K >= k_hi)
		return INFINITY;
	return K / (loop_k_ref() + K * c);
}

static void row(FILE *fp, const struct loop_point *p, const struct loop_result *r)
{
	fprintf(fp,
		"%s,%g,%g,%.4f,%.3f,%g,%g,%g,%g,%d,%d,%s,%d,%.5f,%.5f,%.5f,%.4f,%.4f,%d,%.6f,%.6f,%.6f,%.3f,%.3f,%d\n",
		mode_name(p->mode), p->rate_hz, p->k_mult, r->k_N_m, r->a_mm, r->mass_g, p->damper_Ns_m, p->mass_kg,
		p->damping_Ns_m, p->delay, p->passivity, loop_class_name(r->cls), (int)r->cls, r->p2p_first_mm,
		r->p2p_last_mm, r->sigma_per_s, r->peak_dev_mm, r->peak_force_N, r->force_limited, r->e_port_J * 1e3,
		r->e_created_J * 1e3, r->e_created_max_J * 1e3, r->ctl_created_J * 1e3, r->ctl_damped_J * 1e3,
		theory_mult(p->mode, p->rate_hz, p->mass_kg, p->damping_Ns_m, p->damper_Ns_m, p->delay) >= p->k_mult);
}

static int unstable(const struct loop_result *r)
{
	return r->cls == LOOP_LIMIT_CYCLE || r->cls == LOOP_DIVERGENT;
}

static void write_plots(const struct lopts *o)
{
	FILE *fp = lopen(o, "loop.gp");
	char cmd[4300];
	int mode, ir, pas, im;

	fprintf(fp,
		"# gnuplot script written by swell-bench loop; run from this directory: gnuplot loop.gp\n"
		"set datafile separator ','\n"
		"set terminal pngcairo size 1000,%d font ',9'\n"
		"set logscale y 2\n"
		"set yrange [0.18:90]\n"
		"set xrange [-0.5:4.5]\n"
		"set xtics 1\n"
		"set grid\n"
		"set key below horizontal font ',9'\n"
		"set xlabel 'link delay (ticks, controller -> device)'\n"
		"set ylabel 'stiffness / (rho g a b of the 50 mm cube)'\n",
		o->nrate > 1 ? 1100 : 600);
	for (mode = 0; mode < 2; mode++) {
		if (o->mode != 2 && o->mode != mode)
			continue;
		static const char *const cls[] = { "stable", "limit-cycle", "divergent", "beyond-effect-range" };
		static const char *const col[] = { "dark-green", "orange", "red", "gray" };
		static const char *const shape[] = { "squares", "circles", "triangles", "diamonds" };
		char masses[256] = "";

		for (im = 0; im < o->nmass && im < 4; im++)
			snprintf(masses + strlen(masses), sizeof(masses) - strlen(masses), "%s%s %g kg", im ? ", " : "",
				 shape[im], o->mass[im]);
		fprintf(fp,
			"set output 'loop-%s.png'\nset multiplot layout %d,2 title \"%s mode: device damping %g N s/m, "
			"force law damper b_{max} %g N s/m\\n%s (offset); dashed: theory\"\n",
			mode_name(mode), o->nrate, mode_name(mode), o->damping[0], o->damper[0], masses);
		for (ir = 0; ir < o->nrate; ir++)
			for (pas = 0; pas < 2; pas++) {
				fprintf(fp, "set title '%g Hz, %s the passivity controller'\nplot ", o->rate[ir],
					pas ? "with" : "without");
				for (im = 0; im < o->nmass && im < 4; im++) {
					const double off = o->nmass > 1 ? 0.25 * (im - (o->nmass - 1) / 2.0) : 0.0;
					int kc;

					for (kc = 0; kc < 4; kc++) {
						fprintf(fp,
							"'loop.csv' using (strcol(1) eq '%s' && $2 == %g && $11 == %d "
							"&& "
							"$8 == %g && $9 == %g && $7 == %g && strcol(12) eq '%s' ? $10 "
							"+ %g : "
							"1/0):3 with points pt %d ps 1.6 lc '%s' ",
							mode_name(mode), o->rate[ir], pas, o->mass[im], o->damping[0],
							o->damper[0], cls[kc], off, 5 + 2 * im, col[kc]);
						if (im == 0)
							fprintf(fp, "title '%s', \\\n     ", cls[kc]);
						else
							fprintf(fp, "notitle, \\\n     ");
					}
					fprintf(fp,
						"'loop_theory.csv' using (strcol(1) eq '%s' && $2 == %g && $3 == %g && "
						"$4 == %g && $5 == %g ? $6 + %g : 1/0):($7 > 0 ? $7 : 1/0) with "
						"linespoints dt 2 pt %d ps 0.8 lc 'black' %s%s",
						mode_name(mode), o->rate[ir], o->mass[im], o->damping[0], o->damper[0],
						off, 4 + 2 * im, im == 0 ? "title 'theory'" : "notitle",
						im + 1 < o->nmass && im + 1 < 4 ? ", \\\n     " : "\n");
				}
			}
		fprintf(fp, "unset multiplot\n");
	}
	fclose(fp);
	if (strchr(o->out, '\'')) {
		fprintf(stderr, "swell-bench: output path contains a quote; run gnuplot loop.gp there by hand\n");
		return;
	}
	snprintf(cmd, sizeof(cmd), "cd '%s' && gnuplot loop.gp", o->out);
	if (system(cmd) != 0)
		fprintf(stderr, "swell-bench: gnuplot failed; the CSV files are complete, plots not made\n");
	else
		fprintf(stderr, "swell-bench: plots: %s/loop-stream.png, loop-effect.png\n", o->out);
}

/* The critical stiffness of one (mode, rate, mass, damping, damper, delay) without the passivity
 * controller: the sweep's bracket (highest stable multiple below the lowest unstable one), then
 * BISECT_STEPS halvings in log2. lo, hi: the bracket; state 0 when bisection ran, 1 when even the
 * largest multiple is stable, -1 when the smallest is not. */
struct crit {
	struct loop_point base;
	double lo, hi;
	int state;
};

int bench_loop_main(int argc, char **argv)
{
	struct lopts o;
	struct stat st;
	int full = 0, preset_given = 0, nobisect = 0, k, fails = 0;
	int modes[2] = { 0, 0 }, nmodes = 0, pass[2] = { 0, 0 }, npass = 0;
	long n = 0, i;
	struct loop_point *pt;
	struct loop_result *res;
	double t0 = now();

	memset(&o, 0, sizeof(o));
	o.out = "bench-out";
	o.pc_delay = -1; /* not given */
	for (k = 1; k < argc; k++)
		if (!strcmp(argv[k], "--full"))
			full = 1;
	lpreset(&o, full);
	{
		const struct swell_cli_opt opts[] = {
			SWELL_CLI_FLAG("--quick", preset_given),
			SWELL_CLI_FLAG("--full", preset_given),
			SWELL_CLI_STR("--out", o.out),
			SWELL_CLI_HOOK("--k", k_opt, 1),
			SWELL_CLI_HOOK("--damper", damper_opt, 1),
			SWELL_CLI_HOOK("--mass", mass_opt, 1),
			SWELL_CLI_HOOK("--damping", damping_opt, 1),
			SWELL_CLI_HOOK("--delays", delay_opt, 1),
			SWELL_CLI_HOOK("--rates", rate_opt, 1),
			SWELL_CLI_CHOICE("--modes", o.mode, "stream|effect|both"),
			SWELL_CLI_CHOICE("--passivity", o.passivity, "off|on|both"),
			SWELL_CLI_NUM("--seconds", o.seconds, 0.5, 60, "s"),
			SWELL_CLI_WHOLE("--jobs", o.jobs, 1, 16, ""),
			SWELL_CLI_FLAG("--no-bisect", nobisect),
			SWELL_CLI_SET("--no-plots", o.plots, 0),
			SWELL_CLI_FLAG("--water-energy", o.water_energy),
			SWELL_CLI_NUM("--pc-damping", o.pc_damping, 0.1, 1000, "N s/m"),
			SWELL_CLI_WHOLE("--pc-delay", o.pc_delay, 0, 7, "ticks"),
			SWELL_CLI_STR("--trace", o.trace),
		};
		struct swell_cli cli = { .prog = "swell-bench loop",
					 .usage = loop_usage,
					 .opt = opts,
					 .n_opt = SWELL_CLI_N(opts),
					 .ctx = &o };

		swell_cli_parse(&cli, argc, argv);
	}
	o.bisect = !nobisect;
	o.pc_delay_given = o.pc_delay >= 0;
	if (mkdir(o.out, 0777) != 0 && errno != EEXIST) {
		fprintf(stderr, "swell-bench loop: cannot create %s: %s\n", o.out, strerror(errno));
		return 2;
	}
	if (stat(o.out, &st) != 0 || !S_ISDIR(st.st_mode) || access(o.out, W_OK | X_OK) != 0) {
		fprintf(stderr, "swell-bench loop: --out %s is not a writable directory\n", o.out);
		return 2;
	}
	for (k = 0; k < 2; k++) {
		if (o.mode == 2 || o.mode == k)
			modes[nmodes++] = k;
		if (o.passivity == 2 || o.passivity == k)
			pass[npass++] = k;
	}

	/* the map */
	pt = zalloc((size_t)nmodes * o.nrate * o.nmass * o.ndamping * o.ndamper * o.ndelay * o.nk * npass, sizeof(*pt));
	{
		int im, ir, ima, idg, idp, idl, ik, ip;

		for (im = 0; im < nmodes; im++)
			for (ir = 0; ir < o.nrate; ir++)
				for (ima = 0; ima < o.nmass; ima++)
					for (idg = 0; idg < o.ndamping; idg++)
						for (idp = 0; idp < o.ndamper; idp++)
							for (idl = 0; idl < o.ndelay; idl++)
								for (ip = 0; ip < npass; ip++)
									for (ik = 0; ik < o.nk; ik++) {
										struct loop_point *p = &pt[n++];

										p->mode = modes[im];
										p->rate_hz = o.rate[ir];
										p->mass_kg = o.mass[ima];
										p->damping_Ns_m = o.damping[idg];
										p->damper_Ns_m = o.damper[idp];
										p->delay = (int)o.delay[idl];
										p->passivity = pass[ip];
										p->pc_damping_Ns_m = o.pc_damping;
										p->pc_delay_given = o.pc_delay_given;
										p->pc_delay = o.pc_delay;
										p->k_mult = o.k[ik];
										p->seconds = o.seconds;
										p->water_energy = o.water_energy;
									}
	}
	res = zalloc((size_t)n, sizeof(*res));
	printf("swell-bench loop %s preset: %ld points, output in %s/\n", o.preset, n, o.out);
	if (o.trace) { /* one point, its ticks */
		FILE *tf = n == 1 ? fopen(o.trace, "w") : NULL;

		if (!tf) {
			fprintf(stderr, "swell-bench loop: --trace needs one point and a writable file\n");
			free(pt);
			free(res);
			return 2;
		}
		fprintf(tf, "t_s,z_mm,v_mm_s,f_N,hand_N,state\n");
		pt[0].trace = tf;
		loop_run(&pt[0], &res[0]);
		fclose(tf);
		pt[0].trace = NULL;
	} else {
		run_all(pt, res, n, o.jobs, "map");
	}
	{
		FILE *fp = lopen(&o, "loop.csv"), *ft = lopen(&o, "loop_theory.csv");
		int cnt[2][LOOP_BEYOND_EFFECT + 1] = { { 0 } };
		double kmin = o.k[0];

		for (k = 1; k < o.nk; k++)
			kmin = o.k[k] < kmin ? o.k[k] : kmin;

		fprintf(fp,
			"mode,rate_hz,k_mult,k_N_m,a_mm,mass_g,damper_Ns_m,dev_mass_kg,dev_damping_Ns_m,delay_ticks,"
			"passivity,class,class_code,p2p_first_mm,p2p_last_mm,sigma_per_s,peak_dev_mm,peak_force_N,"
			"force_limited,e_port_mJ,e_created_mJ,e_created_max_mJ,ctl_created_mJ,ctl_damped_mJ,"
			"theory_stable\n");
		for (i = 0; i < n; i++) {
			row(fp, &pt[i], &res[i]);
			cnt[pt[i].passivity][res[i].cls]++;
			if (res[i].cls == LOOP_REFUSED) {
				fprintf(stderr, "swell-bench: loop CHECK FAILED: a point was refused: %s\n",
					res[i].why);
				fails++;
			}
			/* the softest spring without delay or controller settles, in either mode */
			if (pt[i].k_mult == kmin && pt[i].delay == 0 && !pt[i].passivity && res[i].cls != LOOP_STABLE) {
				fprintf(stderr,
					"swell-bench: loop CHECK FAILED: %s, %g Hz, k x%g, %g kg, no delay: %s, not "
					"stable\n",
					mode_name(pt[i].mode), pt[i].rate_hz, pt[i].k_mult, pt[i].mass_kg,
					loop_class_name(res[i].cls));
				fails++;
			}
		}
		fclose(fp);
		fprintf(ft, "mode,rate_hz,dev_mass_kg,dev_damping_Ns_m,damper_Ns_m,delay_ticks,k_crit_mult\n");
		for (i = 0; i < n; i++)
			if (pt[i].k_mult == o.k[0] && pt[i].passivity == pass[0])
				fprintf(ft, "%s,%g,%g,%g,%g,%d,%.4f\n", mode_name(pt[i].mode), pt[i].rate_hz,
					pt[i].mass_kg, pt[i].damping_Ns_m, pt[i].damper_Ns_m, pt[i].delay,
					isfinite(theory_mult(pt[i].mode, pt[i].rate_hz, pt[i].mass_kg,
							     pt[i].damping_Ns_m, pt[i].damper_Ns_m, pt[i].delay))
						? theory_mult(pt[i].mode, pt[i].rate_hz, pt[i].mass_kg,
							      pt[i].damping_Ns_m, pt[i].damper_Ns_m, pt[i].delay)
						: -1.0);
		fclose(ft);
		printf("\n== coupled loop: classes (stable / limit cycle / divergent / beyond effect mode's k) ==\n");
		for (k = 0; k < npass; k++)
			printf("  %s the passivity controller: %d / %d / %d / %d of %ld points\n",
			       pass[k] ? "with" : "without", cnt[pass[k]][0], cnt[pass[k]][1], cnt[pass[k]][2],
			       cnt[pass[k]][LOOP_BEYOND_EFFECT], n / npass);
		/* the energy at the device port: the most any point created, by class, without the controller */
		{
			double emax[3] = { -INFINITY, -INFINITY, -INFINITY };

			for (i = 0; i < n; i++)
				if (!pt[i].passivity && res[i].cls <= LOOP_DIVERGENT &&
				    res[i].e_created_max_J > emax[res[i].cls])
					emax[res[i].cls] = res[i].e_created_max_J;
			printf("  energy created at the device port after the release (the most its balance reached), "
			       "largest without the controller: stable %.3g mJ, limit cycle %.3g mJ, divergent %.3g "
			       "mJ\n",
			       emax[0] * 1e3, emax[1] * 1e3, emax[2] * 1e3);
		}
		/* with the controller: the most any point created at the device port and in the controller's
		 * account, per mode, and how many stream points keep both within PASSIVE_MJ */
		if (npass > 0 && pass[npass - 1]) {
			double port[2] = { 0, 0 }, acct[2] = { 0, 0 };
			int within = 0, stream_pts = 0, npts[2] = { 0, 0 };

			for (i = 0; i < n; i++) {
				const int md = pt[i].mode;

				if (!pt[i].passivity || res[i].cls > LOOP_DIVERGENT)
					continue;
				npts[md]++;
				port[md] = fmax(port[md], res[i].e_created_max_J * 1e3);
				acct[md] = fmax(acct[md], res[i].ctl_created_J * 1e3);
				if (md == 0) {
					stream_pts++;
					within += res[i].e_created_max_J * 1e3 <= PASSIVE_MJ &&
						res[i].ctl_created_J * 1e3 <= PASSIVE_MJ;
				}
			}
			printf("  largest energy created with the controller (force.pc_damping %s, force.pc_delay %s):",
			       o.pc_damping > 0 ? "given" : "default", o.pc_delay_given ? "given" : "the link's");
			if (npts[0])
				printf(" stream %.3g mJ at the device port, %.3g mJ in the controller's account%s",
				       port[0], acct[0], npts[1] ? ";" : "");
			if (npts[1])
				printf(" effect %.3g mJ, %.3g mJ (the device renders the set: the controller does not "
				       "act)",
				       port[1], acct[1]);
			printf("\n");
			if (stream_pts) {
				printf("  passive with the controller: %d of %d stream points create at most %g mJ at "
				       "the "
				       "device port and in the controller's account (ratio %.3f)\n",
				       within, stream_pts, PASSIVE_MJ, (double)within / stream_pts);
				/* the quick map's claim (docs/energy.md), with the controller's own settings */
				if (quick_map(&o) && within < stream_pts) {
					fprintf(stderr,
						"swell-bench: loop CHECK FAILED: with the passivity controller %d "
						"stream "
						"point%s of the quick map create%s more than %g mJ\n",
						stream_pts - within, stream_pts - within == 1 ? "" : "s",
						stream_pts - within == 1 ? "s" : "", PASSIVE_MJ);
					fails++;
				}
			}
		}
	}

	/* the critical stiffness: per combination without the controller, bracket from the map, bisect */
	if (o.bisect && npass > 0 && o.nk > 0 && pass[0] == 0) {
		const long per = (long)npass * o.nk; /* a combination's points: passivity x k, k fastest */
		const long ncomb = n / per;
		struct crit *cr = zalloc((size_t)ncomb, sizeof(*cr));
		struct loop_point *bp = zalloc((size_t)ncomb, sizeof(*bp));
		struct loop_result *br = zalloc((size_t)ncomb, sizeof(*br));
		long c2, step;
		FILE *fc;

		for (c2 = 0; c2 < ncomb; c2++) {
			const struct loop_point *p0 = &pt[c2 * per];
			const struct loop_result *r0 = &res[c2 * per];
			int ik, first_un = -1;

			cr[c2].base = *p0;
			for (ik = 0; ik < o.nk && first_un < 0; ik++) /* o.k ascending is not required */
				if (unstable(&r0[ik]))
					first_un = ik;
			cr[c2].state = 1;
			cr[c2].lo = 0;
			cr[c2].hi = INFINITY;
			for (ik = 0; ik < o.nk; ik++) {
				if (unstable(&r0[ik]) && o.k[ik] < cr[c2].hi)
					cr[c2].hi = o.k[ik];
			}
			for (ik = 0; ik < o.nk; ik++)
				if (r0[ik].cls == LOOP_STABLE && o.k[ik] < cr[c2].hi && o.k[ik] > cr[c2].lo)
					cr[c2].lo = o.k[ik];
			if (isfinite(cr[c2].hi))
				cr[c2].state = cr[c2].lo > 0 ? 0 : -1;
		}
		for (step = 0; step < BISECT_STEPS; step++) {
			long nb = 0;

			for (c2 = 0; c2 < ncomb; c2++)
				if (cr[c2].state == 0) {
					bp[nb] = cr[c2].base;
					bp[nb].k_mult = sqrt(cr[c2].lo * cr[c2].hi);
					nb++;
				}
			if (!nb)
				break;
			run_all(bp, br, nb, o.jobs, "bisection");
			nb = 0;
			for (c2 = 0; c2 < ncomb; c2++)
				if (cr[c2].state == 0) {
					if (unstable(&br[nb]))
						cr[c2].hi = bp[nb].k_mult;
					else
						cr[c2].lo = bp[nb].k_mult;
					nb++;
				}
		}
		fc = lopen(&o, "loop_critical.csv");
		fprintf(fc,
			"mode,rate_hz,dev_mass_kg,dev_damping_Ns_m,damper_Ns_m,delay_ticks,measured_mult,"
			"measured_N_m,theory_mult,theory_N_m,ratio\n");
		printf("\n== coupled loop: critical stiffness, measured (bisection) against theory ==\n");
		printf("%-6s %5s %5s %5s %6s %5s %16s %16s %7s\n", "mode", "Hz", "m kg", "b_v", "b_max", "delay",
		       "measured x(N/m)", "theory x(N/m)", "ratio");
		for (c2 = 0; c2 < ncomb; c2++) {
			const struct loop_point *p = &cr[c2].base;
			const double th =
				theory_mult(p->mode, p->rate_hz, p->mass_kg, p->damping_Ns_m, p->damper_Ns_m, p->delay);
			const double kref = loop_k_ref();
			char meas[40], theo[40], ratio[16];
			double mm = NAN;

			if (cr[c2].state == 1)
				snprintf(meas, sizeof(meas), "> %g", cr[c2].lo);
			else if (cr[c2].state == -1)
				snprintf(meas, sizeof(meas), "< %g", cr[c2].hi);
			else {
				mm = sqrt(cr[c2].lo * cr[c2].hi);
				snprintf(meas, sizeof(meas), "%.3g (%.0f)", mm, mm * kref);
			}
			if (isfinite(th))
				snprintf(theo, sizeof(theo), "%.3g (%.0f)", th, th * kref);
			else
				snprintf(theo, sizeof(theo), "> %.0f",
					 THEORY_K_HI /
						 (loop_k_ref() +
						  THEORY_K_HI * 64.0 / ((double)LOOP_POOL_N * LOOP_POOL_N)));
			if (isfinite(mm) && isfinite(th))
				snprintf(ratio, sizeof(ratio), "%.3f", mm / th);
			else
				snprintf(ratio, sizeof(ratio), "-");
			printf("%-6s %5g %5g %5g %6g %5d %16s %16s %7s\n", mode_name(p->mode), p->rate_hz, p->mass_kg,
			       p->damping_Ns_m, p->damper_Ns_m, p->delay, meas, theo, ratio);
			fprintf(fc, "%s,%g,%g,%g,%g,%d,%.4f,%.2f,%.4f,%.2f,%.4f\n", mode_name(p->mode), p->rate_hz,
				p->mass_kg, p->damping_Ns_m, p->damper_Ns_m, p->delay, isfinite(mm) ? mm : NAN,
				isfinite(mm) ? mm * kref : NAN, th, th * kref,
				isfinite(mm) && isfinite(th) ? mm / th : NAN);
		}
		fclose(fc);
		free(cr);
		free(bp);
		free(br);
	}
	if (o.plots)
		write_plots(&o);
	printf("\nswell-bench loop: %s preset done in %.1f s; %d correctness check%s failed\n", o.preset, now() - t0,
	       fails, fails == 1 ? "" : "s");
	free(pt);
	free(res);
	return fails ? 1 : 0;
}
