/* ef32's row kernels (ef32.h): one a file (ef32_ref.c, ef32_fused.c, ef32_avx2.c), called by ef32.c
 * for the edges owned by cells [i0, i1) of row j (i0 a multiple of 8): E edges, and N, NE, NW edges
 * up to row j+1 (none for the top row). Each returns non-zero if any new flow is non-zero; all give
 * the same bits. */
#ifndef SWELL_EF32_PRIV_H
#define SWELL_EF32_PRIV_H

#include <stdint.h>

#include "ef32.h"
#include "wave_priv.h"

/* The solver's tile flags and sleeping (wave_priv.h, T_*), and two bits of ef32's own. DIRTY: the
 * step in progress may have written acc in this tile. DIRTY_PREV: the same for the last finished
 * step, whose acc is now v. */
#define T_DIRTY 32u
#define T_DIRTY_PREV 64u

/* The flows of cell (i, j) start at this word; the four kinds are 8 words apart. */
#define FE 0
#define FN 8
#define FNE 16
#define FNW 24

static inline int32_t *flows_at(const struct ef32 *w, int i, int j)
{
	return w->f + 32 * ((size_t)j * w->tiles_x + (size_t)i / SWELL_WAVE_TILE) + i % SWELL_WAVE_TILE;
}

/* Bounds that make every intermediate fit int32 (checked by the tests with extreme fields):
 * |h| <= 2^27 so |dh| < 2^28 and |4 dh| < 2^30; c <= 1.5 * 2^30 so |c dh| / 2^30 < 1.5 * 2^28;
 * |f| <= 2^27 so |s| < 2^27 + 1.5 * 2^28 = 2^29 and |4 s| < 2^31. */
static inline int32_t sat28(int32_t x, uint32_t *sat)
{
	if (x > SWELL_H_MAX || x < SWELL_H_MIN) {
		*sat = 1;
		return x > SWELL_H_MAX ? SWELL_H_MAX : SWELL_H_MIN;
	}
	return x;
}

/* THE definition of one edge: s = f + round_nearest(c dh / 2^30), ties up; damped:
 * s = round_toward_zero(q s / 2^30), which is floor + (s < 0) because q is odd; then saturated. */
static inline int32_t flow_ref(int32_t f, int32_t dh, q30_t c, q30_t q, int damp, uint32_t *sat)
{
	int32_t s = f + (int32_t)(((int64_t)dh * c + ((int64_t)1 << 29)) >> 30);

	if (damp)
		s = (int32_t)(((int64_t)s * q) >> 30) - (s >> 31);
	return sat28(s, sat);
}

int32_t ef32_kernel_ref(struct ef32 *w, int j, int i0, int i1, int damp);
int32_t ef32_kernel_fused(struct ef32 *w, int j, int i0, int i1, int damp);
#if SWELL_WAVE_AVX2
int32_t ef32_kernel_avx2(struct ef32 *w, int j, int i0, int i1, int damp);
#endif

#endif
