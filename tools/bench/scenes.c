/* swell-bench: what a scene does not need is skipped (the image's cost scenes on every kernel). */
#include "bench.h"

/* The image's three cost scenes (firmware/stm32f405/logic/scene.c: calm, one local splash, a fully
 * agitated pool; 64x64, damped t = 0.001, FW_COST_STEPS steps from their start) on every kernel this
 * host has, against a float32 loop of the same stencil over the whole grid, timed in the same run; and
 * the image's instruction counts under QEMU when --f405 gives its self-test output. Every kernel
 * must end on the reference kernel's checksum. */
void run_scenes(const struct opts *o)
{
	static int32_t storage[FW_SCENE_WORDS], ef_storage[EF32_WORDS(FW_SCENE_NX, FW_SCENE_NY)];
	const enum swell_wave_kernel kernels[] = { SWELL_KERNEL_REF, SWELL_KERNEL_FUSED, SWELL_KERNEL_AVX2,
						   SWELL_KERNEL_REF, SWELL_KERNEL_FUSED, SWELL_KERNEL_AVX2 };
	const int nedge = 3; /* the first three ef32's, the last three the solver's */
	const long cells = (long)FW_COST_STEPS * FW_SCENE_NX * FW_SCENE_NY;
	struct swell_wave w;
	struct ef32 ef;
	struct bench_field f;
	struct bench_mode md;
	double ns_f32 = INFINITY, e, *h;
	FILE *fp = open_out(o, "scenes.csv");
	int s, k, rep;

	if (fw_cost_scene_init(&w, storage, FW_SCENE_WORDS, FW_COST_CALM) != SWELL_OK) {
		check(0, "scenes: the cost scene is refused");
		return;
	}
	e = (double)w.p.e / SWELL_Q30_ONE;
	h = xmalloc((size_t)FW_SCENE_NX * FW_SCENE_NY * sizeof(double));
	bench_mode_init(&md, FW_SCENE_NX, FW_SCENE_NY, MODE_M, MODE_N);
	bench_mode_field(&md, AMP_MM, h);
	init_or_die(&f, BENCH_F32, FW_SCENE_NX, e, 0.001, SWELL_STENCIL_PAPER);
	bench_field_set_mm(&f, h);
	bench_field_steps(&f, FW_COST_STEPS); /* warm-up */

	printf("\n== skipping what a scene does not need: 64x64, damped t = 0.001, %u steps from the scene's "
	       "start (ns per cell-step over the whole grid; x f32 = against a float32 loop over every cell, "
	       "same run) ==\n",
	       FW_COST_STEPS);
	fprintf(fp,
		"scene,kernel,ns_per_cell_step,ratio_f32,awake_pct,ns_per_awake_cell_step,"
		"f405_instr_per_cell_step,f405_instr_per_awake_cell_step\n");
	for (s = 0; s < FW_COST_SCENES; s++) {
		uint32_t ref_sum = 0;

		for (k = 0; k < (int)(sizeof(kernels) / sizeof(kernels[0])); k++) {
			const int vel = k >= nedge;
			const double f405 = vel ? f405_cost[s] : 0, f405_aw = vel ? f405_cost_awake[s] : 0;
			double best = INFINITY, awake = 0;
			uint32_t sum = 0;
			char kname[32];

			snprintf(kname, sizeof(kname), "%s%s", vel ? "vel-" : "", swell_wave_kernel_name(kernels[k]));
			progress("scenes: %s, %s kernel", fw_cost_scene_name[s], kname);
			for (rep = 0; rep < o->reps; rep++) {
				double t0;
				long n;

				/* float32 in turn with the kernels, so that both see the same machine load */
				t0 = now_s();
				bench_field_steps(&f, FW_COST_STEPS);
				ns_f32 = fmin(ns_f32, (now_s() - t0) * 1e9 / (double)cells);

				/* ef32 from the scene's heights (the solver's field, not stepped) */
				fw_cost_scene_init(&w, storage, FW_SCENE_WORDS, (enum fw_cost_scene)s);
				if (!vel) {
					ef32_init(&ef, FW_SCENE_NX, FW_SCENE_NY, ef_storage,
						  EF32_WORDS(FW_SCENE_NX, FW_SCENE_NY), &w.p);
					for (n = 0; n < FW_SCENE_NY; n++)
						swell_wave_row(&w, (int)n, ef.h + n * FW_SCENE_NX);
				}
				if ((vel ? swell_wave_set_kernel(&w, kernels[k]) : ef32_set_kernel(&ef, kernels[k])) !=
				    SWELL_OK)
					break; /* AVX2 on a CPU without it */
				t0 = now_s();
				for (n = 0; n < (long)FW_COST_STEPS; n++)
					vel ? swell_wave_step(&w) : ef32_step(&ef);
				best = fmin(best, (now_s() - t0) * 1e9 / (double)cells);
				awake = 100.0 *
					(1.0 -
					 (double)(vel ? w.tiles_skipped : ef.tiles_skipped) /
						 ((double)FW_COST_STEPS * FW_SCENE_NY * w.tiles_x));
				sum = vel ? swell_wave_checksum(&w) : ef32_checksum(&ef);
			}
			if (isinf(best)) {
				printf("  %-9s %-9s not available on this CPU\n", fw_cost_scene_name[s], kname);
				continue;
			}
			if (kernels[k] == SWELL_KERNEL_REF)
				ref_sum = sum; /* each form's kernels against that form's reference */
			check(sum == ref_sum, "scene %s: kernel %s ends on checksum 0x%08x, the reference on 0x%08x",
			      fw_cost_scene_name[s], kname, sum, ref_sum);
			printf("  %-9s %-9s %6.2f ns/cell-step = %5.2f x f32 (%.2f ns), awake %5.1f %%, %6.2f ns per "
			       "awake cell-step",
			       fw_cost_scene_name[s], kname, best, best / ns_f32, ns_f32, awake,
			       awake > 0 ? best * 100.0 / awake : 0.0);
			if (kernels[k] == SWELL_KERNEL_FUSED && f405 > 0)
				printf("; F405 (M4 kernel) %.2f instructions per cell-step, %.2f per awake cell-step",
				       f405, f405_aw);
			printf("\n");
			fprintf(fp, "%s,%s,%.4f,%.4f,%.2f,%.4f,%.2f,%.2f\n", fw_cost_scene_name[s], kname, best,
				best / ns_f32, awake, awake > 0 ? best * 100.0 / awake : 0.0,
				kernels[k] == SWELL_KERNEL_FUSED ? f405 : 0.0,
				kernels[k] == SWELL_KERNEL_FUSED ? f405_aw : 0.0);
		}
	}
	if (f405_cost[FW_COST_AGITATED] > 0)
		printf("  F405 agitated pool: the solver %.2f instructions per cell-step (target 20; naive int32 loop "
		       "%.2f)\n",
		       f405_cost[FW_COST_AGITATED], f405_naive);
	bench_field_free(&f);
	free(h);
	fclose(fp);
}
