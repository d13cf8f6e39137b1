/* The velocity form's reference kernel: one cell at a time, in int64, walls by mirrored indices. */
#include "wave_priv.h"

static int64_t h_at(const struct swell_wave *w, int i, int j)
{
	i = i < 0 ? 0 : i >= w->nx ? w->nx - 1 : i;
	j = j < 0 ? 0 : j >= w->ny ? w->ny - 1 : j;
	return w->h[(size_t)j * w->nx + (size_t)i];
}

void swell_wave_vel_ref(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any)
{
	static const int k[3][3] = { { 1, 2, 1 }, { 2, 4, 2 }, { 1, 2, 1 } };
	const int i0 = tx0 * SWELL_WAVE_TILE, i1 = tx1 * SWELL_WAVE_TILE < w->nx ? tx1 * SWELL_WAVE_TILE : w->nx;
	const int f = w->vel_frac;
	const int64_t c = (int64_t)w->e_eff << (f + 1);
	uint32_t sat = 0;
	int64_t total = 0, total_h = 0, dh;
	int i, di, dj;

	for (i = 0; i < tx1 - tx0; i++)
		any[i] = 0;
	for (i = i0; i < i1; i++) {
		const size_t a = (size_t)j * w->nx + (size_t)i;
		int64_t x = -16 * h_at(w, i, j), s;

		for (dj = -1; dj <= 1; dj++)
			for (di = -1; di <= 1; di++)
				x += k[dj + 1][di + 1] * h_at(w, i + di, j + dj);
		if (damp) { /* the sum toward half the kick: dissipative (damped, f = 0) */
			s = w->u[a] + ((x * c) >> 32);
			s += s + w->u[a] < 0;
		} else { /* to nearest, ties up */
			s = w->u[a] + ((x * c + ((int64_t)1 << 31)) >> 32);
		}
		if (s > SWELL_H_MAX || s < SWELL_H_MIN) {
			s = s > SWELL_H_MAX ? SWELL_H_MAX : SWELL_H_MIN;
			sat = 1;
		}
		if (damp) /* toward zero; q odd, so q s / 2^30 is never an integer for s != 0 */
			s = ((s * w->q) >> 30) + (s < 0);
		dh = f ? (s + ((int64_t)1 << (f - 1)) - (s < 0)) >> f : s; /* nearest, ties away from zero */
		w->u[a] = (int32_t)s;
		total += s;
		total_h += dh;
		any[(i - i0) / SWELL_WAVE_TILE] |= (int32_t)s;
	}
	w->saturations += sat;
	sum[0] += total;
	sum[1] += total_h;
}
