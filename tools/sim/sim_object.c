/* swell-sim --object: a floating box on the pool, scripted or free, traced to CSV. See sim_object.h.
 * The options are parsed with doubles and converted once into the integer units of swell/body.h;
 * the force law, coupling and safety stage run in integers as on the controller. */
#define _POSIX_C_SOURCE 200809L
#include "sim_object.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/body.h"
#include "swell/body_free.h"
#include "swell/force_safety.h"
#include "swell/pool.h"

enum motion {
	M_DROP,
	M_HOLD,
	M_VOSC,
	M_HOSC
};

static struct {
	int on;
	double box[4]; /* a, b, H (m), mass (kg) */
	enum motion motion;
	double arg[3];
	int have_at;
	double at[2]; /* m */
	double tick_hz;
	double damper; /* N s/m */
	double f_max, rate, gain;
	const char *trace;
	const char *first; /* the first object option other than --object */
} so = { .motion = M_DROP,
	 .arg = { 0.02, 0, 0 },
	 .tick_hz = SWELL_POOL_TICK_HZ,
	 .damper = 3.0,
	 .f_max = 20,
	 .rate = 2000,
	 .gain = 1 };

void sim_object_usage(FILE *f)
{
	fputs("\nFloating object (paper sections 2.1 and 3; units in the trace header):\n"
	      "  --object A,B,H,MASS_KG   a box A x B (m, along x and y), H high (m), of MASS_KG; runs the force\n"
	      "                        law and coupling at --tick-hz and the solver every dt\n"
	      "  --motion M            drop:HEIGHT_M (default drop:0.02: released with its bottom HEIGHT above\n"
	      "                        the water, floats freely under its own mass) | hold:DEPTH_M |\n"
	      "                        vosc:FREQ_HZ,AMP_M,DEPTH_M (vertical) | hosc:FREQ_HZ,AMP_M,DEPTH_M (along x)\n"
	      "  --at X,Y              centre of the box in m from the pool corner (default the pool centre)\n"
	      "  --tick-hz N           device rate, a multiple of the solver rate (default 2500)\n"
	      "  --damper B            b_max in N s/m at full submersion (default 3)\n"
	      "  --safety FMAX_N,RATE_N_S,GAIN   output limits (default 20,2000,1)\n"
	      "  --trace FILE          CSV, one row a tick: time, pose, submersion, every force term, output,\n"
	      "                        displaced volume, the volume invariant, the floor contact force, the\n"
	      "                        surface velocity before and after its low-pass, and the floor penetration\n",
	      f);
}

/* n numbers, any finite ones */
static int list(struct swell_cli *c, const char *opt, const char *v, double *out, int n)
{
	return swell_cli_numbers(c, opt, v, n, n, -HUGE_VAL, HUGE_VAL, "", out) < 0 ? -1 : 0;
}

int sim_object_option(struct swell_cli *c, const char *a, const char *v)
{
	const char *colon = strchr(v, ':');
	const size_t n = colon ? (size_t)(colon - v) : strlen(v); /* --motion's name */
	double x[3];

	if (!so.first && strcmp(a, "--object"))
		so.first = a;
	if (!strcmp(a, "--object")) {
		if (list(c, a, v, so.box, 4) < 0)
			return -1;
		so.on = 1;
	} else if (!strcmp(a, "--motion")) {
		static const char *const names[] = { "drop", "hold", "vosc", "hosc" }; /* enum motion */
		int m = 0;

		while (m < 4 && (n != 4 || strncmp(v, names[m], 4)))
			m++;
		if (m == 4 || !colon)
			return swell_cli_refuse(c, "%s %s: is not drop:H, hold:D, vosc:F,A,D or hosc:F,A,D", a, v);
		x[1] = x[2] = 0;
		if (list(c, a, colon + 1, x, m >= M_VOSC ? 3 : 1) < 0)
			return -1;
		if (m >= M_VOSC && !(x[0] > 0 && x[0] <= 100))
			return swell_cli_refuse(c, "%s %s: frequency must be in (0, 100] Hz", a, v);
		if (!(fabs(x[1]) < 1 && fabs(x[2]) < 1 && fabs(x[0]) < 1000))
			return swell_cli_refuse(c, "%s %s: amplitudes and depths must be below 1 m", a, v);
		so.motion = (enum motion)m;
		memcpy(so.arg, x, sizeof(x));
	} else if (!strcmp(a, "--at")) {
		if (list(c, a, v, so.at, 2) < 0)
			return -1;
		so.have_at = 1;
	} else if (!strcmp(a, "--tick-hz")) {
		return list(c, a, v, &so.tick_hz, 1);
	} else if (!strcmp(a, "--damper")) {
		return swell_cli_number(c, a, v, 0, 10000, "N s/m", &so.damper);
	} else if (!strcmp(a, "--safety")) {
		if (list(c, a, v, x, 3) < 0)
			return -1;
		so.f_max = x[0];
		so.rate = x[1];
		so.gain = x[2];
	} else {
		so.trace = v; /* --trace */
	}
	return 0;
}

int sim_object_active(void)
{
	return so.on;
}

const char *sim_object_orphan(void)
{
	return so.on ? NULL : so.first;
}

static uint32_t to_u32(const char *what, double x, double scale)
{
	double y = x * scale;

	if (!(y >= 0 && y < 4294967295.0)) {
		fprintf(stderr, "swell-sim: %s %g is out of range\n", what, x);
		exit(2);
	}
	return (uint32_t)llround(y);
}

/* The scripted pose (pool um, um/s) at time t; the free body for a drop. */
static void script(double t, double x0, double y0, double z_free, double v_free, int32_t pos[3], int32_t vel[3])
{
	const double w = 2 * 3.14159265358979323846 * so.arg[0];
	double x = x0, z = 0, vx = 0, vz = 0;

	switch (so.motion) {
	case M_DROP:
		z = z_free;
		vz = v_free;
		break;
	case M_HOLD:
		z = -so.arg[0] * 1e6;
		break;
	case M_VOSC:
		z = -so.arg[2] * 1e6 + so.arg[1] * 1e6 * sin(w * t);
		vz = so.arg[1] * 1e6 * w * cos(w * t);
		break;
	case M_HOSC:
		z = -so.arg[2] * 1e6;
		x = x0 + so.arg[1] * 1e6 * sin(w * t);
		vx = so.arg[1] * 1e6 * w * cos(w * t);
		break;
	}
	pos[0] = (int32_t)lround(x);
	pos[1] = (int32_t)lround(y0);
	pos[2] = (int32_t)lround(z);
	vel[0] = (int32_t)lround(vx);
	vel[1] = 0;
	vel[2] = (int32_t)lround(vz);
}

static double now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec * 1e9 + ts.tv_nsec;
}

int sim_object_run(struct swell_wave *w, double dt_s, double dx_m, long steps, int float64)
{
	struct swell_body_params p = { 0 };
	struct swell_body_xform xf = { { 0, 0, 0 }, SWELL_Q16_ONE, { 0, 1, 2 }, { 1, 1, 1 } };
	struct swell_body_scene sc;
	struct swell_fsafety_params sp;
	struct swell_fsafety safe;
	struct swell_body b;
	struct swell_free_body fb;
	enum swell_err err;
	FILE *tr = NULL;
	double x0, y0, delta_eq, sum_delta = 0, settle = 0, fmax = 0, mm = SWELL_H_ONE_MM;
	int64_t inv0, drift = 0;
	long ticks, t, kk, tail;
	int32_t out_uN = 0;
	double law_ns = 0, t0;
	long law_ticks = 0;

	if (float64) {
		fprintf(stderr, "swell-sim: --object runs on the fixed-point solver only (not --impl float64)\n");
		return 2;
	}
	dt_s = dt_s > 0 ? dt_s : 0.004;
	dx_m = dx_m > 0 ? dx_m : SWELL_POOL_DX_UM / 1e6;
	sc.dx_um = to_u32("--dx", dx_m, 1e6);
	sc.solver_hz = to_u32("solver rate 1/dt", 1 / dt_s, 1);
	sc.tick_hz = to_u32("--tick-hz", so.tick_hz, 1);
	if (fabs(sc.solver_hz * dt_s - 1) > 1e-9) {
		fprintf(stderr, "swell-sim: --object needs a whole solver rate: 1/dt = %g Hz\n", 1 / dt_s);
		return 2;
	}
	p.a_um = to_u32("--object A", so.box[0], 1e6);
	p.b_um = to_u32("--object B", so.box[1], 1e6);
	p.h_um = to_u32("--object H", so.box[2], 1e6);
	p.mass_g = to_u32("--object MASS_KG", so.box[3], 1e3);
	p.rho_kg_m3 = 1000;
	p.g_mm_s2 = 9810;
	p.damper_uN_per_mm_s = to_u32("--damper", so.damper, 1e3);
	err = swell_body_check(&p, &xf, &sc);
	if (err != SWELL_OK) {
		fprintf(stderr,
			"swell-sim: --object %g,%g,%g,%g at %u Hz (solver %u Hz, cells %u um) refused: %s "
			"(sides 1 mm .. %d cells, H 1 .. 500 mm, mass 1 g .. 100 kg, tick rate a multiple "
			"of the solver rate, at most %u ticks a step)\n",
			so.box[0], so.box[1], so.box[2], so.box[3], sc.tick_hz, sc.solver_hz, sc.dx_um,
			swell_err_str(err), SWELL_BODY_MAX_CELLS, SWELL_BODY_MAX_K);
		return 2;
	}
	sp.gain = (q16_t)llround(so.gain * SWELL_Q16_ONE);
	sp.f_max_uN = to_u32("--safety FMAX_N", so.f_max, 1e6);
	sp.rate_uN_per_s = to_u32("--safety RATE_N_S", so.rate, 1e6);
	sp.tick_hz = sc.tick_hz;
	if (!(so.gain >= 0 && so.gain <= 4) || swell_fsafety_init(&safe, &sp) != SWELL_OK) {
		fprintf(stderr,
			"swell-sim: --safety %g,%g,%g refused: F_max in (0, 1000] N, rate at least "
			"1 uN a tick, gain in [0, 4]\n",
			so.f_max, so.rate, so.gain);
		return 2;
	}
	swell_body_init(&b, &p, &xf, &sc, w);
	x0 = so.have_at ? so.at[0] * 1e6 : w->nx * (double)sc.dx_um / 2;
	y0 = so.have_at ? so.at[1] * 1e6 : w->ny * (double)sc.dx_um / 2;
	swell_free_body_init(&fb, so.motion == M_DROP ? so.arg[0] * 1e6 : 0, p.mass_g, sc.tick_hz);
	if (so.trace) {
		tr = fopen(so.trace, "w");
		if (!tr) {
			fprintf(stderr, "swell-sim: --trace %s: %s\n", so.trace, strerror(errno));
			return 2;
		}
		fprintf(tr,
			"t_s,x_mm,y_mm,z_mm,vz_mm_s,surface_mm,delta_mm,f_gravity_N,f_pull_N,f_push_N,"
			"f_up_N,f_viscous_N,f_total_N,f_out_N,v_displaced_mm_cells,invariant_lsb_cells,f_floor_N,"
			"surface_raw_mm_s,surface_mm_s,penetration_mm\n");
	}

	kk = sc.tick_hz / sc.solver_hz;
	ticks = steps * kk;
	tail = ticks < sc.tick_hz ? ticks : sc.tick_hz; /* equilibrium: mean over the last second */
	delta_eq = (double)p.mass_g * p.g_mm_s2 * (1 << 24) / b.k_q8;
	inv0 = swell_body_invariant(&b, w);
	for (t = 0; t < ticks; t++) {
		struct swell_body_out o;
		int32_t pos[3], vel[3];
		int64_t inv;

		if (t > 0 && t % kk == 0) {
			swell_wave_step(w);
			swell_body_solver_stepped(&b, w);
		}
		script((double)t / sc.tick_hz, x0, y0, fb.z_um, fb.v_um_s, pos, vel);
		t0 = now_ns();
		swell_body_tick(&b, w, pos, vel, &o);
		out_uN = swell_fsafety_apply(&safe, o.f.total_uN, 1);
		if (!o.skipped) {
			law_ns += now_ns() - t0;
			law_ticks++;
		}
		if (so.motion == M_DROP)
			swell_free_body_step(&fb, out_uN);
		fmax = fabs(out_uN * 1e-6) > fmax ? fabs(out_uN * 1e-6) : fmax;
		if (fabs(o.delta_lsb - delta_eq) > 0.02 * delta_eq)
			settle = (double)(t + 1) / sc.tick_hz;
		if (t >= ticks - tail)
			sum_delta += o.delta_lsb;
		inv = tr || t == ticks - 1 || t % 256 == 0 ? swell_body_invariant(&b, w) : inv0;
		drift = llabs(inv - inv0) > llabs(drift) ? inv - inv0 : drift;
		if (tr)
			fprintf(tr,
				"%.6f,%.4f,%.4f,%.4f,%.3f,%.5f,%.5f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.5f,%lld,"
				"%.6f,%.3f,%.3f,%.5f\n",
				(double)t / sc.tick_hz, o.x_um * 1e-3, o.y_um * 1e-3, o.z_um * 1e-3, o.vz_um_s * 1e-3,
				o.surface_lsb / mm, o.delta_lsb / mm, o.f.gravity_uN * 1e-6, o.f.pull_uN * 1e-6,
				o.f.push_uN * 1e-6, o.f.up_uN * 1e-6, o.f.viscous_uN * 1e-6, o.f.total_uN * 1e-6,
				out_uN * 1e-6, b.v_displaced / mm, (long long)inv, o.f.floor_uN * 1e-6,
				o.surface_raw_um_s * 1e-3, o.surface_um_s * 1e-3, o.penetration_lsb / mm);
	}
	if (tr && fclose(tr) != 0) {
		fprintf(stderr, "swell-sim: --trace %s: %s\n", so.trace, strerror(errno));
		return 2;
	}

	printf("swell-sim: object %.1f x %.1f x %.1f mm, %.1f g, at (%.1f, %.1f) mm; %dx%d cells of %.2f mm\n",
	       p.a_um * 1e-3, p.b_um * 1e-3, p.h_um * 1e-3, (double)p.mass_g, x0 * 1e-3, y0 * 1e-3, w->nx, w->ny,
	       sc.dx_um * 1e-3);
	printf("rates           device %u Hz, solver %u Hz (%ld ticks a step), %ld ticks = %.3f s\n", sc.tick_hz,
	       sc.solver_hz, kk, ticks, (double)ticks / sc.tick_hz);
	/* k_q8 / 256 is in uN/mm = 1e-3 N/m */
	printf("stiffness       k = rho g a b = %.4f N/m, k H = %.4f N, m g = %.4f N\n", b.k_q8 / 256.0 * 1e-3,
	       b.k_q8 / 256.0 * p.h_um * 1e-9, p.mass_g * p.g_mm_s2 * 1e-6);
	if (so.motion == M_DROP && tail > 0) {
		double d = sum_delta / tail;
		printf("equilibrium     delta %.4f mm (mean of the last %.3f s), m g / k %.4f mm, error %+.4f %%\n",
		       d / mm, (double)tail / sc.tick_hz, delta_eq / mm, 100 * (d - delta_eq) / delta_eq);
		if (settle >= (double)ticks / sc.tick_hz) /* outside at the last tick: it never settled */
			printf("settling        none: still outside 2 %% of m g / k at the end (%.3f s)\n", settle);
		else
			printf("settling        %.3f s to stay within 2 %% of m g / k\n", settle);
	}
	printf("largest output  %.4f N (F_max %.3f N)\n", fmax, sp.f_max_uN * 1e-6);
	printf("displaced       %.3f mm*cells at the end\n", b.v_displaced / mm);
	printf("invariant drift %+lld LSB*cell (sum(h) + pending - V_displaced; 1 LSB = 2^-16 mm)\n", (long long)drift);
	printf("work            %u of %u ticks skipped clear of the water, %u couplings\n", b.skipped, b.ticks,
	       b.coupled);
	if (law_ticks)
		printf("cost            %.0f ns per tick in the water (force law, coupling, safety; host)\n",
		       law_ns / law_ticks);
	if (w->saturations)
		printf("saturations     %u\n", w->saturations);
	return 0;
}
