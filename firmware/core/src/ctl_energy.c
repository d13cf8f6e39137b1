/* The energy account of the hand-water loop and the time-domain passivity controller (swell/ctl.h,
 * docs/energy.md). Integers only: sums in picojoules (uN x um) in int64, saturating; no division on
 * the force path but the controller's one, and only on a tick where it acts.
 *
 * Rounding, per term:
 *   W        exact in pJ: force (uN, the wire's whole cN) x differenced position (um, the device's
 *            10 um samples) per axis; the position's quantisation telescopes, so the sum over a run
 *            is exact for a piecewise constant force.
 *   m g z    exact in pJ (gravity in uN x pool z in um).
 *   springs  1/2 k s^2: k s to uN 2^-4 (floor), its product with s to pJ rounded to nearest: below
 *            one pJ plus s x 2^-4 uN (< 0.05 uJ at 500 mm); the linear part beyond the stretch
 *            where the force stops growing (full submersion, or force.max) k s_sat (uN, nearest)
 *            x (s - s_sat) (um, nearest).
 *   floor    the same with the contact's stiffness, up to its own limit or force.max.
 *   water    the solver's invariant scaled to pJ, rounded to nearest (swell_ctl_water_pJ).
 *   uJ       the figures are the pJ sums / 10^6, rounded to nearest (ties away from zero). */
#include <stddef.h>

#include "ctl_priv.h"
#include "swell/pool.h"

#define PJ_MAX INT64_MAX
#define PJ_MIN (-INT64_MAX)

static int64_t sat_add64(int64_t a, int64_t b)
{
	if (b > 0 && a > PJ_MAX - b)
		return PJ_MAX;
	if (b < 0 && a < PJ_MIN - b)
		return PJ_MIN;
	return a + b;
}

static int64_t pj_to_uj(int64_t pj)
{
	return pj >= 0 ? (pj + 500000) / 1000000 : -((-pj + 500000) / 1000000);
}

/* The force on the wire for an axis, in uN: the whole cN the device is sent. */
static int32_t wire_uN(const struct swell_ctl *c, int32_t uN)
{
	return (int32_t)ctl_force_cN(c, uN) * 10000;
}

/* The stretch (LSB) at which a spring of stiffness k_q8 (uN 2^-24 per LSB) reaches f_uN, rounded up
 * (f <= 2^30, k_q8 >= 1: no overflow). A 64-bit division: only where a limit cuts the spring. */
static int64_t stretch_at(int64_t k_q8, int64_t f_uN)
{
	return ((f_uN << 24) + k_q8 - 1) / k_q8;
}

/* The energy of a spring of stiffness k_q8 stretched by s (LSB) whose force stops growing at the
 * stretch s_sat: 1/2 k s^2 up to s_sat, then k s_sat (s - s_sat). */
static int64_t spring_pJ(int64_t k_q8, int64_t s, int64_t s_sat)
{
	int64_t sc, f_q4, e;

	if (s <= 0)
		return 0;
	sc = s < s_sat ? s : s_sat;
	f_q4 = (k_q8 * sc) >> 20; /* uN 2^-4, <= 2^34 */
	/* 1/2 f s [uN 2^-4 x LSB] -> pJ: x 1000 / 2^(4 + 16 + 1) */
	e = swell_shr_rn(swell_shr_rn(f_q4 * sc, 11) * 1000, 10);
	if (s > sc)
		e = sat_add64(e, swell_shr_rn(k_q8 * sc, 24) * swell_lsb_to_um(s - sc));
	return e;
}

/* S(n) without the water: the object's weight, the buoyancy springs and the floor's contact spring
 * as rendered: each spring's force stops growing where the safety stage's limit (or the floor's own)
 * stops the device's, so that a clamped force is not counted as energy stored. */
static int64_t object_pJ(const struct swell_ctl *c, const struct swell_body_out *o)
{
	const struct swell_body *b = &c->body;
	const int64_t f_max = c->cfg.safety.f_max_uN, f_kh = swell_shr_rn((int64_t)b->k_q8 * b->h_lsb, 24);
	const int64_t floor_k_q8 = (int64_t)SWELL_BODY_FLOOR_K << 8; /* uN/mm -> uN 2^-24 per LSB */
	int64_t s = -(int64_t)o->f.gravity_uN * o->z_um; /* m g z */
	int32_t z, zw;

	if (o->skipped)
		return s;
	z = swell_clamp(swell_um_to_lsb(o->z_um), -((int32_t)1 << 30), (int32_t)1 << 30);
	zw = z < o->floor_lsb ? o->floor_lsb : z;
	/* the net buoyancy: k clamp(w - z - deadband, 0, H), the pushing spring holding it at k H */
	s = sat_add64(s,
		      spring_pJ(b->k_q8, (int64_t)o->surface_lsb - zw - b->deadband_lsb,
				f_kh <= f_max ? b->h_lsb : stretch_at(b->k_q8, f_max)));
	if (o->penetration_lsb > 0)
		s = sat_add64(
			s,
			spring_pJ(floor_k_q8, o->penetration_lsb,
				  stretch_at(floor_k_q8,
					     f_max < SWELL_BODY_FLOOR_F_MAX_UN ? f_max : SWELL_BODY_FLOOR_F_MAX_UN)));
	return s;
}

int64_t swell_ctl_water_pJ(const struct swell_wave *w, uint32_t dx_um, uint32_t rho_kg_m3, uint32_t g_mm_s2)
{
	const struct swell_energy en = swell_wave_energy(w);
	/* E_J = rho g dx^2 / (2 e_eff) (kin + e_eff pot2 / 2) LSB^2, LSB = 2^-16 mm (docs/energy.md):
	 * in pJ with g in mm/s^2 and dx in um: rho g dx^2 1e-9 2^-33 (kin 2^30 / e_eff + pot2 / 2), each
	 * term rounded to nearest by swell_muldiv_u64 (the pot2 divisor 2^34 1e9 fits 64 bits) */
	const uint64_t rgd = (uint64_t)rho_kg_m3 * g_mm_s2 * dx_um * dx_um; /* < 2^14 2^17 2^32 */
	uint64_t kin = 0, pot = 0;
	int64_t e;

	if (en.e_eff <= 0 || en.kin < 0)
		return 0;
	if (!swell_muldiv_u64((uint64_t)en.kin, rgd, (uint64_t)en.e_eff * 8000000000ull, &kin))
		kin = (uint64_t)PJ_MAX;
	if (!swell_muldiv_u64((uint64_t)(en.pot2 < 0 ? -en.pot2 : en.pot2), rgd, 17179869184000000000ull, &pot))
		pot = (uint64_t)PJ_MAX;
	if (kin > (uint64_t)PJ_MAX)
		kin = (uint64_t)PJ_MAX;
	if (pot > (uint64_t)PJ_MAX)
		pot = (uint64_t)PJ_MAX;
	e = sat_add64((int64_t)kin, en.pot2 < 0 ? -(int64_t)pot : (int64_t)pot);
	return e;
}

void ctl_energy_water(struct swell_ctl *c)
{
	if (c->cfg.energy_water)
		c->energy.water_pJ =
			swell_ctl_water_pJ(&c->wave, c->cfg.dx_um, c->cfg.body.rho_kg_m3, c->cfg.body.g_mm_s2);
}

/* D(n) = W(n) - (S(n) - S(0)) */
static int64_t balance(const struct swell_ctl_energy_sums *e)
{
	return sat_add64(e->work_pJ, -sat_add64(e->stored_pJ, -e->stored0_pJ));
}

/* The number of significant bits of x > 0 (CLZ on the Cortex-M4). */
static int bits64(uint64_t x)
{
	return 64 - __builtin_clzll(x);
}

/* num 2^16 / den for num > 0 and den >= 2^16, to 15 significant bits (truncated): both are normalised
 * to a 32-bit dividend with its top bit set and a 16-bit divisor, so that one 32-bit division does it
 * (a 64-bit one is a library call of some hundred instructions on the Cortex-M4). */
static uint64_t div_q16(uint64_t num, uint64_t den)
{
	const int sd = bits64(den) - 16, sn = bits64(num) - 32, sh = 16 + sn - sd;
	const uint32_t n32 = (uint32_t)(sn >= 0 ? num >> sn : num << -sn), d16 = (uint32_t)(den >> sd);
	const uint64_t q = n32 / d16; /* 2^15 .. 2^17 */

	return sh >= 0 ? q << sh : q >> -sh;
}

/* The ring slot of the force the device applied over the step the account counts next: the one sent
 * force.pc_delay ticks before the last tick's (stream mode; in effect mode the device renders the set at
 * its own state, so the force the account computes is the one applied: no delay). */
static unsigned held_slot(const struct swell_ctl *c)
{
	const unsigned d = c->cfg.force_mode == SWELL_FORCE_STREAM ? c->cfg.pc_delay : 0u;

	return (c->energy.ring_head - d) & (SWELL_CTL_PC_RING - 1u);
}

void ctl_energy_force(struct swell_ctl *c, int running, int32_t f_dev_uN[3])
{
	struct swell_ctl_energy_sums *e = &c->energy;
	const int ax = c->cfg.xform.axis[2]; /* the device axis of pool z: the only one the force law drives */
	const int32_t lim = (int32_t)c->cfg.safety.f_max_uN, v = c->vel_um_s[ax];
	const uint64_t b_max = c->cfg.pc_damping_uN_per_mm_s, v2 = (uint64_t)((int64_t)v * v);
	uint64_t neg_d, num;
	int64_t f;

	e->pc_uN[0] = e->pc_uN[1] = e->pc_uN[2] = 0;
	if (!running) {
		e->running = 0;
		return;
	}
	e->pos_now_um[0] = c->pos_um[0];
	e->pos_now_um[1] = c->pos_um[1];
	e->pos_now_um[2] = c->pos_um[2];
	if (!e->running) { /* the run's first tick: the background part takes S(0) */
		e->running = 1;
		e->fresh = 1;
		return;
	}
	/* stream mode only: in effect mode the device renders the effect set itself, and a force added
	 * here would reach the safety stage's watch, not the device */
	if (!c->cfg.passivity || c->cfg.force_mode != SWELL_FORCE_STREAM || e->balance_pJ >= 0 || v == 0 || b_max == 0)
		return;
	/* the controller: the damping alpha = -D / (v^2 dt) that would take the energy created out within
	 * a tick, bounded by force.pc_damping (b_max, uN per mm/s): a damping that large, behind the link's
	 * delay, is active itself. The force -alpha v goes before the safety stage (whose limits hold); what
	 * it takes out shows in W, on the ticks the device applies it. -D held at most 2^36 pJ (69 mJ: at
	 * 50 N s/m and 2500 Hz the bound still acts up to 1.8 m/s), so that -D tick_hz 1000 < 2^63
	 * (tick_hz <= 100000), against b_max v^2 < 2^64 (b_max <= 10^6, v^2 < 2^44 for the wire's 3 m/s) */
	neg_d = (uint64_t)(-e->balance_pJ < ((int64_t)1 << 36) ? -e->balance_pJ : ((int64_t)1 << 36));
	num = neg_d * c->cfg.tick_hz * 1000u; /* uN um/s x 1000: alpha in uN per mm/s times v^2 */
	if (num >= b_max * v2) {
		/* bounded: -b_max v / 1000, b_max v / 1000 as (b_max v 4194) >> 22 (2^22 / 1000 = 4194.3:
		 * 7e-5 low), rounded toward minus infinity; |b_max v| < 2^42 */
		f = -(((int64_t)b_max * v * 4194) >> 22);
	} else {
		/* alpha = -D tick_hz / v^2 (uN per um/s, Q16), below b_max: one 32-bit division (div_q16
		 * needs a divisor of at least 2^16; v^2 below it is scaled up with the dividend, which is
		 * then below b_max v^2 / 1000 < 2^36) */
		uint64_t n2 = neg_d * c->cfg.tick_hz, d2 = v2;
		int64_t alpha_q16;

		while (d2 < ((uint64_t)1 << 16)) {
			d2 <<= 4;
			n2 <<= 4;
		}
		alpha_q16 = (int64_t)div_q16(n2, d2);
		f = -((alpha_q16 * v) >> 16);
	}
	e->pc_uN[ax] = (int32_t)(f > lim ? lim : (f < -lim ? -lim : f));
	f_dev_uN[ax] = swell_clamp(swell_sat_i64((int64_t)f_dev_uN[ax] + e->pc_uN[ax]), -INT32_MAX, INT32_MAX);
	e->controller_ticks++;
	e->acted = 1;
}

void ctl_energy_account(struct swell_ctl *c)
{
	struct swell_ctl_energy_sums *e = &c->energy;
	const int ax = c->cfg.xform.axis[2];
	int64_t dw = 0, dd;
	unsigned h;
	int k;

	if (!e->running)
		return;
	if (e->fresh) { /* S(0) here, nothing held before it: the forces before the run were zero */
		e->fresh = 0;
		e->work_pJ = e->damped_pJ = e->min_balance_pJ = e->balance_pJ = 0;
		e->stored0_pJ = sat_add64(object_pJ(c, &c->out), e->water_pJ);
		e->stored_pJ = e->stored0_pJ;
		e->water0_pJ = e->water_pJ;
		e->ticks = e->controller_ticks = 0;
		for (h = 0; h < SWELL_CTL_PC_RING; h++)
			e->ring_cN[h] = e->pc_ring_cN[h] = 0;
	} else {
		/* W: the force the device held since the last tick times the way it went meanwhile; along the
		 * force law's axis the force sent pc_delay ticks before the last tick's (stream mode). The
		 * other axes carry no force of the force law: the last tick's. |pos| <= 300 mm on the wire */
		h = held_slot(c);
		for (k = 0; k < 3; k++)
			dw -= (k == ax ? (int64_t)e->ring_cN[h] * 10000 : (int64_t)e->force_uN[k]) *
				(e->pos_now_um[k] - e->pos_um[k]);
		dd = -(int64_t)e->pc_ring_cN[h] * 10000 * (e->pos_now_um[ax] - e->pos_um[ax]);
		e->work_pJ = sat_add64(e->work_pJ, dw);
		e->damped_pJ = sat_add64(e->damped_pJ, dd);
		e->stored_pJ = sat_add64(object_pJ(c, &c->out), e->water_pJ);
		e->balance_pJ = balance(e);
		if (e->balance_pJ < e->min_balance_pJ)
			e->min_balance_pJ = e->balance_pJ;
	}
	e->ticks++;
	/* what is sent from now on: this tick's force as the wire carries it, and the controller's part */
	for (k = 0; k < 3; k++) {
		e->pos_um[k] = e->pos_now_um[k];
		e->force_uN[k] = wire_uN(c, c->force_dev_uN[k]);
	}
	e->ring_head = (uint8_t)((e->ring_head + 1u) & (SWELL_CTL_PC_RING - 1u));
	e->ring_cN[e->ring_head] = ctl_force_cN(c, c->force_dev_uN[ax]);
	e->pc_ring_cN[e->ring_head] = ctl_to_cN(e->pc_uN[ax]);
}

enum swell_err swell_ctl_energy(const struct swell_ctl *c, struct swell_energy_account *out)
{
	const struct swell_ctl_energy_sums *e;

	if (!c || !out)
		return SWELL_EINVAL;
	e = &c->energy;
	out->work_uJ = pj_to_uj(e->work_pJ);
	out->stored_uJ = pj_to_uj(sat_add64(e->stored_pJ, -e->stored0_pJ));
	out->balance_uJ = pj_to_uj(balance(e));
	out->created_uJ = pj_to_uj(-e->min_balance_pJ);
	out->damped_uJ = pj_to_uj(e->damped_pJ);
	out->water_uJ = pj_to_uj(sat_add64(e->water_pJ, -e->water0_pJ));
	out->ticks = e->ticks;
	out->controller_ticks = e->controller_ticks;
	return SWELL_OK;
}
