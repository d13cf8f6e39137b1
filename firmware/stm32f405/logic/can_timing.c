#include "can_timing.h"

static uint32_t absdiff(uint32_t a, uint32_t b)
{
	return a > b ? a - b : b - a;
}

enum swell_err can_timing_compute(uint32_t clk_hz, uint32_t bitrate, uint16_t want_sp_permille, struct can_timing *t)
{
	struct can_timing best = { 0 };
	uint32_t best_err = UINT32_MAX, tq;

	if (!t)
		return SWELL_EINVAL;
	if (!clk_hz || !bitrate || !want_sp_permille || want_sp_permille >= 1000)
		return SWELL_ERANGE;
	for (tq = 25; tq >= 8; tq--) {
		uint64_t per_brp = (uint64_t)bitrate * tq;
		uint32_t brp, sp_q, ts1, ts2, sp, err;

		if (clk_hz % per_brp)
			continue;
		brp = (uint32_t)(clk_hz / per_brp);
		if (brp < 1 || brp > 1024)
			continue;
		sp_q = (want_sp_permille * tq + 500) / 1000; /* quanta up to the sample point */
		ts1 = sp_q > 1 ? sp_q - 1 : 1;
		if (ts1 > 16)
			ts1 = 16;
		if (tq - 1 - ts1 > 8)
			ts1 = tq - 1 - 8;
		if (ts1 > tq - 2)
			ts1 = tq - 2;
		ts2 = tq - 1 - ts1;
		if (ts1 < 1 || ts1 > 16 || ts2 < 1 || ts2 > 8)
			continue;
		sp = (1000 * (1 + ts1) + tq / 2) / tq;
		err = absdiff(sp, want_sp_permille);
		if (err < best_err) { /* strict: at equal error the larger tq (seen first) stays */
			best_err = err;
			best.brp = (uint16_t)brp;
			best.ts1 = (uint8_t)ts1;
			best.ts2 = (uint8_t)ts2;
			best.sjw = (uint8_t)(ts2 < 4 ? ts2 : 4);
			best.tq_per_bit = (uint8_t)tq;
			best.sample_permille = (uint16_t)sp;
		}
	}
	if (best_err == UINT32_MAX)
		return SWELL_ERANGE;
	*t = best;
	return SWELL_OK;
}

uint32_t can_timing_btr(const struct can_timing *t)
{
	return ((uint32_t)(t->brp - 1u) & 0x3FFu) | ((uint32_t)(t->ts1 - 1u) & 0xFu) << 16 |
		((uint32_t)(t->ts2 - 1u) & 0x7u) << 20 | ((uint32_t)(t->sjw - 1u) & 0x3u) << 24;
}
