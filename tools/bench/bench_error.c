/* swell-bench: the error runs, shared by the matrix, and the error against steps (error_steps.csv). */
#include "bench.h"
#include "swell/wave_ref.h"

/* Run the (1,1) mode at AMP_MM from rest and compare at the given steps (ascending) with: float64
 * of the same scheme (swell_wave_ref, the impl's own coefficients, its quantised start), the exact
 * discrete eigenmode (scalar recurrence, the impl's coefficients), and, when t = 0, the continuous
 * seiche for the physical e. */
void error_run(enum bench_impl impl, enum swell_stencil st, int nx, double e, double t, const long *at, int nat,
	       struct sample *out, uint32_t *sat)
{
	struct bench_field f;
	struct bench_mode md;
	struct bench_amp am;
	struct swell_wave_ref r;
	int n = nx * nx, s = 0;
	double *h = xmalloc((size_t)n * sizeof(double)), *x = xmalloc((size_t)n * sizeof(double));
	double *rs = xmalloc(SWELL_WAVE_REF_DOUBLES(nx, nx) * sizeof(double));
	double v0, e0, w_sei;
	long k;

	init_or_die(&f, impl, nx, e, t, st);
	bench_mode_init(&md, nx, nx, MODE_M, MODE_N);
	bench_mode_field(&md, AMP_MM, h);
	bench_field_set_mm(&f, h);
	bench_field_get_mm(&f, h);
	bench_field_ref(&f, h, &r, rs);
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

/* ---- error against steps ------------------------------------------------------------------ */

void run_error_steps(const struct opts *o)
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
