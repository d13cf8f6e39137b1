/* The velocity form's fast kernel: one pass along a row segment with the column sums
 * h(j-1) + 2 h(j) + h(j+1) of the cells left, centre and right carried in registers, so that a cell
 * costs three loads of h, a handful of adds and shifts, the product and the momentum's load and
 * store. On ARMv7E-M: SMMLAR gives u + nearest(e_eff x / 2^31) in one instruction (with 2 e_eff as
 * operand, when it fits int32), SSAT #28 the saturation (the sticky Q flag, read once a segment) and
 * SMMUL the damping toward zero, as in the edge-flux kernel. Same bits as swell_wave_vel_ref. */
#include "swell/wave_vel.h"

#ifdef SWELL_WAVE_FIXED_NX
#define VEL_NX(w) SWELL_WAVE_FIXED_NX
#else
#define VEL_NX(w) ((w)->nx)
#endif

#if defined(__ARM_FEATURE_DSP) && defined(__thumb2__)
#include <arm_acle.h>
#define VEL_DSP 1
#else
#define VEL_DSP 0
#endif

static inline __attribute__((always_inline)) int32_t vel_cell(int32_t u, int32_t x, int32_t e, int32_t e2,
							     int32_t q, int damp, int dsp, uint32_t *sat)
{
	int32_t s;

#if VEL_DSP
	if (dsp) {
		int32_t r;

		(void)e;
		(void)sat;
		if (damp) { /* floor (SMMLA), then one toward zero when negative */
			__asm__("smmla %0, %1, %2, %3" : "=r"(s) : "r"(x), "r"(e2), "r"(u));
			s += (int32_t)((uint32_t)s >> 31);
		} else {
			__asm__("smmlar %0, %1, %2, %3" : "=r"(s) : "r"(x), "r"(e2), "r"(u));
		}
		s = __ssat(s, 28);
		if (damp) {
			__asm__("smmul %0, %1, %2" : "=r"(r) : "r"(s * 4), "r"(q));
			s = r - (s >> 31);
		}
		return s;
	}
#endif
	(void)e2;
	(void)dsp;
	if (damp) {
		s = u + (int32_t)(((int64_t)x * e) >> 31);
		s += s < 0;
	} else {
		s = u + (int32_t)(((int64_t)x * e + ((int64_t)1 << 30)) >> 31);
	}
	if (s > SWELL_H_MAX || s < SWELL_H_MIN) {
		s = s > SWELL_H_MAX ? SWELL_H_MAX : SWELL_H_MIN;
		*sat = 1;
	}
	if (damp)
		s = (int32_t)(((int64_t)s * q) >> 30) - (s >> 31);
	return s;
}

/* fixed: a whole tile (8 cells) away from the east wall, unrolled */
static inline __attribute__((always_inline)) int32_t vel_seg(struct swell_wave *w, int j, int i0, int i1,
							    int damp, int dsp, int fixed, int64_t *sum)
{
	const int nx = VEL_NX(w), n = fixed ? 8 : i1 - i0, east = fixed ? 0 : i1 == nx;
	const int32_t *restrict hc = w->h + (size_t)j * nx + i0;
	const int32_t *restrict hd = j > 0 ? hc - nx : hc;
	const int32_t *restrict hu = j + 1 < w->ny ? hc + nx : hc;
	int32_t *restrict u = w->u + (size_t)j * nx + i0;
	int32_t *restrict acc = w->acc + (size_t)j * nx + i0;
	const int32_t e = w->e_eff, e2 = (int32_t)((uint32_t)w->e_eff << 1), q = w->q;
	const int w0 = i0 > 0 ? -1 : 0, end = east ? n - 1 : n;
	int32_t c = hc[0], sl = hd[w0] + hu[w0] + 2 * hc[w0], sc = hd[0] + hu[0] + 2 * c, sr, cn, s;
	int32_t any = 0, tot = 0;
	uint32_t sat = 0;
	int k;

#if VEL_DSP
	if (dsp)
		__set_saturation_occurred(0);
#endif
#pragma GCC unroll 8
	for (k = 0; k < end; k++) {
		cn = hc[k + 1];
		sr = hd[k + 1] + hu[k + 1] + 2 * cn;
		s = vel_cell(u[k], sl + sr + 2 * sc - 16 * c, e, e2, q, damp, dsp, &sat);
		u[k] = s;
		acc[k] += s;
		tot += s;
		any |= s;
		sl = sc;
		sc = sr;
		c = cn;
	}
	if (east) { /* the mirrored column beyond the east wall is the last one */
		s = vel_cell(u[k], sl + 3 * sc - 16 * c, e, e2, q, damp, dsp, &sat);
		u[k] = s;
		acc[k] += s;
		tot += s;
		any |= s;
	}
#if VEL_DSP
	if (dsp)
		sat = (uint32_t)__saturation_occurred();
#endif
	w->saturations += sat;
	*sum += tot;
	return any;
}

int32_t swell_wave_vel_fused(struct swell_wave *w, int j, int i0, int i1, int damp, int64_t *sum)
{
	const int fixed = i1 == i0 + 8 && i1 < VEL_NX(w);
#if VEL_DSP
	const int dsp = w->e_eff < ((int32_t)1 << 30); /* 2 e_eff fits int32 */
#else
	const int dsp = 0;
#endif

	if (dsp) {
		if (fixed)
			return damp ? vel_seg(w, j, i0, i1, 1, 1, 1, sum) : vel_seg(w, j, i0, i1, 0, 1, 1, sum);
		return damp ? vel_seg(w, j, i0, i1, 1, 1, 0, sum) : vel_seg(w, j, i0, i1, 0, 1, 0, sum);
	}
	if (fixed)
		return damp ? vel_seg(w, j, i0, i1, 1, 0, 1, sum) : vel_seg(w, j, i0, i1, 0, 0, 1, sum);
	return damp ? vel_seg(w, j, i0, i1, 1, 0, 0, sum) : vel_seg(w, j, i0, i1, 0, 0, 0, sum);
}
