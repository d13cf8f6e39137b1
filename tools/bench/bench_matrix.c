/* swell-bench: the matrix, run time against error of every kernel on every grid, e and stencil
 * (matrix.csv, the table and the Pareto front). */
#include <string.h>

#include "bench.h"

struct row {
	enum bench_impl impl;
	enum swell_stencil st;
	int nx;
	double e, e_eff;
	double ns, ratio, instr;
	double linf_ref, l2_ref, linf_eig, l2_eig, linf_sei, l2_sei, omega_ratio;
	double vol_lsb, vol_mm, e_drift;
	double err_bound; /* ef32: LSB sqrt(steps) / omega_d, mm */
	uint32_t sat;
	int pareto;
};

static struct row *rows;
static int nrows, rows_cap;

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
			const double t0 = now_s();

			bench_field_steps(&f[k], batch);
			ns[k] = fmin(ns[k], (now_s() - t0) * 1e9 / ((double)batch * n));
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

static void measure_matrix(const struct opts *o)
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
					struct bench_mode md;
					uint32_t sat;
					double lsb_mm;

					r->impl = (enum bench_impl)k;
					r->st = sts[si];
					r->nx = nx;
					r->e = e;
					init_or_die(&tmp, r->impl, nx, e, 0, sts[si]);
					r->e_eff = tmp.e_eff;
					lsb_mm = tmp.lsb_mm;
					bench_field_free(&tmp);
					r->ns = ns[k];
					r->ratio = ns[k] / ns[BENCH_F32];
					r->instr = f405_instr[k];
					error_run(r->impl, sts[si], nx, e, 0.0, at, 20, smp, &sat);
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
					r->vol_mm = r->vol_lsb * lsb_mm / ((double)nx * nx);
					bench_mode_init(&md, nx, nx, MODE_M, MODE_N);
					r->omega_ratio =
						bench_omega_discrete(r->e_eff, md.S) / bench_omega_seiche(e, &md);
					r->err_bound = sqrt((double)o->steps) / bench_omega_discrete(r->e_eff, md.S) /
						SWELL_H_ONE_MM;
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
					if (r->impl == BENCH_EF32) {
						check(sat == 0, "ef32 %s %dx%d e=%.3f: %u saturations at 1 mm",
						      stencil_name(sts[si]), nx, nx, e, sat);
						/* Stated bound: rounding errors of +-1/2 LSB per flow and step act as a
						 * random force, so the error of a mode of frequency w grows like a random
						 * walk, about LSB sqrt(steps) / w; measured 0.14..0.22 of that, checked
						 * against 1x. */
						check(r->linf_ref < r->err_bound,
						      "ef32 %s %dx%d e=%.3f: L-inf against float64 %.3g mm > bound "
						      "LSB sqrt(steps)/w = %.3g mm",
						      stencil_name(sts[si]), nx, nx, e, r->linf_ref, r->err_bound);
						/* the same model for energy: relative drift below 2 bound / amplitude */
						check(fabs(r->e_drift) < 2 * r->err_bound / AMP_MM,
						      "ef32 %s %dx%d e=%.3f: energy drift %.3g > 2 bound / A = %.3g "
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

void run_matrix(const struct opts *o)
{
	measure_matrix(o);
	write_matrix(o);
	print_matrix(o);
	free(rows);
}
