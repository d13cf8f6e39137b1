/* The HapticMaster's command language, emulated: the device states, the effects it renders and the
 * text commands a client sends over TCP (docs/hapticmaster.md). No I/O here (hm_serve.c carries the
 * bytes) and no allocation: a fixed table of effects, replies written into the caller's buffer.
 *
 * A request is one or more commands joined by ';'. Each command is checked whole before it changes
 * anything: a refused command is answered "--- ERROR: <reason>" and leaves the device as it was; the
 * other commands of the request still run, in order. The reply holds one answer per command, joined
 * by ';'.
 *
 * Forces are rendered only in the `force` state, from the enabled effects:
 *   spring    (pos, vel, stiffness, dampfactor, deadband, direction, maxforce, dampglobal): see
 *             hm_spring_force for the law;
 *   damper    F_i = -dampcoef_i (v_i - vel_i);
 *   biasforce F = force (zeroed by the device-side watchdog when the client that set it falls silent,
 *             and when it disconnects; a spring or damper is disabled alike, for the client that last
 *             set anything on it).
 * Every effect's origin moves with its `vel`: pos += vel dt each device tick. */
#ifndef SWELL_HM_CMD_H
#define SWELL_HM_CMD_H

#include <stddef.h>
#include <stdint.h>

#define HM_EFFECTS_MAX 16 /* effects the device holds at once */
#define HM_NAME_MAX 32 /* longest effect name, with its terminating NUL */
#define HM_CLIENTS_MAX 8 /* clients the watchdog follows (hm_serve's table) */

enum hm_dev_state {
	HM_STATE_OFF,
	HM_STATE_INIT,
	HM_STATE_HOME,
	HM_STATE_FORCE,
	HM_STATE_POSITION,
	HM_STATE_STOP
};

enum hm_effect_kind {
	HM_FX_SPRING,
	HM_FX_DAMPER,
	HM_FX_BIAS
};

struct hm_spring {
	double k_N_m; /* stiffness; negative: a pushing spring (away from its origin) */
	double dampfactor; /* damping relative to critical, 2 sqrt(|k| m) with m the device inertia */
	double deadband_m; /* no spring force within this distance of the origin */
	double dir[3]; /* unit vector the spring acts along; all zero: every direction */
	double maxforce_N; /* |F| of the spring (spring + damping) is limited to this */
	int dampglobal; /* 1: damping everywhere; 0: only where the spring acts (outside the deadband) */
};

struct hm_effect {
	int used, enabled;
	enum hm_effect_kind kind;
	char name[HM_NAME_MAX];
	double pos_m[3], vel_m_s[3], att[4];
	struct hm_spring spring;
	double dampcoef_Ns_m[3];
	double force_N[3];
	int owner; /* biasforce: the client that last set its force; spring, damper: that last set anything on
		    * it (-1 none) */
};

struct hm_dev {
	enum hm_dev_state state;
	double rate_hz, f_max_N; /* device tick rate, largest force per axis */
	double inertia_kg, coulomb_N;
	int estop; /* the emergency button is pushed */
	int force_calibrated;
	int init_fails_calibration; /* fault injection: init leaves the device uncalibrated */
	uint32_t watchdog_ticks; /* a client silent this long: its bias forces zero, its springs and dampers
				  * disabled; 0: off */
	/* the model, as the last tick left it (swell-hm writes these) */
	double x_m[3], v_m_s[3], a_m_s2[3], fmeas_N[3];
	struct hm_effect fx[HM_EFFECTS_MAX];
	uint64_t tick;
	uint64_t client_heard[HM_CLIENTS_MAX]; /* tick of each client's last request */
	/* counters */
	uint32_t commands, errors, watchdog_trips, vanished_zeroed, estop_stops;
};

/* Device off, no effects, inertia 2 kg, no friction, watchdog off. */
void hm_dev_init(struct hm_dev *d, double rate_hz, double f_max_N);

/* Runs a request of len bytes (need not be NUL-terminated) from client (0..HM_CLIENTS_MAX-1, or -1 for
 * none) and writes the reply, NUL-terminated, into reply (cap bytes; an answer that does not fit is cut
 * and the reply ends in "--- ERROR: reply too long"). Returns the reply's length. */
size_t hm_dev_request(struct hm_dev *d, int client, const char *text, size_t len, char *reply, size_t cap);

/* A client went away: the bias forces it set drop to zero, its springs and dampers are disabled, at once. */
void hm_dev_client_gone(struct hm_dev *d, int client);

/* The e-stop: pressed, the device goes to `stop` (every effect force drops at once) and refuses
 * every state but `stop` and `off` until it is released. */
void hm_dev_set_estop(struct hm_dev *d, int pressed);

/* One device tick: the watchdog on silent clients, then every effect's origin moves with its vel.
 * f_N gets the force the effects render at x, v (zero outside `force`), limited to f_max per axis. */
void hm_dev_tick(struct hm_dev *d, const double x_m[3], const double v_m_s[3], double f_N[3]);

/* The spring law (docs/hapticmaster.md), for the effect at pos_m moving with vel_m_s, a device of
 * inertia m_kg at x, v. With u = dir, e = x - pos, e' = v - vel:
 *   u != 0: s = u.e; outside = |s| > D; F = -k sign(s) (|s| - D) u [outside] - c (u.e') u [outside or
 *           dampglobal]
 *   u == 0: r = |e|; outside = r > D;   F = -k (r - D) e / r [outside]      - c e'         [idem]
 * with c = dampfactor 2 sqrt(|k| m); then |F| is limited to maxforce. */
void hm_spring_force(const struct hm_spring *s, const double pos_m[3], const double vel_m_s[3], double m_kg,
		     const double x_m[3], const double v_m_s[3], double f_N[3]);

const char *hm_dev_state_name(enum hm_dev_state s);

#endif
