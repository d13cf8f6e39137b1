/* Safety stage on every force output; see force_safety.h. */
#include "swell/force_safety.h"

#include <string.h>

#include "swell/pool.h"

enum swell_err swell_fsafety_check(const struct swell_fsafety_params *p)
{
	if (!p)
		return SWELL_EINVAL;
	if (p->gain < 0 || p->gain > SWELL_FSAFETY_MAX_GAIN)
		return SWELL_ERANGE;
	if (p->f_max_uN < 1 || p->f_max_uN > SWELL_FSAFETY_MAX_FORCE_UN)
		return SWELL_ERANGE;
	if (p->tick_hz < SWELL_TICK_HZ_MIN || p->tick_hz > SWELL_TICK_HZ_MAX)
		return SWELL_ERANGE;
	if (p->rate_uN_per_s < p->tick_hz)
		return SWELL_ERANGE;
	return SWELL_OK;
}

enum swell_err swell_fsafety_init(struct swell_fsafety *s, const struct swell_fsafety_params *p)
{
	if (s && swell_fsafety_check(p) == SWELL_OK)
		memset(s, 0, sizeof(*s)); /* a refused init leaves s as it was */
	return swell_fsafety_set(s, p);
}

enum swell_err swell_fsafety_set(struct swell_fsafety *s, const struct swell_fsafety_params *p)
{
	enum swell_err err;

	if (!s)
		return SWELL_EINVAL;
	err = swell_fsafety_check(p);
	if (err != SWELL_OK)
		return err;
	s->p = *p;
	s->step_uN = (int32_t)(p->rate_uN_per_s / p->tick_hz);
	return SWELL_OK;
}

int32_t swell_fsafety_apply(struct swell_fsafety *s, int32_t f_uN, int running)
{
	const int32_t fmax = (int32_t)s->p.f_max_uN;
	int32_t target, d;

	if (!running) {
		if (s->out_uN != 0)
			s->zeroed++;
		s->out_uN = 0;
		return 0;
	}
	target = swell_mul_q16_rn(f_uN, s->p.gain);
	if (target > fmax || target < -fmax) {
		target = swell_clamp(target, -fmax, fmax);
		s->force_limited++;
	}
	d = target - s->out_uN; /* both within +-1e9: no overflow */
	if (d > s->step_uN || d < -s->step_uN) {
		d = swell_clamp(d, -s->step_uN, s->step_uN);
		s->rate_limited++;
	}
	s->out_uN = swell_clamp(s->out_uN + d, -fmax, fmax);
	return s->out_uN;
}
