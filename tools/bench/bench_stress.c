/* swell-bench: the stress runs, at the edge of stability, near saturation and under random pushes
 * (stress.csv). */
#include "bench.h"

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
	/* the largest e_eff swell_wave_check accepts: one even step below the exclusive limit */
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
	/* ef32 saturates to the int28 range: down to -(h_max + 1) */
	check(m_all <= f.h_max + (impl == BENCH_EF32 || impl == BENCH_VELOCITY),
	      "%s %s: |h| %.0f LSB beyond the saturation bound", scenario, bench_impl_name(impl), m_all);
	if (impl == BENCH_EF32 && noise_frac < 0.01) {
		check(f.saturations == 0 && ratio < 1.5, "ef32 at the stability edge t=%.2f grew %.2fx", t, ratio);
		check(bench_field_volume_lsb(&f) == v0, "ef32 at the edge: volume drift %+.0f LSB",
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
	const int n = 64 * 64;
	double v0, resid_v = 0, resid_h = 0, mean, *h = xmalloc((size_t)n * sizeof(double));
	long k;
	int i;

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
	mean = bench_field_volume_lsb(&f) / n;
	bench_field_get_mm(&f, h);
	for (i = 0; i < n; i++)
		resid_h = fmax(resid_h, fabs(h[i] / f.lsb_mm - mean));
	free(h);
	printf("forcing %-10s 64x64 e=0.2 t=0.02: %ld steps of pushes (6x6, +-0.3 mm) then %ld free: vol "
	       "drift %+.0f LSB, residual max|dh/step| %.0f LSB (%.2e mm), residual max|h-mean| %.0f LSB "
	       "(%.2e mm)\n",
	       bench_impl_name(impl), push_steps, decay_steps, bench_field_volume_lsb(&f) - v0, resid_v,
	       resid_v * f.lsb_mm, resid_h, resid_h * f.lsb_mm);
	fprintf(stress_fp, "forcing,%s,0.02,%.9f,%.3e,,,%.0f,%u,%.0f,%.0f\n", bench_impl_name(impl), f.e_eff,
		(double)(push_steps + decay_steps) * n, bench_field_volume_lsb(&f) - v0, f.saturations, resid_v,
		resid_h);
	if (impl == BENCH_EF32 || impl == BENCH_VELOCITY) {
		check(bench_field_volume_lsb(&f) == v0, "%s under random pushes: volume drift %+.0f LSB",
		      bench_impl_name(impl), bench_field_volume_lsb(&f) - v0);
		check(resid_v == 0, "%s: motion of %.0f LSB/step left after damping (limit cycle)",
		      bench_impl_name(impl), resid_v);
	}
	bench_field_free(&f);
}

void run_stress(const struct opts *o)
{
	const enum bench_impl forced[] = { BENCH_EF32,    BENCH_VELOCITY, BENCH_EF16,    BENCH_TL32_FLOOR,
					   BENCH_TL32_RN, BENCH_TL32_RZ,  BENCH_TL16_RN, BENCH_F32 };
	size_t k;

	stress_fp = open_out(o, "stress.csv");
	fprintf(stress_fp,
		"scenario,impl,t,e_eff,cell_steps,max_gain,energy_drift_max,volume_drift_lsb,"
		"saturations,residual_step_lsb,residual_height_lsb\n");
	printf("\n== stress ==\n");
	/* 1 mm of noise (64 LSB of the int16 kernels' 2^-10 mm: 1/32 of their bound) */
	stress_edge(o, "edge", BENCH_EF32, 0.0, 0, 1.0 / 2048);
	stress_edge(o, "edge", BENCH_EF32, 0.5, 0, 1.0 / 2048);
	stress_edge(o, "edge", BENCH_TL32_RN, 0.0, 0, 1.0 / 2048);
	stress_edge(o, "edge", BENCH_EF16, 0.0, 0, 1.0 / 32);
	for (k = 0; k < sizeof(forced) / sizeof(forced[0]); k++)
		stress_forcing(forced[k], 2000, 4000);
	/* near saturation: the (1,1) mode alone at 97 % of the bound (must not saturate), then at 90 %
	 * with 10 % noise at the edge of stability (saturates: look for wrap, growth, volume) */
	stress_edge(o, "near-bound", BENCH_EF32, 0.0, 0.97, 0);
	stress_edge(o, "near-bound", BENCH_TL32_RN, 0.0, 0.97, 0);
	stress_edge(o, "saturation", BENCH_EF32, 0.0, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_EF32, 0.5, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_TL32_RN, 0.0, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_VELOCITY, 0.0, 0.9, 0.1);
	stress_edge(o, "saturation", BENCH_EF16, 0.0, 0.9, 0.1);
	fclose(stress_fp);
}
