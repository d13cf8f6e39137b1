/* Scripted users' hands for the HapticMaster model. While it holds the handle, a hand is a
 * spring-damper (k, b) pulling the device towards a target trajectory on all three axes:
 *     F_user = k (target - x) + b (target_v - v);
 * released, it exerts no force. Scripts (times in s, lengths in mm, from the start of the run):
 *
 *   idle                     never touches the handle.
 *   drop:z=20,hold=1         holds the object at height z (its bottom, mm above the rest water
 *                            level) for hold seconds, then lets go: it falls and floats.
 *   release:at=0.5           holds the handle where it starts (see --start) and lets go at `at`.
 *   press:at=3,depth=45,ramp=0.5,hold=2
 *                            free until `at`; then grabs the handle where it is and pushes its
 *                            target down to z = -depth in `ramp` seconds, holds it there for
 *                            `hold` seconds and lets go.
 *   shake:at=3,axis=z,f=1,amp=10,for=3
 *                            free until `at`; then grabs the handle where it is and moves it
 *                            sinusoidally along `axis` (x, y or z) at f Hz and amp mm for `for`
 *                            seconds (0: until the end), then lets go.
 * Every script also takes k= (N/m, default 2000) and b= (N s/m, default 60). */
#ifndef SWELL_HM_HAND_H
#define SWELL_HM_HAND_H

#include <stddef.h>

#include "swell/err.h"

enum hm_hand_kind {
	HM_HAND_IDLE,
	HM_HAND_DROP,
	HM_HAND_RELEASE,
	HM_HAND_PRESS,
	HM_HAND_SHAKE
};

struct hm_hand {
	enum hm_hand_kind kind;
	double k_N_m, b_Ns_m;
	double z_m; /* drop: height held */
	double at_s; /* release, press, shake: when the hand acts */
	double hold_s; /* drop, press: how long it holds */
	double depth_m; /* press: target depth below the rest level */
	double ramp_s; /* press: time to reach it */
	double f_hz, amp_m; /* shake */
	int axis; /* shake: 0 x, 1 y, 2 z */
	double for_s; /* shake: duration, 0 = until the end */

	/* run state */
	int grabbed; /* the hand has taken the handle (its grab position is set) */
	double grab_m[3]; /* where it took the handle */
};

/* Parses "NAME[:key=value,...]". SWELL_EUNKNOWN for an unknown hand or key, SWELL_ERANGE for a value
 * outside its range or not a number; why (may be NULL) gets a one-line reason. On error *h is
 * untouched. */
enum swell_err hm_hand_parse(const char *spec, struct hm_hand *h, char *why, size_t why_len);

/* The name of the script. */
const char *hm_hand_name(enum hm_hand_kind kind);

/* Where the device starts for this hand when no --start is given (m): drop starts where it holds. */
void hm_hand_start(const struct hm_hand *h, double x0_m[3]);

/* The hand force at time t for the device at x with velocity v (SI); returns 1 while holding. */
int hm_hand_force(struct hm_hand *h, double t_s, const double x_m[3], const double v_m_s[3], double f_N[3]);

#endif
