#include "can_filter.h"

/* 16-bit filter word: STID[10:0] << 5 | RTR << 4 | IDE << 3 | EXID[17:15]. */
#define F16(id) ((uint32_t)(id) << 5)
#define F16_MASK(m) (((uint32_t)(m) << 5) | (1u << 4) | (1u << 3))

static int spec_ok(const struct can_filter_spec *s)
{
	return s->id <= 0x7FF && s->mask <= 0x7FF && s->fifo <= 1 &&
		(s->kind == CAN_FILTER_EXACT || s->kind == CAN_FILTER_MASK);
}

static unsigned banks_needed(const struct can_filter_spec *s, unsigned n)
{
	unsigned exact[2] = { 0, 0 }, mask[2] = { 0, 0 }, i, total = 0, f;

	for (i = 0; i < n; i++) {
		if (s[i].kind == CAN_FILTER_EXACT)
			exact[s[i].fifo]++;
		else
			mask[s[i].fifo]++;
	}
	for (f = 0; f < 2; f++)
		total += (exact[f] + 3) / 4 + (mask[f] + 1) / 2;
	return total;
}

enum swell_err can_filter_plan(const struct can_filter_spec *specs, unsigned n, struct can_filter_bank *banks,
			       unsigned max_banks, unsigned *nbanks)
{
	unsigned i, f, kind, nb = 0;

	if ((!specs && n) || !banks || !nbanks)
		return SWELL_EINVAL;
	for (i = 0; i < n; i++)
		if (!spec_ok(&specs[i]))
			return SWELL_ERANGE;
	if (banks_needed(specs, n) > max_banks)
		return SWELL_ESIZE;
	for (f = 0; f < 2; f++) {
		for (kind = CAN_FILTER_EXACT; kind <= CAN_FILTER_MASK; kind++) {
			uint32_t w[4];
			unsigned per = kind == CAN_FILTER_EXACT ? 4 : 2, k = 0;

			for (i = 0; i <= n; i++) {
				int flush = i == n;

				if (!flush) {
					const struct can_filter_spec *s = &specs[i];

					if (s->fifo != f || s->kind != kind)
						continue;
					if (kind == CAN_FILTER_EXACT) {
						w[k++] = F16(s->id);
					} else {
						w[k++] = F16(s->id & s->mask);
						w[k++] = F16_MASK(s->mask);
					}
					flush = k == 4;
				}
				if (flush && k) {
					/* Unused slots repeat the last entry (id, or id and mask): harmless duplicates. */
					for (; k < 4; k++)
						w[k] = w[k - 4 / per];
					banks[nb].fr1 = w[0] | w[1] << 16;
					banks[nb].fr2 = w[2] | w[3] << 16;
					banks[nb].list_mode = kind == CAN_FILTER_EXACT;
					banks[nb].fifo = (uint8_t)f;
					nb++;
					k = 0;
				}
			}
		}
	}
	*nbanks = nb;
	return SWELL_OK;
}

int can_filter_match(const struct can_filter_bank *banks, unsigned nbanks, uint16_t id, int rtr, int ide,
		     unsigned *fifo)
{
	uint32_t x = F16(id & 0x7FFu) | (rtr ? 1u << 4 : 0) | (ide ? 1u << 3 : 0);
	unsigned pass, b;

	/* Equal scale: list mode before mask mode, then the lower bank number. */
	for (pass = 0; pass < 2; pass++) {
		for (b = 0; b < nbanks; b++) {
			const struct can_filter_bank *k = &banks[b];
			int hit;

			if (k->list_mode != (pass == 0))
				continue;
			if (k->list_mode)
				hit = x == (k->fr1 & 0xFFFFu) || x == k->fr1 >> 16 || x == (k->fr2 & 0xFFFFu) ||
					x == k->fr2 >> 16;
			else
				hit = ((x ^ k->fr1) & (k->fr1 >> 16) & 0xFFFFu) == 0 ||
					((x ^ k->fr2) & (k->fr2 >> 16) & 0xFFFFu) == 0;
			if (hit) {
				if (fifo)
					*fifo = k->fifo;
				return 1;
			}
		}
	}
	return 0;
}
