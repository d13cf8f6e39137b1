/* The velocity form's fast kernel: one pass along a run of awake tiles of a row with the column sums
 * h(j-1) + 2 h(j) + h(j+1) of the cells left, centre and right carried in registers, so that a cell
 * costs three loads of h, a handful of adds and shifts, the product and the momentum's load and
 * store (the heights' update is the driver's, one row behind). On ARMv7E-M: SMMLAR gives u + nearest(x C / 2^32) in one instruction (SMMUL and a range
 * test when damped), SSAT #28 the saturation (the sticky Q flag, read once a run) and SMMUL the
 * damping toward zero, as in the edge-flux kernel. Same bits as swell_wave_vel_ref. */
#include "wave_priv.h"

/* An image that fixes its usual width (SWELL_WAVE_FIXED_NX) gets the kernel twice: with the width as
 * a constant for grids of that width, and with w->nx for any other (a pool chosen at start-up). */
#ifdef SWELL_WAVE_FIXED_NX
#define VEL_NX(w, fixed) ((fixed) ? SWELL_WAVE_FIXED_NX : (w)->nx)
#define VEL_FIXED(w) ((w)->nx == SWELL_WAVE_FIXED_NX)
#else
#define VEL_NX(w, fixed) ((void)(fixed), (w)->nx)
#define VEL_FIXED(w) 0
#endif

#if defined(__ARM_FEATURE_DSP) && defined(__thumb2__)
#include <arm_acle.h>
#define VEL_DSP 1
#else
#define VEL_DSP 0
#endif

/* The new momentum of one cell from its momentum u and x = 2 L9 (wave_priv.h); c = e_eff 2^(f+1),
 * as int32 for the DSP path (it fits there) and as int64 (c64) for the portable one. */
static inline __attribute__((always_inline)) int32_t vel_cell(int32_t u, int32_t x, int32_t c, int64_t c64, int32_t f,
							      int32_t q, int damp, int dsp, uint32_t *sat)
{
	int32_t s;

#if VEL_DSP
	if (dsp) {
		int32_t r;

		(void)sat;
		(void)f;
		(void)c64;
		if (damp) { /* floor (SMMLA), then one up when below half the kick (s + u < 0) */
			__asm__("smmla %0, %1, %2, %3" : "=r"(s) : "r"(x), "r"(c), "r"(u));
			s += (int32_t)((uint32_t)(s + u) >> 31);
		} else {
			__asm__("smmlar %0, %1, %2, %3" : "=r"(s) : "r"(x), "r"(c), "r"(u));
		}
		s = __ssat(s, 28);
		if (damp) {
			__asm__("smmul %0, %1, %2" : "=r"(r) : "r"(s * 4), "r"(q));
			s = r - (s >> 31);
		}
		return s;
	}
#endif
	(void)dsp;
	(void)f;
	(void)c;
	if (damp) {
		s = u + (int32_t)(((int64_t)x * c64) >> 32);
		s += s + u < 0;
	} else {
		s = u + (int32_t)(((int64_t)x * c64 + ((int64_t)1 << 31)) >> 32);
	}
	if (s > SWELL_H_MAX || s < SWELL_H_MIN) {
		s = s > SWELL_H_MAX ? SWELL_H_MAX : SWELL_H_MIN;
		*sat = 1;
	}
	if (damp)
		s = (int32_t)(((int64_t)s * q) >> 30) - (s >> 31);
	return s;
}

/* One cell: the column sum of the cell's right neighbour column (sr, from its three heights; the
 * centre one is cn), the cell's value, its stores, and the register rotation. */
#define VEL_CELL(K, SR)                                                                        \
	do {                                                                                   \
		sr = (SR);                                                                     \
		s = vel_cell(u[K], sl + sr + 2 * sc - 16 * c, cf, c64, f, q, damp, dsp, &sat); \
		dh = damp ? s : (s + half + ((s >> 31) & fm)) >> f; /* damped: f = 0 */        \
		u[K] = s;                                                                      \
		tot += s;                                                                      \
		if (!damp) /* damped: dh = s, the same sum */                                  \
			tot_h += dh;                                                           \
		a_or |= s;                                                                     \
		sl = sc;                                                                       \
		sc = sr;                                                                       \
		c = cn;                                                                        \
	} while (0)

/* A run of awake tiles of row j: whole blocks of 8 cells unrolled, the rest one by one, the cell
 * at the east wall with its mirrored column. mid: a row with rows above and below (the row
 * pointers are then constant offsets of one pointer when the width is fixed). */
static inline __attribute__((always_inline)) void vel_run(struct swell_wave *w, int j, int tx0, int tx1, int damp,
							  int dsp, int mid, int fixed, int64_t *sum, int32_t *any)
{
	const int nx = VEL_NX(w, fixed), i0 = tx0 * 8, i1 = tx1 * 8 < nx ? tx1 * 8 : nx;
	const int east = i1 == nx, m = (i1 - i0) - east; /* cells whose right column exists */
	const int32_t *restrict hc = w->h + (size_t)j * nx + i0;
	const int32_t *restrict hd = mid ? hc - nx : j > 0 ? hc - nx : hc;
	const int32_t *restrict hu = mid ? hc + nx : j + 1 < w->ny ? hc + nx : hc;
	int32_t *restrict u = w->u + (size_t)j * nx + i0;
	const int32_t f = w->vel_frac, half = f ? 1 << (f - 1) : 0, fm = f ? -1 : 0, q = w->q; /* f 0: dh = s */
	const int64_t c64 = (int64_t)w->e_eff << (f + 1);
	const int32_t cf = dsp ? (int32_t)c64 : 0; /* fits int32 when dsp */
	const int w0 = i0 > 0 ? -1 : 0;
	int32_t c = hc[0], sl = hd[w0] + hu[w0] + 2 * hc[w0], sc = hd[0] + hu[0] + 2 * c, sr, cn, s;
	int32_t a_or, tot = 0, tot_h = 0, dh; /* the sums of at most 16 cells */
	int64_t run_tot = 0, run_tot_h = 0; /* the run's: up to 64 cells, beyond int32 */
	uint32_t sat = 0;
	int b, k;

#if VEL_DSP
	if (dsp)
		__set_saturation_occurred(0);
#endif
		/* a row with rows above and below in a grid of the fixed width: the three rows from one pointer
	 * with immediate offsets (fewer registers live in the unrolled block) */
#define VEL_DOWN(K) (mid && fixed ? hc[(K)-nx] : hd[K])
#define VEL_UP(K) (mid && fixed ? hc[(K) + nx] : hu[K])
	for (b = 0; b < m / 8; b++) {
		a_or = 0;
#pragma GCC unroll 8
		for (k = 0; k < 8; k++) {
			cn = hc[k + 1];
			VEL_CELL(k, VEL_DOWN(k + 1) + VEL_UP(k + 1) + 2 * cn);
		}
		any[b] = a_or;
		if (b & 1) { /* 16 cells of int28 still fit int32 */
			run_tot += tot;
			run_tot_h += tot_h;
			tot = tot_h = 0;
		}
		hc += 8;
		if (!(mid && fixed)) {
			hd += 8;
			hu += 8;
		}
		u += 8;
	}
	a_or = 0;
	if (east && m % 8 == 7) { /* a whole last tile at the east wall (widths of whole tiles): unrolled too */
#pragma GCC unroll 8
		for (k = 0; k < 7; k++) {
			cn = hc[k + 1];
			VEL_CELL(k, VEL_DOWN(k + 1) + VEL_UP(k + 1) + 2 * cn);
		}
		cn = c; /* the mirrored column beyond the east wall is the last one */
		VEL_CELL(7, sc);
	} else {
		for (k = 0; k < m % 8; k++) {
			cn = hc[k + 1];
			VEL_CELL(k, VEL_DOWN(k + 1) + VEL_UP(k + 1) + 2 * cn);
		}
		if (east) {
			cn = c;
			VEL_CELL(k, sc);
		}
	}
	if (m % 8 || east)
		any[m / 8] = a_or;
#if VEL_DSP
	if (dsp)
		sat = (uint32_t)__saturation_occurred();
#endif
	w->saturations += sat;
	run_tot += tot;
	sum[0] += run_tot;
	sum[1] += damp ? run_tot : run_tot_h + tot_h;
}

#undef VEL_DOWN
#undef VEL_UP

static inline __attribute__((always_inline)) void vel_rows(struct swell_wave *w, int j, int tx0, int tx1, int damp,
							   int64_t sum[2], int32_t *any, int fixed)
{
	const int mid = j > 0 && j + 1 < w->ny;
#if VEL_DSP
	const int dsp = ((int64_t)w->e_eff << (w->vel_frac + 1)) <= INT32_MAX; /* the coefficient fits */
#else
	const int dsp = 0;
#endif

	if (dsp) {
		if (mid)
			damp ? vel_run(w, j, tx0, tx1, 1, 1, 1, fixed, sum, any)
			     : vel_run(w, j, tx0, tx1, 0, 1, 1, fixed, sum, any);
		else
			damp ? vel_run(w, j, tx0, tx1, 1, 1, 0, fixed, sum, any)
			     : vel_run(w, j, tx0, tx1, 0, 1, 0, fixed, sum, any);
		return;
	}
	if (mid)
		damp ? vel_run(w, j, tx0, tx1, 1, 0, 1, fixed, sum, any)
		     : vel_run(w, j, tx0, tx1, 0, 0, 1, fixed, sum, any);
	else
		damp ? vel_run(w, j, tx0, tx1, 1, 0, 0, fixed, sum, any)
		     : vel_run(w, j, tx0, tx1, 0, 0, 0, fixed, sum, any);
}

void swell_wave_vel_fused(struct swell_wave *w, int j, int tx0, int tx1, int damp, int64_t sum[2], int32_t *any)
{
	if (VEL_FIXED(w))
		vel_rows(w, j, tx0, tx1, damp, sum, any, 1);
	else
		vel_rows(w, j, tx0, tx1, damp, sum, any, 0);
}
