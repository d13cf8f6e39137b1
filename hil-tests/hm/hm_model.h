/* The HapticMaster model: an admittance-controlled device, per axis
 *
 *     m_v a = F_user + F_cmd - b_v v + F_wall
 *
 * integrated at the device rate with semi-implicit Euler (v first, then x with the new v), in SI
 * units and doubles (host code: the bench, never the controller). Like the real device it
 * compensates its own gravity, so the object's weight is not here: it comes from the controller's
 * force law through F_cmd.
 *
 * F_cmd is the last FORCE_CMD, applied only while the device trusts it (the device-side watchdog):
 *   - the command's enable bit is set, the e-stop is released, and
 *   - the controller has not been silent for watchdog_ticks ticks: a command is held for at most
 *     watchdog_ticks - 1 ticks without a fresh one, then the commanded force is zero until the next.
 * The force of the device's own effects (effect_N, effect mode) is added to the command and follows
 * the same rules. |F_cmd| is limited per axis to f_max. The workspace is a box of +-limit per axis, its faces stiff
 * spring-dampers (k_wall, b_wall) that push back and never pull. */
#ifndef SWELL_HM_MODEL_H
#define SWELL_HM_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"

struct hm_params {
	double rate_hz; /* device tick rate (HapticMaster servo: 2500) */
	double mass_kg; /* virtual mass m_v */
	double damping_Ns_m; /* virtual damping b_v */
	double limit_m[3]; /* workspace half-range per axis */
	double wall_k_N_m; /* workspace wall stiffness */
	double wall_b_Ns_m; /* workspace wall damping */
	double f_max_N; /* largest commanded force applied, per axis */
	uint32_t watchdog_ticks; /* controller silent this many ticks -> no commanded force */
};

struct hm_state {
	double x[3], v[3]; /* m, m/s; device frame: x, y horizontal, z up */
	double cmd_N[3]; /* last FORCE_CMD received */
	double effect_N[3]; /* effect mode: what the device's own effects produce this tick (set by the
			     * caller before hm_step, applied with the command and under its rules) */
	int cmd_enable; /* its enable bit */
	int have_cmd; /* a command has ever arrived */
	uint32_t cmd_age; /* ticks integrated since the last command (saturating) */
	uint32_t cmd_watchdog; /* this command's watchdog in ticks; 0: the params' (hm_command_for) */
	int estop; /* e-stop pressed: no commanded force */
	double f_cmd_N[3]; /* commanded force applied in the last tick */
	double f_wall_N[3]; /* wall force in the last tick */
	int applying; /* the last tick applied the command */
	uint64_t ticks;
	uint32_t watchdog_trips; /* times the watchdog dropped an enabled command */
	uint32_t wall_ticks; /* ticks spent in a workspace wall */
};

/* The defaults documented in docs/hm.md (2 kg, 2 N s/m, +-200 mm, 250 N, watchdog 2 ticks). */
void hm_params_default(struct hm_params *p);

/* SWELL_ERANGE for a value outside its range, SWELL_EUNSTABLE when the integration would not be
 * stable at this rate (stiffest spring k with sqrt(k/m)/rate > 0.5, or b dt / m > 0.5). why (may be
 * NULL) gets a one-line reason. stiff_extra_N_m is any further spring the caller adds (the hand). */
enum swell_err hm_params_check(const struct hm_params *p, double stiff_extra_N_m, double damp_extra_Ns_m, char *why,
			       size_t why_len);

/* At rest at x0 (metres), no command, nothing applied. */
void hm_init(struct hm_state *s, const double x0_m[3]);

/* A FORCE_CMD arrived (forces in N). It is applied from the next hm_step on. */
void hm_command(struct hm_state *s, const double f_N[3], int enable);

/* The same with its own watchdog (ticks >= 1): an effect set, whose freshness limit is its watchdog. */
void hm_command_for(struct hm_state *s, const double f_N[3], int enable, uint32_t watchdog_ticks);

/* The watchdog of the command in force, in ticks. */
uint32_t hm_cmd_watchdog(const struct hm_params *p, const struct hm_state *s);

/* Would the next hm_step apply the command? */
int hm_cmd_active(const struct hm_params *p, const struct hm_state *s);

/* One device tick with the user's hand force f_user (N). */
void hm_step(const struct hm_params *p, struct hm_state *s, const double f_user_N[3]);

#endif
