/* swell-bench: run time against error, stability maps and stress runs of the wave solver variants.
 * Host-only. Writes CSV files and gnuplot PNGs into --out; figures and progress on the terminal.
 * Exit status: 0 all correctness checks passed, 1 a check failed, 2 bad arguments. Wall-clock
 * figures are reported, never checked. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "bench.h"
#include "scene.h"
#include "measure.h"
#include "swell/wave_ref.h"

struct row {
	enum bench_impl impl;
	enum swell_stencil st;
	int nx;
	double e, e_eff;
	double ns, ratio, instr;
	double linf_ref, l2_ref, linf_eig, l2_eig, linf_sei, l2_sei, omega_ratio;
	double vol_lsb, vol_mm, e_drift;
	double err_bound; /* shipped: LSB sqrt(steps) / omega_d, mm */
	uint32_t sat;
	int pareto;
};

static struct row *rows;
static int nrows, rows_cap;
static int failures;
static double f405_instr[BENCH_IMPL_COUNT];

void check(int ok, const char *fmt, ...)
{
	va_list ap;

	if (ok)
		return;
	failures++;
	fprintf(stderr, "swell-bench: CHECK FAILED: ");
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fputc('\n', stderr);
}

void progress(const char *fmt, ...)
{
	va_list ap;

	fprintf(stderr, "swell-bench: ");
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fputc('\n', stderr);
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

static const char *stencil_name(enum swell_stencil st)
{
	return st == SWELL_STENCIL_CALIBRATED ? "calibrated" : "paper";
}

FILE *open_out(const struct opts *o, const char *name)
{
	char path[4096];
	FILE *fp;

	snprintf(path, sizeof(path), "%s/%s", o->out, name);
	fp = fopen(path, "w");
	if (!fp) {
		fprintf(stderr, "swell-bench: cannot write %s: %s\n", path, strerror(errno));
		exit(1);
	}
	return fp;
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

/* ---- error runs ------------------------------------------------------------------------- */

struct sample {
	long step;
	double linf_ref, l2_ref, linf_eig, l2_eig, linf_sei, l2_sei, e_drift, vol_lsb;
};

/* Run the (1,1) mode at AMP_MM from rest and compare at the given steps (ascending) with: float64
 * of the same scheme (swell_wave_ref, the impl's own coefficients, its quantised start), the exact
 * discrete eigenmode (scalar recurrence, the impl's coefficients), and, when t = 0, the continuous
 * seiche for the physical e. */
static void error_run(enum bench_impl impl, enum swell_stencil st, int nx, double e, double t, const long *at, int nat,
		      struct sample *out, uint32_t *sat)
{
	struct bench_field f;
	struct bench_mode md;
	struct bench_amp am;
	struct swell_wave_ref r;
	int n = nx * nx, a, s = 0;
	double *h = xmalloc((size_t)n * sizeof(double)), *x = xmalloc((size_t)n * sizeof(double));
	double *rs = xmalloc(SWELL_WAVE_REF_DOUBLES(nx, nx) * sizeof(double));
	double v0, e0, w_sei;
	long k;

	init_or_die(&f, impl, nx, e, t, st);
	bench_mode_init(&md, nx, nx, MODE_M, MODE_N);
	bench_mode_field(&md, AMP_MM, h);
	bench_field_set_mm(&f, h);
	bench_field_get_mm(&f, h);
	r.nx = r.ny = nx;
	r.h = rs;
	r.hp = rs + n;
	r.next = rs + 2 * n;
	r.e_eff = f.e_eff;
	r.q = f.q;
	r.steps = 0;
	for (a = 0; a < n; a++)
		r.h[a] = r.hp[a] = h[a];
	bench_amp_init(&am, AMP_MM, f.e_eff, f.q, md.S);
	w_sei = bench_omega_seiche(e, &md);
	v0 = bench_field_volume_lsb(&f);
	e0 = bench_field_energy(&f);
	for (k = 1; s < nat; k++) {
		bench_field_step(&f);
		swell_wave_ref_step(&r);
		bench_amp_step(&am);
		if (k != at[s])
			continue;
		out[s].step = k;
		bench_field_get_mm(&f, h);
		bench_err(h, r.h, n, &out[s].linf_ref, &out[s].l2_ref);
		bench_mode_field(&md, (double)am.s, x);
		bench_err(h, x, n, &out[s].linf_eig, &out[s].l2_eig);
		if (t == 0) {
			bench_mode_field(&md, bench_amp_closed(AMP_MM, w_sei, k), x);
			bench_err(h, x, n, &out[s].linf_sei, &out[s].l2_sei);
		} else {
			out[s].linf_sei = out[s].l2_sei = NAN;
		}
		out[s].e_drift = e0 > 0 ? (bench_field_energy(&f) - e0) / e0 : NAN;
		out[s].vol_lsb = bench_field_volume_lsb(&f) - v0;
		s++;
	}
	*sat = f.saturations;
	bench_field_free(&f);
	free(h);
	free(x);
	free(rs);
}

/* ---- timing ----------------------------------------------------------------------------- */

/* Best of o->reps batches of about 2^18 cell-steps each, after one warm-up batch, every impl
 * interleaved in each repetition so that all see the same machine state. ns per cell-step. */
static void time_group(const struct opts *o, enum swell_stencil st, int nx, double e, double *ns)
{
	struct bench_field f[BENCH_IMPL_COUNT];
	struct bench_mode md;
	int n = nx * nx, k, rep;
	long batch = (1L << 18) / n > 2 ? (1L << 18) / n : 2;
	double *h = xmalloc((size_t)n * sizeof(double));

	bench_mode_init(&md, nx, nx, MODE_M, MODE_N);
	bench_mode_field(&md, AMP_MM, h);
	for (k = 0; k < BENCH_IMPL_COUNT; k++) {
		init_or_die(&f[k], (enum bench_impl)k, nx, e, 0.0, st);
		bench_field_set_mm(&f[k], h);
		bench_field_steps(&f[k], batch); /* warm-up: caches, branch predictors, page faults */
		ns[k] = INFINITY;
	}
	for (rep = 0; rep < o->reps; rep++) {
		for (k = 0; k < BENCH_IMPL_COUNT; k++) {
			double t0 = now_s(), dt;

			bench_field_steps(&f[k], batch);
			dt = now_s() - t0;
			ns[k] = fmin(ns[k], dt * 1e9 / ((double)batch * n));
		}
	}
	for (k = 0; k < BENCH_IMPL_COUNT; k++)
		bench_field_free(&f[k]);
	free(h);
}

/* ---- the matrix ------------------------------------------------------------------------- */

static struct row *new_row(void)
{
	if (nrows == rows_cap) {
		rows_cap = rows_cap ? 2 * rows_cap : 64;
		rows = realloc(rows, (size_t)rows_cap * sizeof(*rows));
		if (!rows) {
			fprintf(stderr, "swell-bench: out of memory\n");
			exit(1);
		}
	}
	memset(&rows[nrows], 0, sizeof(rows[0]));
	return &rows[nrows++];
}

/* The Pareto front of cost (ratio to f32, less sensitive to machine load than ns) against error
 * (L-inf against the exact eigenmode), among the fixed-point kernels only: float has no place on the
 * controller path, so f32 and f64 are baselines, not candidates. */
static void mark_pareto(struct row *g, int n)
{
	int a, b;

	for (a = 0; a < n; a++) {
		g[a].pareto = bench_impl_is_fixed(g[a].impl);
		for (b = 0; b < n && g[a].pareto; b++)
			if (b != a && bench_impl_is_fixed(g[b].impl) && g[b].ratio <= g[a].ratio &&
			    g[b].linf_eig <= g[a].linf_eig &&
			    (g[b].ratio < g[a].ratio || g[b].linf_eig < g[a].linf_eig))
				g[a].pareto = 0;
	}
}

static void run_matrix(const struct opts *o)
{
	const enum swell_stencil sts[2] = { SWELL_STENCIL_PAPER, SWELL_STENCIL_CALIBRATED };
	int total = 2 * o->ngrids * o->nes, done = 0, si, gi, ei, k, s;
	long at[20];
	struct sample smp[20];
	double t_start = now_s();

	for (s = 0; s < 20; s++) {
		at[s] = o->steps * (s + 1) / 20; /* --steps >= 20, so these are ascending and >= 1 */
		if (s > 0 && at[s] <= at[s - 1])
			at[s] = at[s - 1] + 1;
	}

	for (gi = 0; gi < o->ngrids; gi++) {
		for (si = 0; si < 2; si++) {
			for (ei = 0; ei < o->nes; ei++) {
				int nx = o->grids[gi];
				double e = o->es[ei], ns[BENCH_IMPL_COUNT];
				int first; /* the group's first row (rows may move when they grow) */

				progress("matrix %d/%d: %s stencil, %dx%d, e = %.3f (%.1f s so far)", ++done, total,
					 stencil_name(sts[si]), nx, nx, e, now_s() - t_start);
				time_group(o, sts[si], nx, e, ns);
				first = nrows;
				for (k = 0; k < BENCH_IMPL_COUNT; k++) {
					struct row *r = new_row();
					struct bench_field tmp;
					uint32_t sat;

					r->impl = (enum bench_impl)k;
					r->st = sts[si];
					r->nx = nx;
					r->e = e;
					init_or_die(&tmp, r->impl, nx, e, 0, sts[si]);
					r->e_eff = tmp.e_eff;
					bench_field_free(&tmp);
					r->ns = ns[k];
					r->ratio = ns[k] / ns[BENCH_F32];
					r->instr = f405_instr[k];
					error_run(r->impl, sts[si], nx, e, 0.0, at, 20, smp, &sat);
					r->linf_ref = r->l2_ref = r->linf_eig = r->l2_eig = r->linf_sei = r->l2_sei = 0;
					r->e_drift = 0;
					for (s = 0; s < 20; s++) {
						r->linf_ref = fmax(r->linf_ref, smp[s].linf_ref);
						r->l2_ref = fmax(r->l2_ref, smp[s].l2_ref);
						r->linf_eig = fmax(r->linf_eig, smp[s].linf_eig);
						r->l2_eig = fmax(r->l2_eig, smp[s].l2_eig);
						r->linf_sei = fmax(r->linf_sei, smp[s].linf_sei);
						r->l2_sei = fmax(r->l2_sei, smp[s].l2_sei);
						if (fabs(smp[s].e_drift) > fabs(r->e_drift))
							r->e_drift = smp[s].e_drift;
					}
					r->vol_lsb = smp[19].vol_lsb;
					{
						struct bench_field g;

						init_or_die(&g, r->impl, nx, e, 0, sts[si]);
						r->vol_mm = r->vol_lsb * g.lsb_mm / ((double)nx * nx);
						bench_field_free(&g);
					}
					{
						struct bench_mode md;

						bench_mode_init(&md, nx, nx, MODE_M, MODE_N);
						r->omega_ratio = bench_omega_discrete(r->e_eff, md.S) /
							bench_omega_seiche(e, &md);
						r->err_bound = sqrt((double)o->steps) /
							bench_omega_discrete(r->e_eff, md.S) / SWELL_H_ONE_MM;
					}
					r->sat = sat;
					if (bench_impl_wave(r->impl) || r->impl == BENCH_EF16)
						check(r->vol_lsb == 0,
						      "%s %s %dx%d e=%.3f: volume drift %.0f LSB, must be 0",
						      bench_impl_name(r->impl), stencil_name(sts[si]), nx, nx, e,
						      r->vol_lsb);
					if (r->impl == BENCH_VEL_REF || r->impl == BENCH_VEL_FUSED) /* after velocity */
						check(r->linf_eig == rows[first + BENCH_VELOCITY].linf_eig &&
							      r->linf_ref == rows[first + BENCH_VELOCITY].linf_ref,
						      "%s %s %dx%d e=%.3f: error differs from velocity (another kernel "
						      "of the same bits)",
						      bench_impl_name(r->impl), stencil_name(sts[si]), nx, nx, e);
					if (r->impl == BENCH_SHIPPED) {
						check(sat == 0, "shipped %s %dx%d e=%.3f: %u saturations at 1 mm",
						      stencil_name(sts[si]), nx, nx, e, sat);
						/* Stated bound: rounding errors of +-1/2 LSB per flow and step act as a
						 * random force, so the error of a mode of frequency w grows like a random
						 * walk, about LSB sqrt(steps) / w; measured 0.14..0.22 of that, checked
						 * against 1x. */
						check(r->linf_ref < r->err_bound,
						      "shipped %s %dx%d e=%.3f: L-inf against float64 %.3g mm > bound "
						      "LSB sqrt(steps)/w = %.3g mm",
						      stencil_name(sts[si]), nx, nx, e, r->linf_ref, r->err_bound);
						/* the same model for energy: relative drift below 2 bound / amplitude */
						check(fabs(r->e_drift) < 2 * r->err_bound / AMP_MM,
						      "shipped %s %dx%d e=%.3f: energy drift %.3g > 2 bound / A = %.3g "
						      "(t = 0)",
						      stencil_name(sts[si]), nx, nx, e, r->e_drift,
						      2 * r->err_bound / AMP_MM);
					}
					if (r->impl == BENCH_F64)
						check(r->linf_eig < 1e-9,
						      "f64 %s %dx%d e=%.3f: %.3g mm from the exact eigenmode (> 1e-9 "
						      "mm): "
						      "the eigenmode or the reference is wrong",
						      stencil_name(sts[si]), nx, nx, e, r->linf_eig);
				}
				mark_pareto(&rows[first], BENCH_IMPL_COUNT);
			}
		}
	}
}

static void write_matrix(const struct opts *o)
{
	FILE *fp = open_out(o, "matrix.csv");
	int k;

	fprintf(fp,
		"impl,stencil,nx,ny,e,e_eff,t,steps,ns_per_cell_step,ratio_f32,f405_instr_per_cell_step,"
		"bytes_per_cell,linf_ref64_mm,l2_ref64_mm,linf_eigen_mm,l2_eigen_mm,linf_seiche_mm,"
		"l2_seiche_mm,omega_ratio,volume_drift_lsb,volume_drift_mm,energy_drift_rel,saturations,"
		"pareto\n");
	for (k = 0; k < nrows; k++) {
		const struct row *r = &rows[k];

		fprintf(fp, "%s,%s,%d,%d,%.4f,%.9f,0,%ld,%.3f,%.3f,", bench_impl_name(r->impl), stencil_name(r->st),
			r->nx, r->nx, r->e, r->e_eff, o->steps, r->ns, r->ratio);
		if (r->instr > 0)
			fprintf(fp, "%.2f", r->instr);
		fprintf(fp, ",%zu,%.3e,%.3e,%.3e,%.3e,%.3e,%.3e,%.6f,%.0f,%.3e,%.3e,%u,%d\n",
			bench_impl_bytes_per_cell(r->impl), r->linf_ref, r->l2_ref, r->linf_eig, r->l2_eig, r->linf_sei,
			r->l2_sei, r->omega_ratio, r->vol_lsb, r->vol_mm, r->e_drift, r->sat, r->pareto);
	}
	fclose(fp);
}

static void print_matrix(const struct opts *o)
{
	int k;

	printf("\n== run time against error: (1,1) mode, 1 mm, t = 0, %ld steps; errors are the maximum "
	       "over 20 samples ==\n",
	       o->steps);
	printf("cost: best of %d batches of ~2^18 cell-steps after a warm-up, CLOCK_MONOTONIC, impls "
	       "interleaved; ratio to f32 of the same grid and e\n",
	       o->reps);
	printf("%-10s %-10s %4s %5s %9s %6s %5s %10s %10s %10s %8s %10s %10s %s\n", "impl", "stencil", "grid", "e",
	       "ns/cell", "x f32", "B/cel", "Linf64 mm", "Linf_eig", "Linf_sei", "w_d/w_c", "vol drift", "E drift",
	       "pareto");
	for (k = 0; k < nrows; k++) {
		const struct row *r = &rows[k];

		printf("%-10s %-10s %4d %5.3f %9.3f %6.2f %5zu %10.3e %10.3e %10.3e %8.5f %8.0fLSB %10.2e %s\n",
		       bench_impl_name(r->impl), stencil_name(r->st), r->nx, r->e, r->ns, r->ratio,
		       bench_impl_bytes_per_cell(r->impl), r->linf_ref, r->linf_eig, r->linf_sei, r->omega_ratio,
		       r->vol_lsb, r->e_drift, r->pareto ? "*" : "");
	}
	printf("\nPareto front (fixed point; cost x f32 against L-inf vs eigenmode; * above):\n");
	for (k = 0; k < nrows; k++) {
		const struct row *r = &rows[k];

		if (r->pareto)
			printf("  %-10s %-10s %4dx%-4d e=%.3f: %5.2f x f32 (%.2f ns/cell-step), %.2e mm, volume "
			       "drift %.0f LSB\n",
			       bench_impl_name(r->impl), stencil_name(r->st), r->nx, r->nx, r->e, r->ratio, r->ns,
			       r->linf_eig, r->vol_lsb);
	}
}

/* ---- error against steps ------------------------------------------------------------------ */

static void run_error_steps(const struct opts *o)
{
	const enum swell_stencil sts[2] = { SWELL_STENCIL_PAPER, SWELL_STENCIL_CALIBRATED };
	long at[64];
	int nat = 0, si, k, s;
	struct sample smp[64];
	double dec;
	FILE *fp = open_out(o, "error_steps.csv");

	for (dec = 1; dec <= o->long_steps && nat < 60; dec *= 10) {
		const double mul[4] = { 1, 2, 5, 0 };

		for (k = 0; mul[k] > 0 && nat < 60; k++)
			if (dec * mul[k] <= o->long_steps)
				at[nat++] = (long)(dec * mul[k]);
	}
	if (nat == 0 || at[nat - 1] != o->long_steps)
		at[nat++] = o->long_steps;
	fprintf(fp,
		"impl,stencil,nx,e,step,linf_ref64_mm,l2_ref64_mm,linf_eigen_mm,l2_eigen_mm,linf_seiche_mm,"
		"energy_drift_rel,volume_drift_lsb\n");
	for (si = 0; si < 2; si++) {
		for (k = 0; k < BENCH_IMPL_COUNT; k++) {
			uint32_t sat;

			if (k == BENCH_VEL_REF || k == BENCH_VEL_FUSED)
				continue; /* the bits of velocity (the matrix checks it) */
			progress("error against steps: %s, %s stencil, 64x64, e = 0.2, %ld steps",
				 bench_impl_name((enum bench_impl)k), stencil_name(sts[si]), o->long_steps);
			error_run((enum bench_impl)k, sts[si], 64, 0.2, 0.0, at, nat, smp, &sat);
			for (s = 0; s < nat; s++)
				fprintf(fp, "%s,%s,64,0.2,%ld,%.4e,%.4e,%.4e,%.4e,%.4e,%.4e,%.0f\n",
					bench_impl_name((enum bench_impl)k), stencil_name(sts[si]), smp[s].step,
					smp[s].linf_ref, smp[s].l2_ref, smp[s].linf_eig, smp[s].l2_eig, smp[s].linf_sei,
					smp[s].e_drift, smp[s].vol_lsb);
			printf("error after %ld steps (64x64, e = 0.2, %s): %-10s Linf64 %.3e mm  Linf_eig %.3e mm  "
			       "Linf_sei %.3e mm  E drift %.2e  vol %+.0f LSB\n",
			       o->long_steps, stencil_name(sts[si]), bench_impl_name((enum bench_impl)k),
			       smp[nat - 1].linf_ref, smp[nat - 1].linf_eig, smp[nat - 1].linf_sei,
			       smp[nat - 1].e_drift, smp[nat - 1].vol_lsb);
		}
		fprintf(fp, "\n\n"); /* gnuplot index per stencil */
	}
	fclose(fp);
}

/* ---- stability map ---------------------------------------------------------------------- */

/* the map covers the first two; the boundary all three */
static const enum bench_impl map_impls[3] = { BENCH_SHIPPED, BENCH_F64, BENCH_VELOCITY };

#define MAP_N 16 /* 16 x 16 grid: the highest mode has |S| within 1e-3 of 8 */
#define MAP_GROWTH 1.5 /* bounded: last-quarter max |h| within 1.5x the first quarter's */
#define MAP_E_MAX 1.33 /* 3/2 e_eff must fit Q1.30 */

static int bounded_at(enum bench_impl impl, double e_eff, double t, long steps, double *gain)
{
	struct bench_field f;
	q30_t ee = (q30_t)llround(e_eff * SWELL_Q30_ONE), q = SWELL_Q30_ONE - (q30_t)llround(t * SWELL_Q30_ONE);
	int ok;

	init_or_die(&f, impl, MAP_N, 0.1, 0.0, SWELL_STENCIL_PAPER);
	if (bench_field_force(&f, ee, q) != SWELL_OK) {
		bench_field_free(&f);
		*gain = NAN;
		return -1;
	}
	ok = bench_bounded(&f, AMP_MM, steps, MAP_GROWTH, 12345, gain);
	bench_field_free(&f);
	return ok;
}

static void run_stability(const struct opts *o)
{
	FILE *fp = open_out(o, "stability.csv"), *fb;
	int ki, ie, it, total = 2 * o->map_ne * o->map_nt, done = 0;
	double t_start = now_s();

	fprintf(fp, "impl,t,e_eff,e_limit,bounded,gain\n");
	for (ki = 0; ki < 2; ki++) {
		for (it = 0; it < o->map_nt; it++) {
			double t = 0.75 * it / (o->map_nt - 1);

			if (done % 50 == 0 || it == 0)
				progress("stability map %d/%d (%.1f s)", done, total, now_s() - t_start);
			for (ie = 0; ie < o->map_ne; ie++) {
				double e = 0.30 + (MAP_E_MAX - 0.30) * ie / (o->map_ne - 1), gain;
				int b = bounded_at(map_impls[ki], e, t, o->map_steps, &gain);

				done++;
				fprintf(fp, "%s,%.4f,%.4f,%.6f,%d,%.4g\n", bench_impl_name(map_impls[ki]), t, e,
					bench_e_limit(1 - t), b, gain);
			}
		}
		fprintf(fp, "\n\n");
	}
	fclose(fp);

	/* measured boundary by bisection on e_eff, against (1+q)/(4q) */
	fb = open_out(o, "boundary.csv");
	fprintf(fb, "t,e_limit,e_shipped,e_f64,e_velocity\n");
	printf("\n== stability boundary (paper stencil, e_eff; %dx%d noise 1 mm, %ld steps; bounded = max|h| "
	       "of the last quarter within %gx the first quarter's, no saturation) ==\n",
	       MAP_N, MAP_N, o->map_steps, MAP_GROWTH);
	printf("%6s %12s %12s %12s %12s %10s %10s %10s\n", "t", "analytic", "shipped", "f64", "velocity", "ship/ana",
	       "f64/ana", "vel/ana");
	for (it = 0; it < o->bnd_nt; it++) {
		double t = 0.75 * it / (o->bnd_nt - 1), lim = bench_e_limit(1 - t), meas[3];

		for (ki = 0; ki < 3; ki++) {
			double lo = 0.9 * lim, hi = fmin(1.1 * lim, MAP_E_MAX), gain;
			int iter;

			if (bounded_at(map_impls[ki], hi, t, o->map_steps, &gain) == 1) {
				meas[ki] = INFINITY; /* bounded up to the largest e_eff that fits Q1.30 */
				continue;
			}
			if (bounded_at(map_impls[ki], lo, t, o->map_steps, &gain) != 1) {
				meas[ki] = NAN;
				continue;
			}
			for (iter = 0; iter < 20; iter++) {
				double mid = 0.5 * (lo + hi);

				if (bounded_at(map_impls[ki], mid, t, o->map_steps, &gain) == 1)
					lo = mid;
				else
					hi = mid;
			}
			meas[ki] = 0.5 * (lo + hi);
		}
		fprintf(fb, "%.4f,%.6f,%.6f,%.6f,%.6f\n", t, lim, meas[0], meas[1], meas[2]);
		printf("%6.3f %12.6f %12.6f %12.6f %12.6f %10.5f %10.5f %10.5f\n", t, lim, meas[0], meas[1], meas[2],
		       meas[0] / lim, meas[1] / lim, meas[2] / lim);
		/* rounding must not move the boundary: the velocity form's within 0.1 % of float64's measured
		 * in the same run (how far above the analytic one a finite run resolves depends on its length:
		 * 0.12 % at t = 0.75 in the quick preset's 1000 steps, for f64 too) */
		check(isfinite(meas[2]) && fabs(meas[2] / meas[1] - 1) < 0.001 && meas[2] >= lim,
		      "velocity form: stability boundary at t = %.3f is %.5f, float64 %.5f, analytic %.5f (more than "
		      "0.1%% from float64, or below the analytic)",
		      t, meas[2], meas[1], lim);
		check(isfinite(meas[1]) && fabs(meas[1] / lim - 1) < 0.01,
		      "f64 stability boundary at t = %.3f is %.5f, analytic %.5f (more than 1%% apart)", t, meas[1],
		      lim);
		check(isnan(meas[0]) == 0 && meas[0] >= 0.98 * lim,
		      "shipped solver unbounded below 0.98 of the analytic limit at t = %.3f (%.5f vs %.5f)", t,
		      meas[0], lim);
	}
	fclose(fb);
}

/* ---- stress ----------------------------------------------------------------------------- */

static FILE *stress_fp;

/* Long run at the edge of the stability region from noise (amp_frac of the kernel's bound; a mode
 * at amp_frac when mode_frac > 0): growth is the last quarter's max |h| over the first quarter's. */
static void stress_edge(const struct opts *o, const char *scenario, enum bench_impl impl, double t, double mode_frac,
			double noise_frac)
{
	struct bench_field f;
	struct bench_mode md;
	q30_t lim = swell_wave_e_limit((q30_t)llround(t * SWELL_Q30_ONE), SWELL_STENCIL_PAPER);
	int n = 64 * 64;
	long steps = (long)ceil(o->stress_cells / n), k, first_sat = -1;
	double m_first = 0, m_last = 0, m_all = 0, e0, ed_max = 0, v0, t0 = now_s(), ratio, e_end;
	char sat_at[48] = "";
	struct bench_rng rng;
	double *h = xmalloc((size_t)n * sizeof(double));
	int a;

	init_or_die(&f, impl, 64, 0.1, t, SWELL_STENCIL_PAPER);
	/* the largest e_eff the shipped check accepts: one even step below the exclusive limit */
	bench_field_force(&f, (lim - 1) & ~(q30_t)1, SWELL_Q30_ONE - (q30_t)llround(t * SWELL_Q30_ONE));
	bench_mode_init(&md, 64, 64, MODE_M, MODE_N);
	bench_mode_field(&md, mode_frac * f.h_max * f.lsb_mm, h);
	bench_rng_seed(&rng, 777);
	for (a = 0; a < n; a++)
		h[a] += noise_frac * f.h_max * f.lsb_mm * (2 * bench_rng_uniform(&rng) - 1);
	bench_field_set_mm(&f, h);
	free(h);
	e0 = bench_field_energy(&f);
	v0 = bench_field_volume_lsb(&f);
	for (k = 1; k <= steps; k++) {
		bench_field_step(&f);
		if (first_sat < 0 && f.saturations)
			first_sat = k;
		if (k % 16 == 0 || k == steps) {
			double m = bench_field_max_abs_lsb(&f);

			m_all = fmax(m_all, m);
			if (k <= steps / 4)
				m_first = fmax(m_first, m);
			if (k > steps - steps / 4)
				m_last = fmax(m_last, m);
			if (t == 0)
				ed_max = fmax(ed_max, fabs(bench_field_energy(&f) - e0) / e0);
		}
		if (k % (steps / 5 > 0 ? steps / 5 : 1) == 0)
			progress("stress %s %s t=%.2f: %ld/%ld steps, max|h| %.4g mm (%.1f s)", scenario,
				 bench_impl_name(impl), t, k, steps, m_all * f.lsb_mm, now_s() - t0);
	}
	ratio = m_first > 0 ? m_last / m_first : 0;
	if (first_sat >= 0)
		snprintf(sat_at, sizeof(sat_at), " (first at step %ld)", first_sat);
	e_end = bench_field_energy(&f) / e0;
	printf("%-10s %-10s t=%.2f e_eff=%.9f (limit %.6f): %.2e cell-steps, max|h| %.4g mm (%.4f of bound), "
	       "last/first quarter %.3f, %s %.2e, vol drift %+.0f LSB, saturations %u%s\n",
	       scenario, bench_impl_name(impl), t, f.e_eff, bench_e_limit(1 - t), (double)steps * n, m_all * f.lsb_mm,
	       m_all / f.h_max, ratio, t == 0 ? "|E drift| max" : "E end/E0", t == 0 ? ed_max : e_end,
	       bench_field_volume_lsb(&f) - v0, f.saturations, sat_at);
	fprintf(stress_fp, "%s,%s,%.3f,%.9f,%.3e,%.4f,%.3e,%.0f,%u,,\n", scenario, bench_impl_name(impl), t, f.e_eff,
		(double)steps * n, ratio, t == 0 ? ed_max : e_end, bench_field_volume_lsb(&f) - v0, f.saturations);
	/* the shipped kernel saturates to the int28 range: down to -(h_max + 1) */
	check(m_all <= f.h_max + (impl == BENCH_SHIPPED || impl == BENCH_VELOCITY),
	      "%s %s: |h| %.0f LSB beyond the saturation bound", scenario, bench_impl_name(impl), m_all);
	if (impl == BENCH_SHIPPED && noise_frac < 0.01) {
		check(f.saturations == 0 && ratio < 1.5, "shipped at the stability edge t=%.2f grew %.2fx", t, ratio);
		check(bench_field_volume_lsb(&f) == v0, "shipped at the edge: volume drift %+.0f LSB",
		      bench_field_volume_lsb(&f) - v0);
	}
	bench_field_free(&f);
}

/* Random volume-conserving pushes, then free decay: volume, residual motion (limit cycles),
 * frozen residual heights. */
static void stress_forcing(enum bench_impl impl, long push_steps, long decay_steps)
{
	struct bench_field f;
	struct bench_rng rng;
	double v0, resid_v = 0, resid_h = 0;
	long k;
	int i, n = 64 * 64;

	init_or_die(&f, impl, 64, 0.2, 0.02, SWELL_STENCIL_PAPER);
	bench_rng_seed(&rng, 4242);
	v0 = bench_field_volume_lsb(&f);
	for (k = 0; k < push_steps + decay_steps; k++) {
		if (k < push_steps && k % 4 == 0) {
			int i0 = (int)(bench_rng_uniform(&rng) * 58), j0 = (int)(bench_rng_uniform(&rng) * 58);
			double depth_mm = 0.6 * (bench_rng_uniform(&rng) - 0.5);

			bench_push(&f, i0, j0, 6, (int32_t)lround(depth_mm / f.lsb_mm));
		}
		bench_field_step(&f);
		if (k >= push_steps + decay_steps - 200)
			resid_v = fmax(resid_v, bench_field_max_step_lsb(&f));
	}
	{
		double *h = xmalloc((size_t)n * sizeof(double)), mean = bench_field_volume_lsb(&f) / n;

		bench_field_get_mm(&f, h);
		for (i = 0; i < n; i++)
			resid_h = fmax(resid_h, fabs(h[i] / f.lsb_mm - mean));
		free(h);
	}
	printf("forcing %-10s 64x64 e=0.2 t=0.02: %ld steps of pushes (6x6, +-0.3 mm) then %ld free: vol "
	       "drift %+.0f LSB, residual max|dh/step| %.0f LSB (%.2e mm), residual max|h-mean| %.0f LSB "
	       "(%.2e mm)\n",
	       bench_impl_name(impl), push_steps, decay_steps, bench_field_volume_lsb(&f) - v0, resid_v,
	       resid_v * f.lsb_mm, resid_h, resid_h * f.lsb_mm);
	fprintf(stress_fp, "forcing,%s,0.02,%.9f,%.3e,,,%.0f,%u,%.0f,%.0f\n", bench_impl_name(impl), f.e_eff,
		(double)(push_steps + decay_steps) * n, bench_field_volume_lsb(&f) - v0, f.saturations, resid_v,
		resid_h);
	if (impl == BENCH_SHIPPED || impl == BENCH_VELOCITY) {
		check(bench_field_volume_lsb(&f) == v0, "%s under random pushes: volume drift %+.0f LSB",
		      bench_impl_name(impl), bench_field_volume_lsb(&f) - v0);
		check(resid_v == 0, "%s: motion of %.0f LSB/step left after damping (limit cycle)",
		      bench_impl_name(impl), resid_v);
	}
	bench_field_free(&f);
}

static void run_stress(const struct opts *o)
{
	const enum bench_impl forced[] = { BENCH_SHIPPED, BENCH_VELOCITY, BENCH_EF16,    BENCH_TL32_FLOOR,
					   BENCH_TL32_RN, BENCH_TL32_RZ,  BENCH_TL16_RN, BENCH_F32 };
	size_t k;

	stress_fp = open_out(o, "stress.csv");
	fprintf(stress_fp,
		"scenario,impl,t,e_eff,cell_steps,max_gain,energy_drift_max,volume_drift_lsb,"
		"saturations,residual_step_lsb,residual_height_lsb\n");
	printf("\n== stress ==\n");
	/* 1 mm of noise (64 LSB of the int16 kernels' 2^-10 mm: 1/32 of their bound) */
	stress_edge(o, "edge", BENCH_SHIPPED, 0.0, 0, 1.0 / 2048);
	stress_edge(o, "edge", BENCH_SHIPPED, 0.5, 0, 1.0 / 2048);
	stress_edge(o, "edge", BENCH_TL32_RN, 0.0, 0, 1.0 / 2048);
	stress_edge(o, "edge", BENCH_EF16, 0.0, 0, 1.0 / 32);
	for (k = 0; k < sizeof(forced) / sizeof(forced[0]); k++)
		stress_forcing(forced[k], 2000, 4000);
	/* near saturation: the (1,1) mode alone at 97 % of the bound (must not saturate), then at 90 %
	 * with 10 % noise at the edge of stability (saturates: look for wrap, growth, volume) */
	stress_edge(o, "near-bound", BENCH_SHIPPED, 0.0, 0.97, 0);
	stress_edge(o, "near-bound", BENCH_TL32_RN, 0.0, 0.97, 0);
	/* near saturation: the (1,1) mode at 90 % of the bound plus 10 % noise, at the edge */
	stress_edge(o, "saturation", BENCH_SHIPPED, 0.0, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_SHIPPED, 0.5, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_TL32_RN, 0.0, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_VELOCITY, 0.0, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_EF16, 0.0, 0.9, 0.1);
	fclose(stress_fp);
}

/* ---- plots ------------------------------------------------------------------------------ */

/* 0 when the plots were made. */
static int write_plots(const struct opts *o)
{
	FILE *fp = open_out(o, "plots.gp");
	char cmd[4200];
	int k, rc;

	fprintf(fp,
		"# gnuplot script written by swell-bench; run from this directory: gnuplot plots.gp\n"
		"set datafile separator ','\n"
		"set terminal pngcairo size 900,600 font ',10'\n"
		"set key outside right\n"
		"set grid\n"
		"set format y '10^{%%L}'\n"
		"set output 'pareto.png'\n"
		"set title 'Run time against error: (1,1) mode of 1 mm, t = 0; every grid, e and stencil'\n"
		"set logscale xy\n"
		"set xrange [0.2:60]\n"
		"set xlabel 'host cost per cell-step, relative to float32 measured in the same run'\n"
		"set ylabel 'L-inf error against the exact discrete eigenmode (mm)'\n"
		"set key bottom right inside font ',9'\n"
		"impls = '");
	for (k = 0; k < BENCH_IMPL_COUNT; k++)
		fprintf(fp, "%s%s", k ? " " : "", bench_impl_name((enum bench_impl)k));
	fprintf(fp,
		"'\n"
		"plot for [i=1:words(impls)] 'matrix.csv' using (strcol(1) eq word(impls,i) ? $10 : 1/0):"
		"($15 > 1e-16 ? $15 : 1e-16) with points pt i ps 1.3 title word(impls,i), \\\n"
		"     'matrix.csv' using ($24 == 1 && $3 == 64 && $5 > 0.19 && $5 < 0.21 ? $10 : 1/0):"
		"($15 > 1e-16 ? $15 : 1e-16) with points pt 6 ps 3 lc 'black' title "
		"'fixed-point Pareto front, 64x64 e = 0.2'\n"
		"set autoscale x\n"
		"unset logscale\n"
		"set output 'error_steps.png'\n"
		"set title 'Error against steps (64x64, e = 0.2, t = 0; L-inf vs float64 of the same scheme)'\n"
		"set logscale xy\n"
		"set xlabel 'steps'\n"
		"set ylabel 'L-inf (mm)'\n"
		"set multiplot layout 1,2\n"
		"set key bottom right inside font ',8'\n"
		"set title 'paper stencil'\n"
		"plot for [i=1:words(impls)-1] 'error_steps.csv' index 0 using (strcol(1) eq word(impls,i) ? "
		"$5 : 1/0):($6 > 1e-16 ? $6 : 1e-16) with linespoints pt i title word(impls,i), "
		"'error_steps.csv' index 0 using (strcol(1) eq 'shipped' ? $5 : 1/0):($10 > 1e-16 ? $10 : "
		"1/0) with lines dt 2 lc 'black' title 'discretisation (vs seiche)'\n"
		"set title 'calibrated stencil'\n"
		"plot for [i=1:words(impls)-1] 'error_steps.csv' index 1 using (strcol(1) eq word(impls,i) ? "
		"$5 : 1/0):($6 > 1e-16 ? $6 : 1e-16) with linespoints pt i title word(impls,i), "
		"'error_steps.csv' index 1 using (strcol(1) eq 'shipped' ? $5 : 1/0):($10 > 1e-16 ? $10 : "
		"1/0) with lines dt 2 lc 'black' title 'discretisation (vs seiche)'\n"
		"unset multiplot\n"
		"unset logscale\n"
		"set key outside right\n"
		"set format y '%%g'\n"
		"set output 'stability.png'\n"
		"set title 'Stability map, paper stencil (16x16 noise; filled = bounded)'\n"
		"set xlabel 'damping t'\n"
		"set ylabel 'e_{eff}'\n"
		"set xrange [-0.02:0.77]\n"
		"set yrange [0.28:1.35]\n"
		"set samples 200\n"
		"lim(t) = (2 - t) / (4 * (1 - t))\n"
		"plot 'stability.csv' index 0 using ($5 == 1 ? $2 : 1/0):3 with points pt 7 ps 0.9 lc "
		"'dark-green' title 'shipped bounded', \\\n"
		"     'stability.csv' index 0 using ($5 == 0 ? $2 : 1/0):3 with points pt 6 ps 0.9 lc 'red' "
		"title 'shipped unbounded', \\\n"
		"     'stability.csv' index 1 using ($5 == 1 ? $2 : 1/0):($3 + 0.006) with points pt 1 ps 0.5 "
		"lc 'blue' title 'f64 bounded', \\\n"
		"     'boundary.csv' using 1:3 with linespoints pt 9 ps 1.5 lc 'black' title 'measured "
		"boundary (shipped)', \\\n"
		"     lim(x) with lines lw 2 lc 'orange' title 'analytic (1+q)/(4q)'\n");
	fclose(fp);
	if (strchr(o->out, '\'')) {
		progress("output path contains a quote; run gnuplot plots.gp there by hand");
		return -1;
	}
	snprintf(cmd, sizeof(cmd), "cd '%s' && gnuplot plots.gp", o->out);
	rc = system(cmd);
	if (rc != 0) {
		progress("gnuplot failed (exit %d); CSV files are complete, plots not made", rc);
		return -1;
	}
	progress("plots: %s/pareto.png, error_steps.png, stability.png", o->out);
	return 0;
}

/* --replot: the CSV files the plots read, each there and not empty; else the one missing. */
static const char *missing_results(const struct opts *o)
{
	static const char *const need[] = { "matrix.csv", "error_steps.csv", "stability.csv", "boundary.csv" };
	char path[4096];
	struct stat st;
	size_t k;

	for (k = 0; k < sizeof(need) / sizeof(need[0]); k++) {
		snprintf(path, sizeof(path), "%s/%s", o->out, need[k]);
		if (stat(path, &st) != 0 || st.st_size == 0)
			return need[k];
	}
	return NULL;
}

/* ---- arguments -------------------------------------------------------------------------- */

static void usage(FILE *fp)
{
	fprintf(fp,
		"usage: swell-bench [--quick | --full] [--out DIR] [options]\n"
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
		"(never on time), 2 on bad arguments.\n");
}

static void bad(const char *fmt, const char *arg)
{
	fprintf(stderr, "swell-bench: ");
	fprintf(stderr, fmt, arg);
	fprintf(stderr, " (see --help)\n");
	exit(2);
}

static long parse_long(const char *s, const char *what, long lo, long hi)
{
	char *end;
	long v;

	errno = 0;
	v = strtol(s, &end, 10);
	if (errno || end == s || *end || v < lo || v > hi)
		bad(what, s);
	return v;
}

static double parse_double(const char *s, const char *what, double lo, double hi)
{
	char *end;
	double v;

	errno = 0;
	v = strtod(s, &end);
	if (errno || end == s || *end || !(v >= lo && v <= hi))
		bad(what, s);
	return v;
}

static int parse_list(const char *s, const char *what, double *out, double lo, double hi)
{
	char buf[256], *tok, *save = NULL;
	int n = 0;

	if (strlen(s) >= sizeof(buf))
		bad(what, s);
	strcpy(buf, s);
	for (tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
		if (n == MAX_LIST)
			bad(what, s);
		out[n++] = parse_double(tok, what, lo, hi);
	}
	if (!n)
		bad(what, s);
	return n;
}

/* Instructions per cell-step on the STM32F405 image: lines 'impl value', or the image's self-test
 * output under QEMU (-icount shift=0), whose 'solver cell-step: X instructions ...' line is the
 * shipped solver and 'naive int32 9-point cell-step: X' a plain loop, printed for reference. */

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
			snprintf(want, sizeof(want), "cost scene velocity-%s: %%lf instructions per cell-step, %%lf",
				 fw_cost_scene_name[sc]);
			if (sscanf(line, want, &v, &aw) == 2) {
				f405_vcost[sc] = v;
				f405_vcost_awake[sc] = aw;
			}
		}
		if (sscanf(line, "solver cell-step: %lf", &v) == 1) {
			f405_instr[BENCH_SHIPPED] = v;
		} else if (sscanf(line, "naive int32 9-point cell-step: %lf", &v) == 1) {
			f405_naive = v;
		} else if (sscanf(line, "%63s %lf", name, &v) == 2) {
			enum bench_impl k = bench_impl_parse(name);

			if (k != BENCH_IMPL_COUNT)
				f405_instr[k] = v;
		}
	}
	fclose(fp);
	if (f405_instr[BENCH_SHIPPED] > 0 || f405_naive > 0)
		printf("STM32F405 (QEMU -icount shift=0): shipped %.2f, naive int32 9-point loop %.2f "
		       "instructions per cell-step\n",
		       f405_instr[BENCH_SHIPPED], f405_naive);
}

static void preset(struct opts *o, int full)
{
	static const double e_quick[] = { 0.05, 0.2, 0.45 }, e_full[] = { 0.05, 0.1, 0.2, 0.3, 0.45 };
	int k;

	o->preset = full ? "full" : "quick";
	o->ngrids = full ? 3 : 1;
	o->grids[0] = 64;
	o->grids[1] = 128;
	o->grids[2] = 256;
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
	int k, full = 0, replot = 0;
	double t0 = now_s(), list[MAX_LIST];

	memset(&o, 0, sizeof(o));
	o.out = "bench-out";
	o.plots = 1;
	for (k = 1; k < argc; k++)
		if (!strcmp(argv[k], "--full"))
			full = 1;
	preset(&o, full);
	for (k = 1; k < argc; k++) {
		const char *a = argv[k];
		const char *v = k + 1 < argc ? argv[k + 1] : NULL;

		if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
			usage(stdout);
			return 0;
		} else if (!strcmp(a, "--quick") || !strcmp(a, "--full")) {
			continue;
		} else if (!strcmp(a, "--no-plots")) {
			o.plots = 0;
			continue;
		} else if (!strcmp(a, "--replot")) {
			replot = 1;
			continue;
		}
		if (strcmp(a, "--out") && strcmp(a, "--grids") && strcmp(a, "--e") && strcmp(a, "--steps") &&
		    strcmp(a, "--reps") && strcmp(a, "--stress-cells") && strcmp(a, "--f405"))
			bad("unknown option %s", a);
		if (!v)
			bad("option %s needs a value", a);
		k++;
		if (!strcmp(a, "--out")) {
			o.out = v;
		} else if (!strcmp(a, "--grids")) {
			int j;

			o.ngrids = parse_list(v, "bad --grids list '%s' (sides 2..1024)", list, 2, 1024);
			for (j = 0; j < o.ngrids; j++) {
				o.grids[j] = (int)list[j];
				if (list[j] != o.grids[j])
					bad("bad --grids list '%s' (whole numbers)", v);
			}
		} else if (!strcmp(a, "--e")) {
			o.nes = parse_list(v, "bad --e list '%s' (each in (0, 2))", o.es, 1e-6, 1.999);
		} else if (!strcmp(a, "--steps")) {
			o.steps = parse_long(v, "bad --steps '%s' (20..10000000)", 20, 10000000);
		} else if (!strcmp(a, "--reps")) {
			o.reps = (int)parse_long(v, "bad --reps '%s' (1..1000)", 1, 1000);
		} else if (!strcmp(a, "--stress-cells")) {
			o.stress_cells = parse_double(v, "bad --stress-cells '%s' (1e4..1e12)", 1e4, 1e12);
		} else if (!strcmp(a, "--f405")) {
			o.f405 = v;
		} else {
			bad("unknown option %s", a);
		}
	}
	if (!replot && mkdir(o.out, 0777) != 0 && errno != EEXIST) {
		fprintf(stderr, "swell-bench: cannot create %s: %s\n", o.out, strerror(errno));
		return 2;
	}
	{
		/* before the run, not when its first CSV file is written */
		struct stat st;

		if (stat(o.out, &st) != 0 || !S_ISDIR(st.st_mode) || access(o.out, W_OK | X_OK) != 0) {
			fprintf(stderr, "swell-bench: --out %s is not a writable directory\n", o.out);
			return 2;
		}
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
	write_matrix(&o);
	print_matrix(&o);
	printf("\n== error against steps ==\n");
	run_error_steps(&o);
	run_scenes(&o);
	run_stability(&o);
	run_stress(&o);
	if (o.plots)
		write_plots(&o);
	printf("\nswell-bench: %s preset done in %.1f s; %d correctness check%s failed\n", o.preset, now_s() - t0,
	       failures, failures == 1 ? "" : "s");
	free(rows);
	return failures ? 1 : 0;
}
