/* Non-inline parts of fixed.h. */
#include "swell/fixed.h"

/* 64 x 64 -> 128-bit product as two halves, from 32-bit partial products. */
static void mul_u64(uint64_t a, uint64_t b, uint64_t *hi, uint64_t *lo)
{
	uint64_t al = a & 0xffffffffu, ah = a >> 32;
	uint64_t bl = b & 0xffffffffu, bh = b >> 32;
	uint64_t ll = al * bl, lh = al * bh, hl = ah * bl, hh = ah * bh;
	uint64_t mid = (ll >> 32) + (lh & 0xffffffffu) + (hl & 0xffffffffu);

	*lo = (mid << 32) | (ll & 0xffffffffu);
	*hi = hh + (lh >> 32) + (hl >> 32) + (mid >> 32);
}

int swell_muldiv_u64(uint64_t a, uint64_t b, uint64_t c, uint64_t *out)
{
	uint64_t hi, lo, q = 0, r = 0;
	int bit;

	if (c == 0)
		return 0;
	mul_u64(a, b, &hi, &lo);
	if (hi >= c)
		return 0; /* quotient would need more than 64 bits */
	/* Restoring division of the 128-bit hi:lo by c, one bit at a time. */
	r = hi;
	for (bit = 63; bit >= 0; bit--) {
		uint64_t top = r >> 63;
		r = (r << 1) | ((lo >> bit) & 1u);
		if (top || r >= c) {
			r -= c;
			q |= (uint64_t)1 << bit;
		}
	}
	/* Round to nearest: compare the remainder with c/2 without overflowing. */
	if (r >= c - r) {
		if (q == UINT64_MAX)
			return 0;
		q++;
	}
	*out = q;
	return 1;
}
