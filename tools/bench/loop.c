/* swell-bench loop: one point of the coupled loop, its classification and the theory; see loop.h. */
#include "loop.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hm_hand.h"
#include "hm_model.h"
#include "swell/ctl.h"
#include "swell/effect.h"
#include "swell/force_safety.h"
#include "swell/param.h"
#include "swell/proto.h"

#define RHO_KG_M3 1000.0
#define G_M_S2 9.81 /* the controller's 9810 mm/s^2 */
#define H_M 0.050 /* the object's height, the reference cube's */
#define REF_SIDE_M 0.050
#define LOOP_MAX_DELAY 4
#define SLOT_MSGS 16 /* what the controller sends the device in one tick, at most */
#define MAX_WINDOWS 4096
#define MAX_SECONDS 60.0
/* effect mode carries each spring's k in 0.01 N/m in 16 bits (EFFECT_SPRING.k_10mN_m); the
 * controller saturates a stiffer one to it (swell_effect_from_body): such a point is refused */
#define EFFECT_K_MAX_N_M 655.35

double loop_k_ref(void)
{
	return RHO_KG_M3 * G_M_S2 * REF_SIDE_M * REF_SIDE_M;
}

double loop_side_mm(double k_mult)
{
	return REF_SIDE_M * 1e3 * sqrt(k_mult);
}

const char *loop_class_name(enum loop_class c)
{
	static const char *const names[] = { "stable", "limit-cycle", "divergent", "refused", "beyond-effect-range" };

	return (unsigned)c < sizeof(names) / sizeof(names[0]) ? names[c] : "?";
}

/* ---- theory ---- */

int loop_schur_stable(const double *c, int n)
{
	double a[17], b[17];
	int i;

	if (n < 0 || n > 16 || c[n] == 0.0)
		return 0;
	memcpy(a, c, (size_t)(n + 1) * sizeof(double));
	while (n > 0) {
		/* |a0| < |an|, then (an p(z) - a0 p*(z)) / z, one degree less, has the same count of roots
		 * inside the unit circle less one */
		if (!(fabs(a[0]) < fabs(a[n])))
			return 0;
		for (i = 0; i < n; i++)
			b[i] = a[n] * a[i + 1] - a[0] * a[n - 1 - i];
		n--;
		memcpy(a, b, (size_t)(n + 1) * sizeof(double));
	}
	return 1;
}

int loop_theory_stable(double m, double b, double k, double B, int d, double T)
{
	/* m z^d (z^2 - (1 + al) z + al) + (k T^2 + B T) z - B T, al = 1 - bT/m */
	double c[17] = { 0 };
	const double al = 1.0 - b * T / m;

	if (d < 0 || d > 14)
		return 0;
	c[d + 2] += m;
	c[d + 1] += -m * (1.0 + al);
	c[d] += m * al;
	c[1] += k * T * T + B * T;
	c[0] += -B * T;
	return loop_schur_stable(c, d + 2);
}

double loop_theory_k_crit(double m, double b, double B, int d, double T, double k_hi)
{
	double lo = 0.0, hi = k_hi;
	int it;

	if (loop_theory_stable(m, b, k_hi, B, d, T))
		return k_hi;
	for (it = 0; it < 60; it++) {
		const double mid = 0.5 * (lo + hi);

		if (loop_theory_stable(m, b, mid, B, d, T))
			lo = mid;
		else
			hi = mid;
	}
	return lo;
}

int loop_theory_damper_stable(double m, double b, double B, int d, double T)
{
	/* m z^d (z - 1 + bT/m) + B T */
	double c[17] = { 0 };

	if (d < 0 || d > 15)
		return 0;
	c[d + 1] += m;
	c[d] += -m + b * T;
	c[0] += B * T;
	return loop_schur_stable(c, d + 1);
}

double loop_theory_b_crit(double m, double b, int d, double T, double b_hi)
{
	double lo = 0.0, hi = b_hi;
	int it;

	if (loop_theory_damper_stable(m, b, b_hi, d, T))
		return b_hi;
	for (it = 0; it < 60; it++) {
		const double mid = 0.5 * (lo + hi);

		if (loop_theory_damper_stable(m, b, mid, d, T))
			lo = mid;
		else
			hi = mid;
	}
	return lo;
}

/* ---- the loop ---- */

/* v rounded half up and saturated for the wire, as the device sends it */
static int16_t wire16(double v)
{
	const double r = floor(v + 0.5);

	return r != r ? 0 : (int16_t)(r > 30000.0 ? 30000.0 : r < -30000.0 ? -30000.0 : r);
}

/* What the device keeps of the controller's effect set (effect mode), as swell-hm renders it. */
struct dev_fx {
	struct swell_effect_rx rx;
	struct swell_effect eff;
	int have;
	uint32_t age, fresh;
	struct swell_fsafety safety;
};

static void dev_act(struct dev_fx *d, struct hm_state *s, const struct swell_msg *m)
{
	static const double none[3] = { 0.0, 0.0, 0.0 };
	struct swell_effect next;

	if (m->type == SWELL_MSG_FORCE_CMD) {
		const double f[3] = { m->u.force_cmd.fx_cN * 0.01, m->u.force_cmd.fy_cN * 0.01,
				      m->u.force_cmd.fz_cN * 0.01 };

		hm_command(s, f, m->u.force_cmd.enable);
		if (!m->u.force_cmd.enable)
			d->have = 0;
	} else if (swell_effect_recv(&d->rx, m, &next) == 1) {
		d->eff = next;
		d->have = 1;
		d->age = 0;
		hm_command_for(s, none, 1, d->fresh);
	}
}

/* The device's own effect force this tick (before hm_step): the set at its wire position and
 * velocity through its limit stage, while the set is fresh and enabled. */
static void dev_effect_tick(struct dev_fx *d, struct hm_state *s, double rate_hz)
{
	int32_t f_uN = 0;
	int on = d->have && d->age < d->fresh && s->cmd_enable;

	if (on) {
		const struct swell_fsafety_params sp = { SWELL_Q16_ONE, d->eff.fmax_cN * 10000u,
							 d->eff.rate_100mN_s * 100000u, (uint32_t)rate_hz };

		if (swell_fsafety_set(&d->safety, &sp) != SWELL_OK)
			on = 0;
		else
			f_uN = swell_effect_force_uN(&d->eff, wire16(s->x[2] * 1e5), wire16(s->v[2] * 1e4));
	}
	s->effect_N[0] = s->effect_N[1] = 0.0;
	s->effect_N[2] = swell_fsafety_apply(&d->safety, f_uN, on) * 1e-6;
	if (d->have && d->age < UINT32_MAX)
		d->age++;
}

/* The static force law's potential at device z (m, water at rest, the pool's level rise with it):
 * F(z) = -m g + k clamp(-z / (1 - r), 0, H). */
static double potential_J(double m_kg, double k, double r, double z)
{
	const double q = 1.0 - r, u = -z;
	double spring = 0.0;

	if (u > 0.0)
		spring = u <= q * H_M ? u * u / (2.0 * q) : q * H_M * H_M / 2.0 + H_M * (u - q * H_M);
	return m_kg * G_M_S2 * z + k * spring;
}

static void refuse(struct loop_result *r, const char *why, const char *detail)
{
	r->cls = LOOP_REFUSED;
	snprintf(r->why, sizeof(r->why), "%s%s%s", why, detail ? ": " : "", detail ? detail : "");
}

/* One parameter set through the controller's own path; 0 when acknowledged. */
static int ctl_param(struct swell_ctl *c, uint16_t id, int32_t v)
{
	const struct swell_msg m = swell_param_request(0, 1, id, v, 0);
	struct swell_msg a[SWELL_CTL_QUEUE];
	size_t n, k;
	int ok = -1;

	swell_ctl_rx(c, SWELL_LINK_HOST, &m);
	n = swell_ctl_tx(c, SWELL_LINK_HOST, a, SWELL_CTL_QUEUE);
	for (k = 0; k < n; k++)
		if (a[k].type == SWELL_MSG_PARAM_ACK)
			ok = 0;
	return ok;
}

/* The envelope: the growth rate (1/s) of the windows' peak-to-peak swing, a least-squares line
 * through their logarithms, windows from..n-1. */
static double envelope_rate(const double *p2p, int from, int n, double w_s)
{
	double sx = 0, sy = 0, sxx = 0, sxy = 0;
	int i, cnt = 0;

	for (i = from; i < n; i++) {
		const double x = i * w_s, y = log(p2p[i] > 1e-9 ? p2p[i] : 1e-9);

		sx += x;
		sy += y;
		sxx += x * x;
		sxy += x * y;
		cnt++;
	}
	if (cnt < 2)
		return 0.0;
	return (cnt * sxy - sx * sy) / (cnt * sxx - sx * sx);
}

void loop_run(const struct loop_point *p, struct loop_result *r)
{
	struct swell_ctl_config cfg;
	struct swell_ctl *c = NULL;
	struct hm_params hp;
	struct hm_state s;
	struct hm_hand hand;
	struct dev_fx fx;
	struct swell_msg slot[LOOP_MAX_DELAY + 1][SLOT_MSGS], host[SWELL_CTL_QUEUE];
	size_t slot_n[LOOP_MAX_DELAY + 1];
	int32_t *arena = NULL;
	double *p2p = NULL;
	size_t words;
	const struct swell_param_desc *pas = swell_param_by_name("force.passivity");
	const struct swell_param_desc *pdl = swell_param_by_name("force.pc_delay"),
				      *pdm = swell_param_by_name("force.pc_damping");
	struct swell_energy_account acc;
	double d_rel = 0.0, d_min = 0.0, run_max = 0.0;
	const double T = 1.0 / p->rate_hz, pool_m = LOOP_POOL_N * SWELL_POOL_DX_UM * 1e-6;
	double side_m, k, m_obj, delta_eq, period, w_s, run_s, x0[3] = { 0, 0, 0 }, e_port = 0.0, zmin, zmax;
	uint32_t a_um, mass_g;
	long n, total, hold, w_ticks, nw = 0;
	char why[100], spec[96];
	int d = p->delay, released = 0;

	memset(r, 0, sizeof(*r));
	if (d < 0 || d > LOOP_MAX_DELAY) {
		refuse(r, "delay outside 0..4 ticks", NULL);
		return;
	}

	/* the object: a = b = 50 mm sqrt(multiple), floating half submerged */
	a_um = (uint32_t)lround(loop_side_mm(p->k_mult) * 1e3);
	side_m = a_um * 1e-6;
	k = RHO_KG_M3 * G_M_S2 * side_m * side_m;
	mass_g = (uint32_t)lround(RHO_KG_M3 * side_m * side_m * (H_M / 2.0) * 1e3);
	m_obj = mass_g * 1e-3;
	r->k_N_m = k;
	r->a_mm = a_um * 1e-3;
	r->mass_g = mass_g;
	r->r_area = side_m * side_m / (pool_m * pool_m);
	delta_eq = m_obj / (RHO_KG_M3 * side_m * side_m);
	r->z_eq_mm = -delta_eq * (1.0 - r->r_area) * 1e3;

	if (p->mode && k > EFFECT_K_MAX_N_M) {
		r->cls = LOOP_BEYOND_EFFECT;
		snprintf(r->why, sizeof(r->why), "effect mode: %.1f N/m is beyond EFFECT_SPRING's %.2f N/m", k,
			 EFFECT_K_MAX_N_M);
		return;
	}
	swell_ctl_default_config(&cfg);
	cfg.nx = cfg.ny = LOOP_POOL_N;
	cfg.xform.offset_um[0] = cfg.xform.offset_um[1] = LOOP_POOL_N * SWELL_POOL_DX_UM / 2;
	cfg.tick_hz = (uint32_t)lround(p->rate_hz);
	cfg.safety.tick_hz = cfg.tick_hz;
	cfg.body.a_um = cfg.body.b_um = a_um;
	cfg.body.mass_g = mass_g;
	cfg.body.damper_uN_per_mm_s = (uint32_t)lround(p->damper_Ns_m * 1e3);
	cfg.safety.f_max_uN = (uint32_t)lround(LOOP_F_MAX_N * 1e6);
	cfg.safety.rate_uN_per_s = INT32_MAX; /* the rate limit would be a nonlinearity of its own */
	cfg.force_mode = (uint8_t)(p->mode ? SWELL_FORCE_EFFECT : SWELL_FORCE_STREAM);
	cfg.autorun = 1;
	cfg.energy_water = (uint8_t)(p->water_energy != 0);
	cfg.passivity = (uint8_t)(p->passivity != 0);
	if (swell_ctl_check(&cfg) != SWELL_OK) {
		refuse(r, "controller configuration", swell_err_str(swell_ctl_check(&cfg)));
		return;
	}
	hm_params_default(&hp);
	hp.rate_hz = p->rate_hz;
	hp.mass_kg = p->mass_kg;
	hp.damping_Ns_m = p->damping_Ns_m;
	if (hm_params_check(&hp, LOOP_HAND_K, LOOP_HAND_B, why, sizeof(why)) != SWELL_OK) {
		refuse(r, "device model", why);
		return;
	}
	/* from just above the water down to the swing's start in LOOP_RAMP_S (slowly: the waves it makes
	 * are small), held there until LOOP_HOLD_S, let go */
	snprintf(spec, sizeof(spec), "press:at=0,depth=%.6f,ramp=%g,hold=%.6f,k=%g,b=%g", -(r->z_eq_mm - LOOP_SWING_MM),
		 LOOP_RAMP_S, LOOP_HOLD_S - LOOP_RAMP_S, LOOP_HAND_K, LOOP_HAND_B);
	if (hm_hand_parse(spec, &hand, why, sizeof(why)) != SWELL_OK) {
		refuse(r, "hand", why);
		return;
	}

	words = swell_ctl_arena_words(cfg.nx, cfg.ny);
	arena = calloc(words, sizeof(int32_t));
	c = calloc(1, sizeof(*c));
	/* the classification's windows: one undamped period of the spring on the device's mass */
	period = 2.0 * 3.14159265358979323846 * sqrt(p->mass_kg / k);
	run_s = fmin(fmax(p->seconds, 6.0 * period), MAX_SECONDS);
	w_ticks = lround(period * p->rate_hz);
	w_ticks = w_ticks < 20 ? 20 : w_ticks;
	w_s = (double)w_ticks / p->rate_hz;
	p2p = calloc(MAX_WINDOWS, sizeof(double));
	if (!arena || !c || !p2p) {
		fprintf(stderr, "swell-bench: out of memory\n");
		exit(1);
	}
	if (swell_ctl_init(c, &cfg, arena, words) != SWELL_OK) {
		refuse(r, "controller start", swell_err_str(c->last_err));
		goto out;
	}
	/* force.passivity through the host link where the table has it (else the configuration's) */
	if (p->passivity && pas && ctl_param(c, pas->id, 1) != 0) {
		refuse(r, "force.passivity 1 refused", NULL);
		goto out;
	}
	/* the link's delay, as a lab sets it for its own link: the account pairs each motion with the force
	 * the device applied then (stream mode; effect mode renders at the device's own state) */
	if (pdl && ctl_param(c, pdl->id, p->pc_delay_given ? p->pc_delay : d) != 0) {
		refuse(r, "force.pc_delay refused", NULL);
		goto out;
	}
	if (p->pc_damping_Ns_m > 0.0 && pdm && ctl_param(c, pdm->id, (int32_t)lround(p->pc_damping_Ns_m * 1e3)) != 0) {
		refuse(r, "force.pc_damping refused", NULL);
		goto out;
	}
	r->ctl_passivity = c->cfg.passivity;

	memset(&fx, 0, sizeof(fx));
	fx.fresh = (uint32_t)lround(0.010 * p->rate_hz); /* swell-hm's default --effect-fresh 10 ms */
	x0[2] = LOOP_START_MM * 1e-3;
	hm_init(&s, x0);
	memset(slot_n, 0, sizeof(slot_n));
	hold = lround(LOOP_HOLD_S * p->rate_hz);
	total = hold + lround(run_s * p->rate_hz);
	zmin = zmax = x0[2];
	for (n = 0; n < total; n++) {
		const double t = (double)n * T;
		struct swell_msg m[2];
		double f_hand[3], z_before;
		const int cur = (int)(n % (LOOP_MAX_DELAY + 1)),
			  due = (int)((n - d + LOOP_MAX_DELAY + 1) % (LOOP_MAX_DELAY + 1));
		size_t j;

		/* the device's sample, then the controller's tick on it */
		memset(m, 0, sizeof(m));
		m[0].type = SWELL_MSG_DEVICE_VEL;
		m[0].u.device_vel.vx_100ums = wire16(s.v[0] * 1e4);
		m[0].u.device_vel.vy_100ums = wire16(s.v[1] * 1e4);
		m[0].u.device_vel.vz_100ums = wire16(s.v[2] * 1e4);
		m[0].u.device_vel.seq = (uint8_t)n;
		m[1].type = SWELL_MSG_DEVICE_POS;
		m[1].u.device_pos.x_10um = wire16(s.x[0] * 1e5);
		m[1].u.device_pos.y_10um = wire16(s.x[1] * 1e5);
		m[1].u.device_pos.z_10um = wire16(s.x[2] * 1e5);
		m[1].u.device_pos.seq = (uint8_t)n;
		m[1].u.device_pos.status = SWELL_DEV_POWERED | SWELL_DEV_FORCE_ON;
		swell_ctl_rx(c, SWELL_LINK_DEVICE, &m[0]);
		swell_ctl_rx(c, SWELL_LINK_DEVICE, &m[1]);
		swell_ctl_tick(c);
		slot_n[cur] = swell_ctl_tx(c, SWELL_LINK_DEVICE, slot[cur], SLOT_MSGS);
		while (swell_ctl_tx(c, SWELL_LINK_HOST, host, SWELL_CTL_QUEUE) == SWELL_CTL_QUEUE)
			;
		/* what the controller sent d ticks ago arrives now */
		if (n >= d) {
			for (j = 0; j < slot_n[due]; j++)
				dev_act(&fx, &s, &slot[due][j]);
			slot_n[due] = 0;
		}
		hm_hand_force(&hand, t, s.x, s.v, f_hand);
		if (n == hold) { /* let go: the free response starts from here */
			released = 1;
			r->z_release_mm = s.x[2] * 1e3;
			zmin = zmax = s.x[2];
			swell_ctl_energy(c, &acc);
			d_rel = d_min = (double)acc.balance_uJ;
		}
		dev_effect_tick(&fx, &s, p->rate_hz);
		z_before = s.x[2];
		hm_step(&hp, &s, f_hand);
		if (p->trace)
			fprintf(p->trace, "%.4f,%.4f,%.3f,%.4f,%.3f,%d\n", t, z_before * 1e3, s.v[2] * 1e3,
				s.f_cmd_N[2], f_hand[2], (int)c->state);
		if (!released)
			continue;
		{
			const double dev = fabs(s.x[2] * 1e3 - r->z_eq_mm), f = fabs(s.f_cmd_N[2]);
			const long i = n - hold; /* ticks since the release, this tick's step done */

			e_port += s.f_cmd_N[2] * (s.x[2] - z_before);
			{ /* the port's running balance, and the controller's (D after the release) */
				const double made = e_port + potential_J(m_obj, k, r->r_area, s.x[2]) -
					potential_J(m_obj, k, r->r_area, r->z_release_mm * 1e-3);

				run_max = made > run_max ? made : run_max;
				swell_ctl_energy(c, &acc);
				d_min = (double)acc.balance_uJ < d_min ? (double)acc.balance_uJ : d_min;
			}
			r->peak_dev_mm = dev > r->peak_dev_mm ? dev : r->peak_dev_mm;
			r->peak_force_N = f > r->peak_force_N ? f : r->peak_force_N;
			zmin = s.x[2] < zmin ? s.x[2] : zmin;
			zmax = s.x[2] > zmax ? s.x[2] : zmax;
			if ((i + 1) % w_ticks == 0 && nw < MAX_WINDOWS) {
				p2p[nw++] = (zmax - zmin) * 1e3;
				zmin = zmax = s.x[2];
			}
			if (r->peak_dev_mm > 4.0 * LOOP_BOUND_MM)
				break; /* far gone: the class cannot change */
		}
	}
	r->e_port_J = e_port;
	r->e_created_J = e_port + potential_J(m_obj, k, r->r_area, s.x[2]) -
		potential_J(m_obj, k, r->r_area, r->z_release_mm * 1e-3);
	r->e_created_max_J = run_max;
	r->ctl_created_J = (d_rel - d_min) * 1e-6;
	r->have_ctl_energy = 1;
	swell_ctl_energy(c, &acc);
	r->ctl_damped_J = acc.damped_uJ * 1e-6;
	r->force_limited = r->peak_force_N >= 0.999 * LOOP_F_MAX_N;
	r->p2p_first_mm = nw > 0 ? p2p[0] : 0.0;
	r->p2p_last_mm = nw > 0 ? p2p[nw - 1] : 0.0;
	r->sigma_per_s = envelope_rate(p2p, (int)(nw / 2), (int)nw, w_s);
	/* against the swing the release starts, 2 |z_release - z_eq| peak to peak: divergent beyond the
	 * bound or at the force limit, or grown past that swing and still growing; a limit cycle: grown
	 * past it, or kept at least half of it with an envelope not falling; else stable (the water's
	 * waves keep a small swing going, whose envelope wanders either way) */
	{
		const double ref = 2.0 * fabs(r->z_release_mm - r->z_eq_mm);

		if (r->peak_dev_mm > LOOP_BOUND_MM || r->force_limited ||
		    (r->sigma_per_s > LOOP_SIGMA_TOL && r->p2p_last_mm > ref))
			r->cls = LOOP_DIVERGENT;
		else if (r->p2p_last_mm > ref ||
			 (r->sigma_per_s >= -LOOP_SIGMA_TOL && r->p2p_last_mm >= LOOP_FLOOR_MM &&
			  r->p2p_last_mm >= 0.5 * ref))
			r->cls = LOOP_LIMIT_CYCLE;
		else
			r->cls = LOOP_STABLE;
	}
out:
	free(p2p);
	free(c);
	free(arena);
}
