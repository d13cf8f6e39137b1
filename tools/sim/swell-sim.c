/* swell-sim: run the common/ wave solver on a scene on the host (no device, no links) and print a
 * summary. Host program: it parses decimal arguments with doubles and converts them once, at start,
 * into the solver's integer units; the solver itself sees integers only. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "swell/cli.h"
#include "swell/pool.h"
#include "swell/shape.h"
#include "swell/wave.h"
#include "swell/wave_ref.h"

#include "sim_object.h"

static const char usage[] =
	"usage: swell-sim [options]\n"
	"Run the fixed-point shallow-water solver (paper eq. 1 and 2) on the host and print a summary.\n"
	"\n"
	"  --grid NXxNY          cells (default 64x64; each side 2..1024)\n"
	"  --e E                 eq. (2) coefficient directly (default 0.2009, the pool at 250 Hz)\n"
	"  --dt S --depth M --dx M [--g M_S2]\n"
	"                        e = g dt^2 d / dx^2 from the time step (s), rest depth (m), cell size (m)\n"
	"                        and gravity (default 9.81 m/s^2)\n"
	"  --damping T           t in [0, 1) (default 0)\n"
	"  --stencil paper|calibrated   L9 as printed (default) or L9/2 (waves at sqrt(g d))\n"
	"  --steps N             solver steps (default 1000)\n"
	"  --init SHAPE          zero | seiche:M,N,AMP_MM | gauss:X,Y,SIGMA,AMP_MM (default gauss at the\n"
	"                        centre, sigma 3 cells, 2 mm); X, Y, SIGMA in cells; starts at rest\n"
	"  --impl fixed|float64  the fixed-point solver (default) or the float64 reference\n"
	"  --dump-csv FILE       final heights in mm, one row j per line, columns i\n"
	"  --no-sleep            update every tile every step (default: skip sleeping tiles, bit-identical)\n"
	"  -h, --help            this text\n"
	"\n"
	"Exit status: 0 done, 1 a runtime failure (a file cannot be written), 2 bad arguments, conflicting\n"
	"options or parameters outside the stability limit (one line on stderr).\n";

enum init_kind {
	INIT_ZERO,
	INIT_SEICHE,
	INIT_GAUSS
};

struct opts {
	int nx, ny;
	double e; /* NAN: not given; then e from dt, depth, dx (and g) when any of them is given */
	double dt, depth, dx, g;
	double damping;
	enum swell_stencil stencil;
	long steps;
	enum init_kind init;
	double init_arg[4];
	int float64;
	int no_sleep;
	const char *dump_csv;
};

/* --grid NXxNY: the sides are checked with the solver's other parameters */
static int grid_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	int nx, ny;
	char tail;

	if (sscanf(v, "%dx%d%c", &nx, &ny, &tail) != 2)
		return swell_cli_refuse(c, "%s: '%s' is not NXxNY", opt, v);
	o->nx = nx;
	o->ny = ny;
	return 0;
}

static int init_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	const int seiche = !strncmp(v, "seiche:", 7), gauss = !strncmp(v, "gauss:", 6);
	double x[4];

	if (!strcmp(v, "zero")) {
		o->init = INIT_ZERO;
		return 0;
	}
	if (!seiche && !gauss)
		return swell_cli_refuse(c, "%s: '%s' is not zero, seiche:M,N,AMP_MM or gauss:X,Y,SIGMA,AMP_MM", opt, v);
	if (swell_cli_numbers(c, opt, v + (seiche ? 7 : 6), 3 + gauss, 3 + gauss, -HUGE_VAL, HUGE_VAL, "", x) < 0)
		return -1;
	o->init = seiche ? INIT_SEICHE : INIT_GAUSS;
	memcpy(o->init_arg, x, (size_t)(3 + gauss) * sizeof(x[0]));
	return 0;
}

/* The floating object's options go to sim_object.c. */
static int object_opt(struct swell_cli *c, const char *opt, const char *v)
{
	return sim_object_option(c, opt, v);
}

static void parse_args(int argc, char **argv, struct opts *o)
{
	*o = (struct opts){ .nx = SWELL_POOL_N,
			    .ny = SWELL_POOL_N,
			    .e = NAN, /* NAN: not given */
			    .dt = NAN,
			    .depth = NAN,
			    .dx = NAN,
			    .g = 9.81,
			    .steps = 1000,
			    .init = INIT_GAUSS,
			    .init_arg = { 32, 32, 3, 2 } };
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_FLAG("--no-sleep", o->no_sleep),
		SWELL_CLI_HOOK("--grid", grid_opt, 1),
		SWELL_CLI_NUM("--e", o->e, -HUGE_VAL, HUGE_VAL, ""),
		SWELL_CLI_NUM("--dt", o->dt, -HUGE_VAL, HUGE_VAL, ""),
		SWELL_CLI_NUM("--depth", o->depth, -HUGE_VAL, HUGE_VAL, ""),
		SWELL_CLI_NUM("--dx", o->dx, -HUGE_VAL, HUGE_VAL, ""),
		SWELL_CLI_NUM("--g", o->g, -HUGE_VAL, HUGE_VAL, ""),
		SWELL_CLI_NUM("--damping", o->damping, -HUGE_VAL, HUGE_VAL, ""),
		SWELL_CLI_CHOICE("--stencil", o->stencil, "paper|calibrated"),
		SWELL_CLI_WHOLE("--steps", o->steps, 0, 1e12, ""),
		SWELL_CLI_HOOK("--init", init_opt, 1),
		SWELL_CLI_CHOICE("--impl", o->float64, "fixed|float64"),
		SWELL_CLI_STR("--dump-csv", o->dump_csv),
		SWELL_CLI_HOOK("--object", object_opt, 1),
		SWELL_CLI_HOOK("--motion", object_opt, 1),
		SWELL_CLI_HOOK("--at", object_opt, 1),
		SWELL_CLI_HOOK("--tick-hz", object_opt, 1),
		SWELL_CLI_HOOK("--damper", object_opt, 1),
		SWELL_CLI_HOOK("--safety", object_opt, 1),
		SWELL_CLI_HOOK("--trace", object_opt, 1),
	};
	struct swell_cli cli = {
		.prog = "swell-sim", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts), .ctx = o
	};
	const int r = swell_cli_scan(&cli, argc, argv);

	if (r > 0) {
		fputs(usage, stdout);
		sim_object_usage(stdout);
		exit(0);
	}
	if (r < 0)
		swell_cli_die("swell-sim", "%s", cli.why);
	if (sim_object_orphan())
		swell_cli_die("swell-sim", "%s is an option of the floating object: give --object too",
			      sim_object_orphan());
}

static void die_num(const char *opt, double v, const char *why)
{
	fprintf(stderr, "swell-sim: %s %g %s\n", opt, v, why);
	exit(2);
}

/* Turn the options into validated solver parameters, or exit with the reason. */
static struct swell_wave_params make_params(const struct opts *o)
{
	struct swell_wave_params p = { 0, 0, o->stencil };
	const int have_e = !isnan(o->e), have_dt = !isnan(o->dt), have_depth = !isnan(o->depth),
		  have_dx = !isnan(o->dx);
	enum swell_err err;

	if (o->nx < SWELL_WAVE_MIN_SIDE || o->ny < SWELL_WAVE_MIN_SIDE || o->nx > SWELL_WAVE_MAX_SIDE ||
	    o->ny > SWELL_WAVE_MAX_SIDE) {
		fprintf(stderr, "swell-sim: --grid %dx%d: each side must be in [%d, %d]\n", o->nx, o->ny,
			SWELL_WAVE_MIN_SIDE, SWELL_WAVE_MAX_SIDE);
		exit(2);
	}
	if (!(o->damping >= 0 && o->damping < 1))
		die_num("--damping", o->damping, "is outside [0, 1)");
	p.damping = (q30_t)llround(o->damping * SWELL_Q30_ONE);
	/* every value given is checked, used or not (a negative one used to fall back to the defaults) */
	if (have_dt && !(o->dt * 1e6 >= 1 && o->dt * 1e6 < 4e9))
		die_num("--dt", o->dt, "s is outside [1e-6, 4000)");
	if (have_depth && !(o->depth * 1e6 >= 1 && o->depth * 1e6 < 4e9))
		die_num("--depth", o->depth, "m is outside [1e-6, 4000)");
	if (have_dx && !(o->dx * 1e6 >= 1 && o->dx * 1e6 < 4e9))
		die_num("--dx", o->dx, "m is outside [1e-6, 4000)");
	if (!(o->g * 1e3 >= 1 && o->g * 1e3 < 4e9))
		die_num("--g", o->g, "m/s^2 is outside [1e-3, 4e6)");
	if (have_e) {
		if (!(o->e > 0 && o->e < 2))
			die_num("--e", o->e, "is outside (0, 2)");
		if (have_depth) {
			fprintf(stderr, "swell-sim: --e and --depth both set e (e = g dt^2 d / dx^2): give one\n");
			exit(2);
		}
		p.e = (q30_t)llround(o->e * SWELL_Q30_ONE);
	} else if (have_dt || have_depth || have_dx) {
		double us = o->dt * 1e6, d_um = o->depth * 1e6, dx_um = o->dx * 1e6, g = o->g * 1e3;

		if (!have_dt || !have_depth || !have_dx) {
			fprintf(stderr,
				"swell-sim: e from the physical parameters needs all of --dt, --depth and --dx "
				"(missing %s)\n",
				!have_dt              ? "--dt"
					: !have_depth ? "--depth"
						      : "--dx");
			exit(2);
		}
		err = swell_wave_e_from_physical((uint32_t)llround(g), (uint32_t)llround(us), (uint32_t)llround(d_um),
						 (uint32_t)llround(dx_um), &p.e);
		if (err != SWELL_OK) {
			fprintf(stderr, "swell-sim: e = g dt^2 d / dx^2 = %g is outside (0, 2)\n",
				o->g * o->dt * o->dt * o->depth / (o->dx * o->dx));
			exit(2);
		}
	} else {
		p.e = (q30_t)llround(0.2009 * SWELL_Q30_ONE);
	}
	err = swell_wave_check(&p);
	if (err == SWELL_EUNSTABLE || err == SWELL_ERANGE) {
		double lim = (double)swell_wave_e_limit(p.damping, p.stencil) / SWELL_Q30_ONE;
		fprintf(stderr,
			"swell-sim: --e %.6g is %s the stability limit %.6g for damping %g (stencil %s): "
			"refused\n",
			(double)p.e / SWELL_Q30_ONE, err == SWELL_EUNSTABLE ? "at or above" : "beyond", lim, o->damping,
			o->stencil == SWELL_STENCIL_PAPER ? "paper" : "calibrated");
		exit(2);
	}
	if (err != SWELL_OK) {
		fprintf(stderr, "swell-sim: parameters refused: %s\n", swell_err_str(err));
		exit(2);
	}
	return p;
}

static double now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static int32_t mm_to_lsb(const char *what, double mm)
{
	double lsb = mm * SWELL_H_ONE_MM;

	if (!(fabs(lsb) <= SWELL_H_MAX))
		die_num(what, mm, "mm is beyond the height range +-2048 mm");
	return (int32_t)llround(lsb);
}

static void init_field(struct swell_wave *w, const struct opts *o)
{
	const double *a = o->init_arg;

	if (o->init == INIT_SEICHE) {
		if (a[0] < 0 || a[1] < 0 || a[0] > 65535 || a[1] > 65535 || a[0] != floor(a[0]) || a[1] != floor(a[1]))
			swell_cli_die("swell-sim",
				      "--init seiche: mode numbers M, N must be whole numbers in [0, 65535]");
		swell_shape_seiche(w->h, w->nx, w->ny, (uint16_t)a[0], (uint16_t)a[1],
				   mm_to_lsb("--init seiche amplitude", a[2]));
	} else if (o->init == INIT_GAUSS) {
		if (!(a[2] >= 0.5 && a[2] < 4096) || !(fabs(a[0]) < 16384 && fabs(a[1]) < 16384))
			swell_cli_die("swell-sim",
				      "--init gauss: sigma must be in [0.5, 4096) cells and X, Y within +-16384");
		swell_shape_gauss(w->h, w->nx, w->ny, (q16_t)llround(a[0] * SWELL_Q16_ONE),
				  (q16_t)llround(a[1] * SWELL_Q16_ONE), (q16_t)llround(a[2] * SWELL_Q16_ONE),
				  mm_to_lsb("--init gauss amplitude", a[3]));
	}
	swell_wave_rest(w);
}

/* Energy of the fixed field in mm^2 (E * 2^31 = kin * 2^31 + e_eff * pot2, heights in LSB). */
static double energy_mm2(const struct swell_wave *w)
{
	struct swell_energy en = swell_wave_energy(w);
	double lsb2 = (double)en.kin + (double)en.e_eff / SWELL_Q30_ONE * 0.5 * (double)en.pot2;

	return lsb2 / ((double)SWELL_H_ONE_MM * SWELL_H_ONE_MM);
}

/* Same energy for the float64 field, directly from its three-level state (mirrored ghosts). */
static double energy_ref_mm2(const struct swell_wave_ref *r)
{
	double kin = 0, pot = 0;
	int i, j;

	for (j = 0; j < r->ny; j++) {
		for (i = 0; i < r->nx; i++) {
			int a = j * r->nx + i;
			double v = r->h[a] - r->hp[a];
			kin += v * v;
			/* each edge once, weights from folding the mirrored diagonals onto the walls */
			if (i + 1 < r->nx) {
				double wgt = (j == 0 || j == r->ny - 1) ? 1.5 : 1.0;
				pot += wgt * (r->h[a + 1] - r->h[a]) * (r->hp[a + 1] - r->hp[a]);
			}
			if (j + 1 < r->ny) {
				double wgt = (i == 0 || i == r->nx - 1) ? 1.5 : 1.0;
				int b = a + r->nx;
				pot += wgt * (r->h[b] - r->h[a]) * (r->hp[b] - r->hp[a]);
				if (i + 1 < r->nx)
					pot += 0.5 * (r->h[b + 1] - r->h[a]) * (r->hp[b + 1] - r->hp[a]);
				if (i > 0)
					pot += 0.5 * (r->h[b - 1] - r->h[a]) * (r->hp[b - 1] - r->hp[a]);
			}
		}
	}
	return kin + r->e_eff * pot;
}

static void dump_csv(const char *path, const double *mm, int nx, int ny)
{
	FILE *f = fopen(path, "w");
	int i, j;

	if (!f) {
		fprintf(stderr, "swell-sim: --dump-csv %s: %s\n", path, strerror(errno));
		exit(2);
	}
	for (j = 0; j < ny; j++)
		for (i = 0; i < nx; i++)
			fprintf(f, "%.10g%c", mm[j * nx + i], i + 1 < nx ? ',' : '\n');
	if (fclose(f) != 0) {
		fprintf(stderr, "swell-sim: --dump-csv %s: %s\n", path, strerror(errno));
		exit(2);
	}
}

static void progress(long k, long steps, double t0, double *next)
{
	double t = now_s();

	if (t < *next)
		return;
	*next = t + 1.0;
	fprintf(stderr, "\rswell-sim: step %ld / %ld (%.0f%%), %.1f s", k, steps, 100.0 * k / steps, t - t0);
}

int main(int argc, char **argv)
{
	struct opts o;
	struct swell_wave_params p;
	struct swell_wave w;
	struct swell_wave_ref r;
	int32_t *store;
	double *rstore, *mm, t0, t1, e0, e1, vol0, vol1, hmin = 0, hmax = 0, next;
	long k;
	int n, a, show = isatty(2);

	parse_args(argc, argv, &o);
	p = make_params(&o);
	n = o.nx * o.ny;
	store = calloc(SWELL_WAVE_WORDS(o.nx, o.ny), sizeof(*store));
	rstore = calloc(SWELL_WAVE_REF_DOUBLES(o.nx, o.ny), sizeof(*rstore));
	mm = calloc((size_t)n, sizeof(*mm));
	if (!store || !rstore || !mm ||
	    swell_wave_init(&w, (uint16_t)o.nx, (uint16_t)o.ny, store, SWELL_WAVE_WORDS(o.nx, o.ny), &p) != SWELL_OK) {
		fprintf(stderr, "swell-sim: %s for a %dx%d grid\n",
			store && rstore && mm ? "solver refused the parameters" : "out of memory", o.nx, o.ny);
		free(store);
		free(rstore);
		free(mm);
		return 2;
	}
	swell_wave_set_sleep(&w, !o.no_sleep);
	init_field(&w, &o);
	if (sim_object_active()) {
		int rc = sim_object_run(&w, isnan(o.dt) ? 0 : o.dt, isnan(o.dx) ? 0 : o.dx, o.steps, o.float64);
		free(store);
		free(rstore);
		free(mm);
		return rc;
	}
	swell_wave_ref_from_fixed(&r, &w, rstore);

	if (o.float64) {
		e0 = energy_ref_mm2(&r);
		vol0 = swell_wave_ref_volume(&r);
	} else {
		e0 = energy_mm2(&w);
		vol0 = (double)swell_wave_volume(&w);
	}
	t0 = now_s();
	next = t0 + 1.0;
	for (k = 0; k < o.steps; k++) {
		if (o.float64)
			swell_wave_ref_step(&r);
		else
			swell_wave_step(&w);
		if (show && (k & 63) == 0)
			progress(k, o.steps, t0, &next);
	}
	t1 = now_s();
	if (show && t1 > t0 + 1.0)
		fprintf(stderr, "\r%60s\r", "");

	for (a = 0; a < n; a++)
		mm[a] = o.float64 ? r.h[a] : (double)swell_wave_h(&w, (size_t)a) / SWELL_H_ONE_MM;
	for (a = 0; a < n; a++) {
		hmin = a == 0 || mm[a] < hmin ? mm[a] : hmin;
		hmax = a == 0 || mm[a] > hmax ? mm[a] : hmax;
	}
	if (o.float64) {
		e1 = energy_ref_mm2(&r);
		vol1 = swell_wave_ref_volume(&r);
	} else {
		e1 = energy_mm2(&w);
		vol1 = (double)swell_wave_volume(&w);
	}

	printf("swell-sim: %dx%d cells, stencil %s, impl %s\n", o.nx, o.ny,
	       o.stencil == SWELL_STENCIL_PAPER ? "paper" : "calibrated", o.float64 ? "float64" : "fixed");
	printf("steps           %ld\n", o.steps);
	printf("e               %.9f (e_eff %.9f), damping t %.9f\n", (double)p.e / SWELL_Q30_ONE,
	       (double)w.e_eff / SWELL_Q30_ONE, (double)p.damping / SWELL_Q30_ONE);
	printf("stability limit e < %.9f\n", (double)swell_wave_e_limit(p.damping, p.stencil) / SWELL_Q30_ONE);
	if (o.float64)
		printf("volume drift    %+.3e mm*cells\n", vol1 - vol0);
	else
		printf("volume drift    %+.0f LSB (1 LSB = 2^-16 mm * cell)\n", vol1 - vol0);
	printf("energy          %.9e -> %.9e mm^2 (%+.3e relative)\n", e0, e1, e0 != 0 ? (e1 - e0) / e0 : 0.0);
	printf("height          min %.6f mm, max %.6f mm\n", hmin, hmax);
	if (o.float64)
		printf("checksum        n/a (float64)\n");
	else
		printf("checksum        0x%08x\n", swell_wave_checksum(&w));
	if (!o.float64 && w.saturations)
		printf("saturations     %u\n", w.saturations);
	if (!o.float64 && o.steps > 0)
		printf("sleeping tiles  %.1f%% of tile-rows skipped\n",
		       100.0 * w.tiles_skipped / ((double)o.steps * o.ny * w.tiles_x));
	if (o.steps > 0)
		printf("time            %.3f s, %.2f ns per cell-step\n", t1 - t0,
		       (t1 - t0) * 1e9 / ((double)o.steps * n));
	if (o.dump_csv)
		dump_csv(o.dump_csv, mm, o.nx, o.ny);
	free(store);
	free(rstore);
	free(mm);
	return 0;
}
