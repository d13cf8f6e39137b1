/* The floating object of the paper (sections 2.1 and 3): a box held by the haptic device, the forces
 * it feels from the water, and the volume it pushes into the water. C11, integers only, no allocation.
 *
 * Units (all integers, named in every field):
 *   position      um (micrometre), pool coordinates: x along cell columns i, y along rows j, origin at
 *                 the corner of cell (0,0); z up, 0 = rest water level. The pose is the centre of the
 *                 object's bottom face.
 *   height        LSB of the solver, 2^-16 mm (SWELL_H_FRAC); w, z and delta are kept in it inside.
 *   velocity      um/s
 *   force         uN (micronewton); springs are summed in a finer unit, uN * 2^-24, so that the two
 *                 springs cancel exactly (see swell_body_springs).
 *   stiffness     k in uN/mm as Q24.8 (k_q8)
 *   damping       uN per mm/s (= mN s/m)
 *   mass          g;  gravity mm/s^2;  density kg/m^3
 *   volume        LSB * cell: one cell area times 2^-16 mm, the unit of swell_wave_volume()
 *   time          ticks of the device rate; the solver steps every K = tick_hz / solver_hz ticks
 *   footprint     edges in Q11 cell units (2048 = one cell side) for area weights
 *
 * Forces (vertical, every tick):
 *   gravity   F_g = -m g
 *   upward    two springs, equal stiffness k = rho g a b and equal deadband: the pulling one with its
 *             origin at the water surface w, active from first contact, the pushing one with its
 *             origin at w - H, active from full submersion. Net: k clamp(w - z - deadband, 0, H).
 *             Both origins move with the surface (its velocity u_w is what moves them).
 *   viscous   F_v = -b_max s (v - u_w), s = delta / H, delta = clamp(w - z, 0, H); u_w low-passed
 *             (SWELL_BODY_UW_CORNER_HZ) so the grid's short waves do not ripple the force
 *   floor     below the pool floor z = -d: a contact spring-damper (SWELL_BODY_FLOOR_*); the water
 *             sees the bottom at max(z, -d) (submersion, springs, coupling)
 * w is the area-weighted mean surface under the footprint (partly covered cells by covered area),
 * read between the two latest solver states (in rows the solver finished ahead, h(n) = h - acc):
 * h(n-1) + alpha v = h - (1 - alpha) v, alpha = k / K for
 * the k-th tick after a solver step, so the force has no steps at solver updates. u_w interpolates
 * the footprint velocity of the last two solver periods the same way, then goes through the low-pass.
 * d, the rest depth, is the one the solver's e stands for: d = e dx^2 solver_hz^2 / g (eq. 2).
 *
 * Coupling (paper 2.1): every cell c under the footprint holds D_c = round(delta_c * area_c) of the
 * object's volume (area_c its covered fraction); when the pose or delta_c changes, the old D_c are
 * taken out and the new ones put in with swell_wave_add() (the solver adds them to h at its next
 * finish, flows untouched; the surface read then ramps them in over the next period, no step).
 * V_displaced is the sum of what was added, so sum(h) + pending adds - V_displaced is constant
 * exactly in integers (at solver step boundaries: sum(h) - V_displaced), whatever the object does,
 * also across a wall or partly outside the pool (cells outside the pool hold nothing).
 * delta_c = clamp(S - max(z, -d), 0, H) is the depth below the mean level S of the pool (sum(h) /
 * cells, exact: found at each solver step and kept up to date by the coupling itself; at the floor
 * it is the whole water column S + d, and pressing further moves no water), not below the
 * surface under the object: measured there, the object would see the volume it just pushed in and
 * push in more every tick; measured against the water around it, volume would move without the
 * object doing work (docs/force-law.md).
 *
 * Skipped work: when the bottom is above every water height (a ceiling found at solver steps while
 * the object is out of the water) and the object holds no volume in the water, a tick computes
 * nothing but gravity (counted). */
#ifndef SWELL_BODY_H
#define SWELL_BODY_H

#include <stdint.h>

#include "swell/err.h"
#include "swell/fixed.h"
#include "swell/wave.h"

#define SWELL_BODY_FP_ONE 2048 /* Q11 cell units */
#define SWELL_BODY_MAX_CELLS 64 /* footprint side, in cells (bounds the work per tick) */
#define SWELL_BODY_MIN_SIDE_UM 1000u
#define SWELL_BODY_MAX_H_UM 500000u /* 500 mm */
#define SWELL_BODY_MAX_MASS_G 100000u /* 100 kg */
#define SWELL_BODY_MAX_DAMPER 10000000u /* uN per mm/s = 10 kN s/m */
#define SWELL_BODY_MAX_DEADBAND_UM 100000u
#define SWELL_BODY_MAX_K 256u /* ticks per solver step */

/* The surface velocity u_w in the damper is low-passed at the device rate so that the short waves
 * the grid rings with (20-55 Hz) do not reach the force (docs/force-law.md): two equal first-order
 * stages, each the backward Euler form of an RC filter, y += alpha (x - y), alpha = w / (tick_hz + w),
 * w = 2 pi f_c: a critically damped second order, gain 1 / (1 + (f / f_c)^2), exactly 1 at rest.
 * A port may set another corner at build time. */
#ifndef SWELL_BODY_UW_CORNER_HZ
#define SWELL_BODY_UW_CORNER_HZ 4u
#endif

/* The pool floor: z = -d, d the rest depth the solver's e stands for. The box's bottom does not go
 * below it for the water (submersion and coupling use max(z, -d)); below it the box feels a contact
 * spring-damper that pushes and never pulls, F_c = clamp(k_c p + b_c min(p, p_r) / p_r (-v), 0,
 * F_c_max), p = -d - z the penetration. */
#define SWELL_BODY_FLOOR_K 10000000u /* k_c, uN/mm = 10 kN/m */
#define SWELL_BODY_FLOOR_DAMPER 50000u /* b_c, uN per mm/s = 50 N s/m */
#define SWELL_BODY_FLOOR_RAMP_UM 1000u /* p_r: the damper comes in over the first 1 mm */
#define SWELL_BODY_FLOOR_F_MAX_UN 20000000 /* F_c_max, 20 N (2 mm in) */

struct swell_body_params {
	uint32_t a_um, b_um; /* footprint along pool x and y */
	uint32_t h_um; /* box height H */
	uint32_t mass_g;
	uint32_t rho_kg_m3; /* water density, 1000 */
	uint32_t g_mm_s2; /* 9810 */
	uint32_t damper_uN_per_mm_s; /* b_max, at full submersion */
	uint32_t deadband_um; /* of both springs (0 in the paper's net form) */
};

/* Device position -> pool: pool[k] = offset[k] + sign[k] * scale * dev[axis[k]]. The force goes
 * back the same way without scale: dev[axis[k]] = sign[k] * F_pool[k]. */
struct swell_body_xform {
	int32_t offset_um[3];
	q16_t scale; /* pool um per device um, in (0, 16] */
	uint8_t axis[3]; /* a permutation of 0, 1, 2 */
	int8_t sign[3]; /* +1 or -1 */
};

struct swell_body_scene {
	uint32_t dx_um; /* cell side */
	uint32_t tick_hz; /* device (force law) rate */
	uint32_t solver_hz; /* divides tick_hz, at most SWELL_BODY_MAX_K ticks a step */
};

/* A footprint clipped to the pool (Q11 cell units, x0 < x1 and y0 < y1 unless empty) and its delta. */
struct swell_body_fp {
	int32_t x0, x1, y0, y1;
	int32_t delta_lsb; /* 0: holds nothing */
};

struct swell_body {
	struct swell_body_params p;
	struct swell_body_xform xf;
	struct swell_body_scene sc;
	uint16_t nx, ny;
	uint32_t ticks_per_step; /* K */
	uint32_t phase; /* ticks since the last solver step, saturates at K */
	int32_t k_q8; /* uN/mm, Q24.8 */
	int32_t h_lsb, deadband_lsb;
	int32_t gravity_uN;
	int32_t ceiling_lsb; /* >= every h and h - v: no interpolated surface is above it */
	uint8_t ceiling_ok; /* ceiling_lsb is valid for this solver period */
	uint8_t wet; /* the last computed tick touched the water or held volume */
	int64_t water_sum; /* sum(h), LSB * cell: from the last scan, kept by coupling */
	int32_t u_prev, u_last; /* footprint velocity, LSB per solver step: last period, this one */
	int64_t uw1_q16, uw2_q16; /* u_w after the first and second low-pass stage, LSB per step * 2^16 */
	int32_t uw_alpha_q16; /* the low-pass gain per tick, Q16 */
	int32_t floor_lsb; /* the pool floor -d (-2^30: none, when d is beyond the height range) */
	q30_t floor_e; /* the solver's e that floor_lsb was found from */
	uint32_t floor_g; /* and the gravity */
	struct swell_body_fp applied; /* what is in the water now */
	int64_t v_displaced; /* LSB * cell, the sum of what coupling added */
	/* what the field's cells hold of it: applied, or an older coupling while swell_body_couple_later
	 * keeps the cells' writes for swell_body_place; v_unplaced the volume still to write */
	struct swell_body_fp placed;
	int64_t v_unplaced;
	/* the velocity form keeps no h(n) - h(n-1) (swell/wave.h): the object's own part of it, the water
	 * it wrote in this solver period weighted by the footprint it holds after each write (fp_sums'
	 * units), and the last period's as a mean height change under the footprint (LSB) */
	int64_t dep_sv;
	int32_t dep_v;
	/* the scan spread over a solver period (swell_body_scan_ahead): rows [0, scan_row) of step
	 * scan_steps scanned so far, their ceiling and sum; scan_ok 0 once the object was in the water */
	int64_t scan_sum;
	int32_t scan_top;
	uint32_t scan_steps;
	uint16_t scan_row;
	uint8_t scan_ok;
	uint8_t scan_ahead; /* the caller scans ahead: the step's end never scans the whole field */
	/* the coupling the last swell_body_tick_force found, until swell_body_couple applies it */
	struct swell_body_fp pending;
	uint8_t pending_set, pending_wet;
	/* counters */
	uint32_t ticks, skipped, coupled, scans, floor_ticks;
};

struct swell_body_forces {
	int32_t gravity_uN, viscous_uN, pull_uN, push_uN, up_uN, floor_uN, total_uN;
};

struct swell_body_out {
	int32_t x_um, y_um, z_um; /* pose in the pool */
	int32_t vz_um_s; /* object velocity, up */
	int32_t surface_lsb; /* w under the footprint (0 when skipped) */
	int32_t delta_lsb; /* submersion clamp(w - max(z, -d), 0, H) */
	int32_t surface_um_s; /* u_w low-passed: the velocity in the damper and of both spring origins */
	int32_t surface_raw_um_s; /* u_w as read from the solver, before the low-pass */
	int32_t floor_lsb; /* the pool floor -d under the object */
	int32_t penetration_lsb; /* how far the bottom is below the floor (0: above it) */
	int32_t origin_pull_lsb, origin_push_lsb;
	struct swell_body_forces f;
	int32_t f_dev_uN[3]; /* total force on the device axes */
	uint8_t skipped; /* clear of the water: nothing but gravity computed */
};

/* The two springs in the fine unit uN * 2^-24 (k_q8 * LSB). Pull: origin w, force +k (w - z - db)
 * while positive. Push: origin w - H, force -k (w - H - z - db) while that stretch is positive.
 * pull + push == k_q8 * clamp(w - z - db, 0, H) exactly. */
struct swell_springs {
	int64_t pull_fine, push_fine;
	int32_t origin_pull_lsb, origin_push_lsb;
};
void swell_body_springs(int32_t k_q8, int32_t w_lsb, int32_t z_lsb, int32_t h_lsb, int32_t deadband_lsb,
			struct swell_springs *s);

/* k = rho g a b in uN/mm, Q24.8, rounded to nearest. SWELL_ERANGE when it does not fit. */
enum swell_err swell_body_stiffness(const struct swell_body_params *p, int32_t *k_q8);

/* Validate: SWELL_EINVAL (null, axis not a permutation, sign not +-1), SWELL_ERANGE (a value outside
 * the limits above, or k H or m g beyond 2^30 uN, or a footprint wider than SWELL_BODY_MAX_CELLS). */
enum swell_err swell_body_check(const struct swell_body_params *p, const struct swell_body_xform *xf,
				const struct swell_body_scene *sc);

/* Bind to a solver field; the object starts out of the water, holding nothing. On error *b is
 * untouched. */
enum swell_err swell_body_init(struct swell_body *b, const struct swell_body_params *p,
			       const struct swell_body_xform *xf, const struct swell_body_scene *sc,
			       const struct swell_wave *w);

/* Change the object's parameters while it runs (the field and rates stay). Refused with
 * SWELL_ESTATE while it holds volume in the water (take it out first); on error nothing changes. */
enum swell_err swell_body_set_params(struct swell_body *b, const struct swell_body_params *p,
				     const struct swell_body_xform *xf);

/* Call right after every solver step (swell_wave_step or swell_wave_step_finish): restarts the
 * interpolation phase. When the object was out of the water it also scans the field (one pass) for
 * the ceiling and sum(h); in the water it does not (the solver conserves sum(h) and the coupling
 * keeps it), so a tick never pays for both the scan and the force law with coupling. */
void swell_body_solver_stepped(struct swell_body *b, const struct swell_wave *w);

/* The same scan spread over the solver period, for a solver that finishes rows ahead
 * (swell_wave_finish_rows): scans the rows finished since the last call (h(n+1) and h(n) = h - acc),
 * nothing while the object is in the water. Once a caller uses it, swell_body_solver_stepped only
 * scans the rows left and takes the result when the whole period was dry; else the ceiling is not
 * known for the next period (no skipping then; sum(h) stays the one the coupling keeps). Water the
 * object moves in rows already scanned is accounted for (the ceiling stays an upper bound). */
void swell_body_scan_ahead(struct swell_body *b, const struct swell_wave *w);

/* Scan the field now: call after anything other than the solver and this object wrote h. */
void swell_body_rescan(struct swell_body *b, const struct swell_wave *w);

/* One device tick: pose from the device position (um) and velocity (um/s), forces, coupling. The
 * same as swell_body_tick_force then swell_body_couple. */
void swell_body_tick(struct swell_body *b, struct swell_wave *w, const int32_t pos_dev_um[3],
		     const int32_t vel_dev_um_s[3], struct swell_body_out *out);

/* The tick's force alone (it only reads the field): what the object will hold in the water is kept
 * for swell_body_couple, which must run before anything else reads or writes the field or this
 * object (the next tick, a solver slice, a scan). A real-time port runs this in the interrupt that
 * sends the force and the coupling in the background part after it: the same bits as
 * swell_body_tick. */
void swell_body_tick_force(struct swell_body *b, const struct swell_wave *w, const int32_t pos_dev_um[3],
			   const int32_t vel_dev_um_s[3], struct swell_body_out *out);

/* The coupling of the last swell_body_tick_force (none pending: nothing). */
void swell_body_couple(struct swell_body *b, struct swell_wave *w);

/* The same coupling with the cells' writes kept for later where nothing reads them before: while the
 * object stays in the water and no row of this solver period has been scanned, only the volume is
 * counted now (V_displaced and the mean level, as swell_body_couple counts them), and
 * swell_body_place writes the period's changes in one pass. Within a solver period the field's h(n)
 * does not move and the water added only reaches h(n+1), so the force law, the solver's slices and
 * the telemetry read the same; the coupling's difference over a period telescopes to one deposit
 * (the same bits as swell_body_couple unless an accumulator or height saturates). Call
 * swell_body_place before the step in progress finishes (swell_wave_step_finish) and before anything
 * else reads the field's h + acc. A coupling that cannot wait writes everything pending at once. */
void swell_body_couple_later(struct swell_body *b, struct swell_wave *w);

/* Write into the field what swell_body_couple_later kept back (nothing kept: nothing). */
void swell_body_place(struct swell_body *b, struct swell_wave *w);

/* sum(h) + adds pending in the solver - (V_displaced less what is not yet placed), in LSB * cell:
 * constant while nothing else
 * writes h and the solver saturates nothing (w->saturations). One pass over the field. */
int64_t swell_body_invariant(const struct swell_body *b, const struct swell_wave *w);

/* Conversions between um and height LSB (rounded to nearest, saturated to int32). */
int32_t swell_um_to_lsb(int64_t um);
int32_t swell_lsb_to_um(int64_t lsb);

#endif
