/* swell-bench loop: the coupled hand-device-controller-water loop in one process, deterministic, no
 * sockets. The controller core (swell_ctl_*, the same code as the image) against the HapticMaster
 * model (hm_model.h) in lockstep: every device tick the device reports DEVICE_VEL and DEVICE_POS, the
 * controller ticks once, and what it sends to the device (FORCE_CMD, or the effect set in effect
 * mode) reaches the device `delay` ticks later (the command path only; the samples are never
 * delayed). The device renders effect sets itself at its rate, at its own position and velocity.
 *
 * A point: the force mode, the device rate, the buoyancy stiffness as a multiple of rho g a b of
 * the reference 50 mm cube (the object's footprint a = b = 50 mm x sqrt(multiple), its mass such
 * that it floats half submerged), the force law's damper b_max, the device's virtual mass and
 * damping, the delay, and the passivity controller (force.passivity) on or off. A stiff hand holds
 * the device LOOP_SWING_MM below the object's floating depth for LOOP_HOLD_S and lets go; the free
 * response is then classified (loop_classify).
 *
 * Host code, doubles; the controller itself stays integer. */
#ifndef SWELL_BENCH_LOOP_H
#define SWELL_BENCH_LOOP_H

#include <stdint.h>
#include <stdio.h>

#define LOOP_POOL_N 128 /* cells a side, 6.25 mm: 800 mm, so the largest object (400 mm) is 1/4 of it */
#define LOOP_START_MM 5.0 /* the object's bottom starts this far above the water */
#define LOOP_RAMP_S 1.0 /* the hand lowers it to the swing's start in this time */
#define LOOP_HOLD_S 2.0 /* the hand lets go this long after the start */
#define LOOP_SWING_MM 5.0 /* held this far below the floating depth */
#define LOOP_BOUND_MM 30.0 /* a swing beyond this from the floating depth is divergent */
#define LOOP_FLOOR_MM 0.05 /* a peak-to-peak swing below this is at rest */
#define LOOP_SIGMA_TOL 0.03 /* 1/s: the envelope's growth rate taken as sustained */
#define LOOP_F_MAX_N 100.0 /* force.max of the runs (the weight of the stiffest object is 39 N) */
#define LOOP_HAND_K 20000.0 /* the holding hand, N/m and N s/m */
#define LOOP_HAND_B 150.0

enum loop_class {
	LOOP_STABLE = 0,
	LOOP_LIMIT_CYCLE = 1,
	LOOP_DIVERGENT = 2,
	LOOP_REFUSED = 3, /* the controller or the device model refused the point's configuration */
	LOOP_BEYOND_EFFECT = 4 /* effect mode: k beyond what EFFECT_SPRING carries (655.35 N/m) */
};

struct loop_point {
	int mode; /* 0 stream, 1 effect (force.mode) */
	double rate_hz; /* device and controller tick */
	double k_mult; /* stiffness multiple of rho g a b of the 50 mm cube (24.525 N/m) */
	double damper_Ns_m; /* body.damper, b_max at full submersion */
	double mass_kg, damping_Ns_m; /* the device's virtual mass and damping */
	int delay; /* ticks on the controller -> device path */
	int passivity; /* force.passivity */
	double pc_damping_Ns_m; /* force.pc_damping; 0: the controller's default */
	int pc_delay_given, pc_delay; /* force.pc_delay in ticks when pc_delay_given, else the link's delay */
	int water_energy; /* the controller keeps the water's energy in its account (a pass over the field
			   * each solver step: most of a point's run time) */
	double seconds; /* of free response after the release */
	FILE *trace; /* NULL, or a line a tick: t s, z mm, v mm/s, applied force N, hand force N, state */
};

struct loop_result {
	enum loop_class cls;
	double k_N_m; /* rho g a b of the object run */
	double a_mm; /* its side (a = b) */
	double mass_g; /* its mass */
	double r_area; /* a b over the pool's area */
	double z_eq_mm; /* the floating depth (device z, static, with the pool's level rise) */
	double z_release_mm; /* where the hand let go */
	double p2p_first_mm, p2p_last_mm; /* peak-to-peak swing in the first and the last window */
	double sigma_per_s; /* the swing envelope's growth rate over the last half */
	double peak_dev_mm; /* the largest |z - z_eq| after the release */
	double peak_force_N; /* the largest |force applied by the device's command| after the release */
	int force_limited; /* the controller's or the device's force limit cut in after the release */
	double e_port_J; /* work of the applied force on the device after the release */
	double e_created_J; /* e_port less what the static force law gives back, at the end: > 0 made */
	double e_created_max_J; /* the most that running figure reached (0 when never above 0) */
	int have_ctl_energy; /* the controller's own figure is there */
	double ctl_created_J; /* its energy created after the release: the most its D fell below D there */
	double ctl_damped_J; /* what its passivity controller took out over the whole run */
	int ctl_passivity; /* 1: the controller accepted force.passivity 1 */
	char why[160]; /* REFUSED: the reason */
};

/* The stiffness of multiple 1 (N/m) and the footprint side (mm) of a multiple. */
double loop_k_ref(void);
double loop_side_mm(double k_mult);

/* Runs one point; deterministic (the same point gives the same result, bit for bit). */
void loop_run(const struct loop_point *p, struct loop_result *r);

const char *loop_class_name(enum loop_class c);

/* Theory: the bench's loop without water, linearised about the floating depth. The device's
 * semi-implicit Euler at T = 1/rate, m (v[n+1] - v[n]) = T (F[n] - b v[n]), x[n+1] = x[n] + T v[n+1],
 * with F[n] = -k x[n-d] - B v[n-d] (the force law computed from the sample d ticks earlier): the
 * characteristic polynomial
 *     P(z) = m z^d (z - 1 + bT/m)(z - 1) + k T^2 z + B T (z - 1).
 * 1 when its d + 2 roots are inside the unit circle (the Schur-Cohn recursion). */
int loop_theory_stable(double m, double b, double k, double B, int d, double T);
/* The largest k (N/m) with every root inside, by bisection up to k_hi; k_hi when stable to there. */
double loop_theory_k_crit(double m, double b, double B, int d, double T, double k_hi);
/* The passivity controller's damping B behind d ticks on the device alone (no spring): the velocity's
 * loop m (v[n+1] - v[n]) = T (-b v[n] - B v[n-d]), characteristic polynomial
 *     m z^d (z - 1 + bT/m) + B T,
 * 1 when its d + 1 roots are inside the unit circle; the largest stable B (N s/m) by bisection up to
 * b_hi. For d >= 1 close to pi m / (2 (d + 1/2) T): the continuous delayed damper's limit. */
int loop_theory_damper_stable(double m, double b, double B, int d, double T);
double loop_theory_b_crit(double m, double b, int d, double T, double b_hi);
/* Schur-Cohn: 1 when every root of c[0] + c[1] z + ... + c[n] z^n (c[n] != 0, n <= 16) has |z| < 1. */
int loop_schur_stable(const double *c, int n);

#endif
