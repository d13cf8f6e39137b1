/* Effect mode: the effect set from the force law's state, its force, its messages (swell/effect.h). */
#include "swell/effect.h"

#include "swell/fixed.h"

/* x / d rounded to nearest, halves away from zero; d > 0. */
static int64_t div_rn(int64_t x, int64_t d)
{
	return x >= 0 ? (x + d / 2) / d : -((-x + d / 2) / d);
}

static int32_t clamp64(int64_t x, int32_t lo, int32_t hi)
{
	return x < lo ? lo : x > hi ? hi : (int32_t)x;
}

void swell_effect_from_body(struct swell_effect *e, const struct swell_body *b, const struct swell_body_out *out,
			    int32_t offset_z_um, uint32_t f_max_uN, uint32_t rate_uN_per_s)
{
	/* w in LSB (2^-16 mm) to 0.01 mm: x 100 / 2^16, rounded */
	const int64_t w_10um = div_rn((int64_t)out->surface_lsb * 100, 65536) - div_rn(offset_z_um, 10);
	/* b_max s, s = delta / H, in uN per mm/s = mN s/m, as the force law has it */
	const int64_t bs = div_rn((int64_t)b->p.damper_uN_per_mm_s * out->delta_lsb, b->h_lsb);

	e->surface_10um = clamp64(w_10um, -30000, 30000);
	e->h_10um = clamp64(div_rn((int64_t)b->p.h_um, 10), 1, 65535);
	e->uw_100ums = clamp64(div_rn(out->surface_um_s, 100), -30000, 30000);
	e->k_10mN_m = (uint32_t)clamp64(div_rn(b->k_q8, 2560), 0, 65535); /* uN/mm Q24.8 = mN/m x 256 */
	e->b_10mNs_m = (uint32_t)clamp64(div_rn(bs, 10), 0, 65535);
	e->bias_mN = clamp64(div_rn(b->gravity_uN, 1000), -8388607, 8388607);
	e->fmax_cN = (uint32_t)clamp64(f_max_uN / 10000u, 1, 25000); /* whole cN within the limit */
	e->rate_100mN_s = (uint32_t)clamp64(rate_uN_per_s / 100000u, 1, 65535);
}

int32_t swell_effect_force_uN(const struct swell_effect *e, int32_t z_10um, int32_t vz_100ums)
{
	const int64_t stretch = (int64_t)e->surface_10um - z_10um;
	const int64_t in = stretch < 0 ? 0 : stretch > e->h_10um ? e->h_10um : stretch;
	/* pull k (surface - z)+ less push k (surface - H - z)+ = k clamp(surface - z, 0, H), in 0.1 uN */
	const int64_t springs = div_rn((int64_t)e->k_10mN_m * in, 10);
	const int64_t damper = -(int64_t)e->b_10mNs_m * ((int64_t)vz_100ums - e->uw_100ums);

	return swell_sat_i64(springs + damper + (int64_t)e->bias_mN * 1000);
}

void swell_effect_encode(const struct swell_effect *e, uint8_t node, struct swell_msg m[3])
{
	m[0].type = SWELL_MSG_EFFECT_SPRING;
	m[1].type = SWELL_MSG_EFFECT_DAMPER;
	m[2].type = SWELL_MSG_EFFECT_LIMIT;
	m[0].node = m[1].node = m[2].node = node;
	m[0].u.effect_spring.surface_10um = (int16_t)e->surface_10um;
	m[0].u.effect_spring.uw_100ums = (int16_t)e->uw_100ums;
	m[0].u.effect_spring.k_10mN_m = (uint16_t)e->k_10mN_m;
	m[0].u.effect_spring.seq = e->seq;
	m[1].u.effect_damper.b_10mNs_m = (uint16_t)e->b_10mNs_m;
	m[1].u.effect_damper.bias_mN = e->bias_mN;
	m[1].u.effect_damper.h_10um = (uint16_t)e->h_10um;
	m[1].u.effect_damper.seq = e->seq;
	m[2].u.effect_limit.fmax_cN = (uint16_t)e->fmax_cN;
	m[2].u.effect_limit.rate_100mN_s = (uint16_t)e->rate_100mN_s;
	m[2].u.effect_limit.seq = e->seq;
}

/* Fills the part of *e that m carries; returns its bit, 0 for another message. */
static unsigned take(struct swell_effect *e, const struct swell_msg *m, uint8_t *seq)
{
	switch (m->type) {
	case SWELL_MSG_EFFECT_SPRING:
		e->surface_10um = m->u.effect_spring.surface_10um;
		e->uw_100ums = m->u.effect_spring.uw_100ums;
		e->k_10mN_m = m->u.effect_spring.k_10mN_m;
		*seq = m->u.effect_spring.seq;
		return 1;
	case SWELL_MSG_EFFECT_DAMPER:
		e->b_10mNs_m = m->u.effect_damper.b_10mNs_m;
		e->bias_mN = m->u.effect_damper.bias_mN;
		e->h_10um = m->u.effect_damper.h_10um;
		*seq = m->u.effect_damper.seq;
		return 2;
	case SWELL_MSG_EFFECT_LIMIT:
		e->fmax_cN = m->u.effect_limit.fmax_cN;
		e->rate_100mN_s = m->u.effect_limit.rate_100mN_s;
		*seq = m->u.effect_limit.seq;
		return 4;
	default:
		return 0;
	}
}

int swell_effect_recv(struct swell_effect_rx *r, const struct swell_msg *m, struct swell_effect *set)
{
	uint8_t seq = 0;
	const unsigned bit = take(&r->pend, m, &seq);

	if (!bit)
		return -1;
	if (!r->mask || seq != r->pend.seq) /* a part of a new set: the old one's parts are dropped */
		r->mask = 0;
	r->pend.seq = seq;
	r->mask |= bit;
	if (r->mask != 7u)
		return 0;
	*set = r->pend;
	r->mask = 0;
	return 1;
}
