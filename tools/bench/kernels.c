/* swell-bench kernels; see kernels.h. Host-only benchmark code. */
#include "kernels.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "wave_priv.h"

__extension__ typedef __int128 i128;

enum rnd {
	RND_FLOOR,
	RND_NEAREST,
	RND_ZERO
};

static const struct {
	const char *name;
	size_t bytes; /* per cell, between steps, scratch included */
	int fixed;
} impl_info[BENCH_IMPL_COUNT] = {
	[BENCH_EF32] = { "ef32", 7 * 4, 1 },       [BENCH_VELOCITY] = { "velocity", 2 * 4, 1 },
	[BENCH_VEL_REF] = { "vel-ref", 2 * 4, 1 }, [BENCH_VEL_FUSED] = { "vel-fused", 2 * 4, 1 },
	[BENCH_EF16] = { "ef16", 5 * 2 + 4, 1 },   [BENCH_TL32_FLOOR] = { "tl32-floor", 3 * 4, 1 },
	[BENCH_TL32_RN] = { "tl32-rn", 3 * 4, 1 }, [BENCH_TL32_RZ] = { "tl32-rz", 3 * 4, 1 },
	[BENCH_TL16_RN] = { "tl16-rn", 3 * 2, 1 }, [BENCH_F32] = { "f32", 3 * 4, 0 },
	[BENCH_F64] = { "f64", 3 * 8, 0 },
};

#define H16_FRAC 10
#define H16_MAX 32767

const char *bench_impl_name(enum bench_impl impl)
{
	return (unsigned)impl < BENCH_IMPL_COUNT ? impl_info[impl].name : "?";
}

enum bench_impl bench_impl_parse(const char *name)
{
	int k;

	for (k = 0; k < BENCH_IMPL_COUNT; k++)
		if (!strcmp(name, impl_info[k].name))
			return (enum bench_impl)k;
	return BENCH_IMPL_COUNT;
}

size_t bench_impl_bytes_per_cell(enum bench_impl impl)
{
	return (unsigned)impl < BENCH_IMPL_COUNT ? impl_info[impl].bytes : 0;
}

int bench_impl_is_fixed(enum bench_impl impl)
{
	return (unsigned)impl < BENCH_IMPL_COUNT && impl_info[impl].fixed;
}

int bench_impl_velocity(enum bench_impl impl)
{
	return impl == BENCH_VELOCITY || impl == BENCH_VEL_REF || impl == BENCH_VEL_FUSED;
}

int bench_impl_wave(enum bench_impl impl)
{
	return impl == BENCH_EF32 || bench_impl_velocity(impl);
}

/* x / 2^s with the given rounding; s >= 1. */
static inline int64_t rshift(int64_t x, int s, enum rnd mode)
{
	switch (mode) {
	case RND_FLOOR:
		return x >> s;
	case RND_NEAREST:
		return (x + ((int64_t)1 << (s - 1))) >> s;
	case RND_ZERO:
	default:
		return (x + (x < 0 ? ((int64_t)1 << s) - 1 : 0)) >> s;
	}
}

static q30_t q30_of(double x)
{
	return (q30_t)llround(x * (double)SWELL_Q30_ONE);
}

static void set_coeffs(struct bench_field *f, q30_t e_eff, q30_t q)
{
	f->e_eff_q30 = e_eff;
	f->q_q30 = q;
	f->e_eff = (double)e_eff / SWELL_Q30_ONE;
	f->q = (double)q / SWELL_Q30_ONE;
	f->c_1 = e_eff;
	f->c_half = e_eff / 2;
	f->c_wall = e_eff + e_eff / 2;
}

enum swell_err bench_field_init(struct bench_field *f, enum bench_impl impl, int nx, int ny, double e, double t,
				enum swell_stencil stencil)
{
	struct swell_wave_params p;
	size_t n, np;
	enum swell_err err;

	if (!f || (unsigned)impl >= BENCH_IMPL_COUNT)
		return SWELL_EINVAL;
	if (nx < SWELL_WAVE_MIN_SIDE || ny < SWELL_WAVE_MIN_SIDE || nx > SWELL_WAVE_MAX_SIDE ||
	    ny > SWELL_WAVE_MAX_SIDE)
		return SWELL_ESIZE;
	if (!(e > 0 && e < 2) || !(t >= 0 && t < 1))
		return SWELL_ERANGE;
	p.e = q30_of(e);
	p.damping = q30_of(t);
	p.stencil = stencil;
	err = swell_wave_check(&p);
	if (err != SWELL_OK)
		return err;

	memset(f, 0, sizeof(*f));
	f->impl = impl;
	f->nx = nx;
	f->ny = ny;
	f->px = nx + 2;
	n = (size_t)nx * ny;
	np = (size_t)(nx + 2) * (ny + 2);
	/* the wave forms' own words; ef16 its bytes a cell; the three-level kernels theirs a padded cell */
	f->mem = calloc(impl == BENCH_EF32                  ? EF32_WORDS(nx, ny) * sizeof(int32_t)
				: bench_impl_velocity(impl) ? SWELL_WAVE_WORDS(nx, ny) * sizeof(int32_t)
							    : impl_info[impl].bytes * (impl == BENCH_EF16 ? n : np),
			1);
	if (!f->mem)
		return SWELL_ESIZE;
	switch (impl) {
	case BENCH_EF32:
		err = ef32_init(&f->ef, (uint16_t)nx, (uint16_t)ny, f->mem, EF32_WORDS(nx, ny), &p);
		if (err == SWELL_OK)
			set_coeffs(f, f->ef.e_eff, f->ef.q);
		break;
	case BENCH_VELOCITY:
	case BENCH_VEL_REF:
	case BENCH_VEL_FUSED:
		err = swell_wave_init(&f->w, (uint16_t)nx, (uint16_t)ny, f->mem, SWELL_WAVE_WORDS(nx, ny), &p);
		if (err == SWELL_OK && impl != BENCH_VELOCITY)
			err = swell_wave_set_kernel(&f->w,
						    impl == BENCH_VEL_REF ? SWELL_KERNEL_REF : SWELL_KERNEL_FUSED);
		if (err == SWELL_OK)
			set_coeffs(f, f->w.e_eff, f->w.q);
		break;
	case BENCH_EF16:
		f->v32 = f->mem;
		f->h16 = (int16_t *)(f->v32 + n);
		f->fe16 = f->h16 + n;
		f->fn16 = f->fe16 + n;
		f->fne16 = f->fn16 + n;
		f->fnw16 = f->fne16 + n;
		break;
	case BENCH_TL32_FLOOR:
	case BENCH_TL32_RN:
	case BENCH_TL32_RZ:
		f->h32 = f->mem;
		f->hp32 = f->h32 + np;
		f->hn32 = f->hp32 + np;
		break;
	case BENCH_TL16_RN:
		f->h16 = f->mem;
		f->hp16 = f->h16 + np;
		f->hn16 = f->hp16 + np;
		break;
	case BENCH_F32:
		f->hf = f->mem;
		f->hpf = f->hf + np;
		f->hnf = f->hpf + np;
		break;
	case BENCH_F64:
	default:
		f->hd = f->mem;
		f->hpd = f->hd + np;
		f->hnd = f->hpd + np;
		break;
	}
	if (err != SWELL_OK) {
		free(f->mem);
		return err;
	}
	if (!bench_impl_wave(impl)) {
		/* the same quantised coefficients as wave.c */
		q30_t ee = stencil == SWELL_STENCIL_CALIBRATED ? p.e / 2 : p.e;

		set_coeffs(f, ee & ~(q30_t)1, SWELL_Q30_ONE - p.damping);
	}
	if (impl == BENCH_F32 || impl == BENCH_F64) {
		/* float kernels use the unquantised coefficients */
		f->e_eff = stencil == SWELL_STENCIL_CALIBRATED ? e / 2 : e;
		f->q = 1.0 - t;
	}
	f->e_eff_f = (float)f->e_eff;
	f->q_f = (float)f->q;
	if (impl == BENCH_F32) {
		f->e_eff = f->e_eff_f; /* what the float32 kernel really multiplies by */
		f->q = f->q_f;
	}
	f->lsb_mm = (impl == BENCH_EF16 || impl == BENCH_TL16_RN) ? 1.0 / (1 << H16_FRAC) : 1.0 / SWELL_H_ONE_MM;
	f->h_max = impl == BENCH_EF16 || impl == BENCH_TL16_RN ? H16_MAX
		: bench_impl_velocity(impl)                    ? SWELL_HV_MAX
		: bench_impl_is_fixed(impl)                    ? SWELL_H_MAX
							       : 0;
	return SWELL_OK;
}

void bench_field_free(struct bench_field *f)
{
	if (f) {
		free(f->mem);
		f->mem = NULL;
	}
}

enum swell_err bench_field_force(struct bench_field *f, q30_t e_eff, q30_t q)
{
	if (!f || e_eff <= 0 || q <= 0 || q > SWELL_Q30_ONE)
		return SWELL_ERANGE;
	if ((int64_t)e_eff + e_eff / 2 > INT32_MAX)
		return SWELL_ERANGE;
	e_eff &= ~(q30_t)1;
	set_coeffs(f, e_eff, q);
	/* Bench-only: the solver's private coefficients, to run it outside the validated region. No
	 * controller code may do this; swell_wave_set_params refuses such values. */
	if (bench_impl_velocity(f->impl))
		swell_wave_force_coeffs(&f->w, e_eff, q);
	if (f->impl == BENCH_EF32)
		ef32_force(&f->ef, e_eff, q);
	f->e_eff_f = (float)f->e_eff;
	f->q_f = (float)f->q;
	return SWELL_OK;
}

static int32_t sat_count(struct bench_field *f, int64_t x, int32_t max)
{
	if (x > max || x < -max) {
		f->saturations++;
		return x > 0 ? max : -max;
	}
	return (int32_t)x;
}

static size_t pidx(const struct bench_field *f, int i, int j)
{
	return (size_t)(j + 1) * f->px + (i + 1);
}

void bench_field_set_mm(struct bench_field *f, const double *h_mm)
{
	int i, j;

	for (j = 0; j < f->ny; j++) {
		for (i = 0; i < f->nx; i++) {
			double x = h_mm[j * f->nx + i];
			size_t a = (size_t)j * f->nx + i, k = pidx(f, i, j);
			int64_t r = f->h_max ? llround(x / f->lsb_mm) : 0;
			int32_t s = f->h_max ? (r > f->h_max ? f->h_max : (r < -f->h_max ? -f->h_max : (int32_t)r)) : 0;

			switch (f->impl) {
			case BENCH_EF32:
				f->ef.h[a] = s;
				break;
			case BENCH_VELOCITY:
			case BENCH_VEL_REF:
			case BENCH_VEL_FUSED:
				f->w.h[a] = s;
				break;
			case BENCH_EF16:
				f->h16[a] = (int16_t)s;
				break;
			case BENCH_TL32_FLOOR:
			case BENCH_TL32_RN:
			case BENCH_TL32_RZ:
				f->h32[k] = f->hp32[k] = s;
				break;
			case BENCH_TL16_RN:
				f->h16[k] = f->hp16[k] = (int16_t)s;
				break;
			case BENCH_F32:
				f->hf[k] = f->hpf[k] = (float)x;
				break;
			default:
				f->hd[k] = f->hpd[k] = x;
				break;
			}
		}
	}
	if (bench_impl_velocity(f->impl))
		swell_wave_rest(&f->w);
	if (f->impl == BENCH_EF32)
		ef32_rest(&f->ef);
	if (f->impl == BENCH_EF16) {
		size_t n = (size_t)f->nx * f->ny;

		memset(f->v32, 0, n * sizeof(int32_t));
		memset(f->fe16, 0, 4 * n * sizeof(int16_t));
	}
}

/* Height of cell (i, j) at h(n) (prev = 0) or h(n-1) (prev = 1), in LSB (float kernels: in
 * units of lsb_mm). */
static double cell_lsb(const struct bench_field *f, int i, int j, int prev)
{
	size_t a = (size_t)j * f->nx + i, k = pidx(f, i, j);

	switch (f->impl) {
	case BENCH_EF32:
		return prev ? (double)f->ef.h[a] - f->ef.v[a] : f->ef.h[a];
	case BENCH_VELOCITY:
	case BENCH_VEL_REF:
	case BENCH_VEL_FUSED: /* h(n-1) as the solver's own change gives it (no v kept: swell/wave.h) */
		return prev ? (double)swell_wave_h(&f->w, a) - swell_wave_dh(&f->w, a) : swell_wave_h(&f->w, a);
	case BENCH_EF16:
		return prev ? (double)f->h16[a] - f->v32[a] : f->h16[a];
	case BENCH_TL32_FLOOR:
	case BENCH_TL32_RN:
	case BENCH_TL32_RZ:
		return prev ? f->hp32[k] : f->h32[k];
	case BENCH_TL16_RN:
		return prev ? f->hp16[k] : f->h16[k];
	case BENCH_F32:
		return (prev ? f->hpf[k] : f->hf[k]) / f->lsb_mm;
	default:
		return (prev ? f->hpd[k] : f->hd[k]) / f->lsb_mm;
	}
}

void bench_field_get_mm(const struct bench_field *f, double *h_mm)
{
	int i, j;

	for (j = 0; j < f->ny; j++)
		for (i = 0; i < f->nx; i++)
			h_mm[j * f->nx + i] = cell_lsb(f, i, j, 0) * f->lsb_mm;
}

void bench_field_ref(const struct bench_field *f, const double *h_mm, struct swell_wave_ref *r, double *storage)
{
	const int n = f->nx * f->ny;
	int a;

	r->nx = f->nx;
	r->ny = f->ny;
	r->h = storage;
	r->hp = storage + n;
	r->next = storage + 2 * n;
	r->e_eff = f->e_eff;
	r->q = f->q;
	r->steps = 0;
	for (a = 0; a < n; a++)
		r->h[a] = r->hp[a] = h_mm[a];
}

void bench_field_add_lsb(struct bench_field *f, int i, int j, int32_t k)
{
	size_t a = (size_t)j * f->nx + i, p = pidx(f, i, j);

	switch (f->impl) {
	case BENCH_EF32:
		f->ef.h[a] = sat_count(f, (int64_t)f->ef.h[a] + k, f->h_max);
		ef32_touched(&f->ef, i, j);
		break;
	case BENCH_VELOCITY:
	case BENCH_VEL_REF:
	case BENCH_VEL_FUSED: /* h(n) moves, the momentum does not: an impulse of volume, not of motion */
		f->w.h[a] = sat_count(f, (int64_t)f->w.h[a] + k, f->h_max);
		swell_wave_touched(&f->w, i, j); /* written from outside: its tile must wake */
		break;
	case BENCH_EF16:
		f->h16[a] = (int16_t)sat_count(f, (int64_t)f->h16[a] + k, H16_MAX);
		break;
	case BENCH_TL32_FLOOR:
	case BENCH_TL32_RN:
	case BENCH_TL32_RZ:
		f->h32[p] = sat_count(f, (int64_t)f->h32[p] + k, SWELL_H_MAX);
		break;
	case BENCH_TL16_RN:
		f->h16[p] = (int16_t)sat_count(f, (int64_t)f->h16[p] + k, H16_MAX);
		break;
	case BENCH_F32:
		f->hf[p] += (float)(k * f->lsb_mm);
		break;
	default:
		f->hd[p] += k * f->lsb_mm;
		break;
	}
}

/* Mirror the edge cells into the ghost ring of a padded array. */
#define FILL_GHOSTS(T, h, nx, ny, px)                                                                         \
	do {                                                                                                  \
		int j_;                                                                                       \
		for (j_ = 1; j_ <= (ny); j_++) {                                                              \
			(h)[j_ * (px)] = (h)[j_ * (px) + 1];                                                  \
			(h)[j_ * (px) + (nx) + 1] = (h)[j_ * (px) + (nx)];                                    \
		}                                                                                             \
		memcpy((h), (h) + (px), (size_t)(px) * sizeof(T));                                            \
		memcpy((h) + (size_t)((ny) + 1) * (px), (h) + (size_t)(ny) * (px), (size_t)(px) * sizeof(T)); \
	} while (0)

/* Three-level eq. (1) in fixed point: 2 L9 exact in int64, then e_eff (2 L9) / 2^31 and
 * (1-t) d / 2^30 rounded by `mode`, heights saturated to +-max. */
#define DEFINE_TL(fname, T, mode)                                                                                      \
	static void fname(struct bench_field *f, T **hh, T **hhp, T **hhn, int32_t max)                                \
	{                                                                                                              \
		const int nx = f->nx, ny = f->ny, px = f->px;                                                          \
		const int64_t e = f->e_eff_q30, q = f->q_q30;                                                          \
		T *h = *hh, *hp = *hhp, *hn = *hhn;                                                                    \
		int i, j;                                                                                              \
                                                                                                                       \
		FILL_GHOSTS(T, h, nx, ny, px);                                                                         \
		for (j = 1; j <= ny; j++) {                                                                            \
			for (i = 1; i <= nx; i++) {                                                                    \
				const int k = j * px + i;                                                              \
				const int64_t c = h[k];                                                                \
				int64_t orth = (int64_t)h[k - 1] + h[k + 1] + h[k - px] + h[k + px];                   \
				int64_t diag = (int64_t)h[k - px - 1] + h[k - px + 1] + h[k + px - 1] + h[k + px + 1]; \
				int64_t l2 = 2 * orth + diag - 12 * c;                                                 \
				int64_t d = c - hp[k] + rshift(e * l2, 31, mode);                                      \
				int64_t x;                                                                             \
                                                                                                                       \
				if (q != SWELL_Q30_ONE)                                                                \
					d = rshift(q * d, 30, mode);                                                   \
				x = c + d;                                                                             \
				if (x > max || x < -max) {                                                             \
					x = x > 0 ? max : -max;                                                        \
					f->saturations++;                                                              \
				}                                                                                      \
				hn[k] = (T)x;                                                                          \
			}                                                                                              \
		}                                                                                                      \
		*hhp = h;                                                                                              \
		*hh = hn;                                                                                              \
		*hhn = hp;                                                                                             \
	}

DEFINE_TL(tl32_floor, int32_t, RND_FLOOR)
DEFINE_TL(tl32_rn, int32_t, RND_NEAREST)
DEFINE_TL(tl32_rz, int32_t, RND_ZERO)
DEFINE_TL(tl16_rn, int16_t, RND_NEAREST)

/* The plain float loop: the baseline every cost is divided by. */
#define DEFINE_FLOAT(fname, T)                                                                                     \
	static void fname(struct bench_field *f, T **hh, T **hhp, T **hhn, T e, T q)                               \
	{                                                                                                          \
		const int nx = f->nx, ny = f->ny, px = f->px;                                                      \
		T *h = *hh, *hp = *hhp, *hn = *hhn;                                                                \
		int i, j;                                                                                          \
                                                                                                                   \
		FILL_GHOSTS(T, h, nx, ny, px);                                                                     \
		for (j = 1; j <= ny; j++) {                                                                        \
			for (i = 1; i <= nx; i++) {                                                                \
				const int k = j * px + i;                                                          \
				const T c = h[k];                                                                  \
				const T l9 = h[k - 1] + h[k + 1] + h[k - px] + h[k + px] +                         \
					(T)0.5 * (h[k - px - 1] + h[k - px + 1] + h[k + px - 1] + h[k + px + 1]) - \
					(T)6 * c;                                                                  \
				hn[k] = c + q * (c - hp[k] + e * l9);                                              \
			}                                                                                          \
		}                                                                                                  \
		*hhp = h;                                                                                          \
		*hh = hn;                                                                                          \
		*hhn = hp;                                                                                         \
	}

DEFINE_FLOAT(step_f32, float)
DEFINE_FLOAT(step_f64, double)

/* Edge-flux with int16 heights and flows: wave.c's scheme, own code, narrower storage. */
static inline void edge16(struct bench_field *f, int16_t *fl, int a, int b, q30_t c)
{
	int32_t s = *fl + (int32_t)rshift((int64_t)(f->h16[b] - f->h16[a]) * c, 30, RND_NEAREST);

	if (f->q_q30 != SWELL_Q30_ONE)
		s = (int32_t)rshift((int64_t)s * f->q_q30, 30, RND_ZERO);
	if (s > H16_MAX || s < -H16_MAX) {
		s = s > 0 ? H16_MAX : -H16_MAX;
		f->saturations++;
	}
	*fl = (int16_t)s;
	f->v32[a] += s;
	f->v32[b] -= s;
}

static void step_ef16(struct bench_field *f)
{
	const int nx = f->nx, ny = f->ny, n = nx * ny;
	int i, j, a;

	memset(f->v32, 0, (size_t)n * sizeof(int32_t));
	for (j = 0; j < ny; j++) {
		const q30_t ce = (j == 0 || j == ny - 1) ? f->c_wall : f->c_1;
		const int up = j + 1 < ny;

		for (i = 0; i < nx; i++) {
			a = j * nx + i;
			if (i + 1 < nx)
				edge16(f, &f->fe16[a], a, a + 1, ce);
			if (!up)
				continue;
			edge16(f, &f->fn16[a], a, a + nx, (i == 0 || i == nx - 1) ? f->c_wall : f->c_1);
			if (i + 1 < nx)
				edge16(f, &f->fne16[a], a, a + nx + 1, f->c_half);
			if (i > 0)
				edge16(f, &f->fnw16[a], a, a + nx - 1, f->c_half);
		}
	}
	for (a = 0; a < n; a++)
		f->h16[a] = (int16_t)sat_count(f, (int64_t)f->h16[a] + f->v32[a], H16_MAX);
}

void bench_field_step(struct bench_field *f)
{
	switch (f->impl) {
	case BENCH_EF32:
		ef32_step(&f->ef);
		f->saturations = f->ef.saturations;
		break;
	case BENCH_VELOCITY:
	case BENCH_VEL_REF:
	case BENCH_VEL_FUSED:
		swell_wave_step(&f->w);
		f->saturations = f->w.saturations;
		break;
	case BENCH_EF16:
		step_ef16(f);
		break;
	case BENCH_TL32_FLOOR:
		tl32_floor(f, &f->h32, &f->hp32, &f->hn32, SWELL_H_MAX);
		break;
	case BENCH_TL32_RN:
		tl32_rn(f, &f->h32, &f->hp32, &f->hn32, SWELL_H_MAX);
		break;
	case BENCH_TL32_RZ:
		tl32_rz(f, &f->h32, &f->hp32, &f->hn32, SWELL_H_MAX);
		break;
	case BENCH_TL16_RN:
		tl16_rn(f, &f->h16, &f->hp16, &f->hn16, H16_MAX);
		break;
	case BENCH_F32:
		step_f32(f, &f->hf, &f->hpf, &f->hnf, f->e_eff_f, f->q_f);
		break;
	default:
		step_f64(f, &f->hd, &f->hpd, &f->hnd, f->e_eff, f->q);
		break;
	}
}

void bench_field_steps(struct bench_field *f, long n)
{
	long k;

	for (k = 0; k < n; k++)
		bench_field_step(f);
}

double bench_field_volume_lsb(const struct bench_field *f)
{
	int64_t si = 0;
	double sd = 0;
	int i, j;

	if (f->impl == BENCH_EF32)
		return (double)ef32_volume(&f->ef);
	if (bench_impl_velocity(f->impl))
		return (double)swell_wave_volume(&f->w);
	for (j = 0; j < f->ny; j++)
		for (i = 0; i < f->nx; i++) {
			if (bench_impl_is_fixed(f->impl))
				si += (int64_t)cell_lsb(f, i, j, 0);
			else
				sd += cell_lsb(f, i, j, 0);
		}
	return bench_impl_is_fixed(f->impl) ? (double)si : sd;
}

/* 2 w for the edge (i,j)-(i+di,j+dj): 2 inner orthogonal, 3 along a wall, 1 diagonal. */
static int two_w(const struct bench_field *f, int i, int j, int di, int dj)
{
	if (di && dj)
		return 1;
	if (di)
		return (j == 0 || j == f->ny - 1) ? 3 : 2;
	return (i == 0 || i == f->nx - 1) ? 3 : 2;
}

static const int edge_d[4][2] = { { 1, 0 }, { 0, 1 }, { 1, 1 }, { -1, 1 } };

/* E 2^31 = kin 2^31 + e_eff pot2, exact; one rounding to double at the end */
static double energy_exact(const struct bench_field *f, i128 kin, i128 pot2)
{
	return (double)((kin << 31) + (i128)f->e_eff_q30 * pot2) / 2147483648.0;
}

double bench_field_energy(const struct bench_field *f)
{
	const int fixed = bench_impl_is_fixed(f->impl);
	i128 kin = 0, pot2 = 0; /* fixed point: exact (the heights are whole LSB) */
	long double kin_f = 0, pot2_f = 0; /* float */
	int i, j, k;

	if ((bench_impl_wave(f->impl)) && bench_field_max_abs_lsb(f) < (1 << 23) && f->nx * f->ny <= 65536) {
		struct swell_energy en = f->impl == BENCH_EF32 ? ef32_energy(&f->ef) : swell_wave_energy(&f->w);

		return energy_exact(f, en.kin, en.pot2);
	}
	for (j = 0; j < f->ny; j++) {
		for (i = 0; i < f->nx; i++) {
			const double v = cell_lsb(f, i, j, 0) - cell_lsb(f, i, j, 1);

			kin += fixed ? (i128)(int64_t)v * (int64_t)v : 0;
			kin_f += (long double)v * v;
			for (k = 0; k < 4; k++) {
				const int bi = i + edge_d[k][0], bj = j + edge_d[k][1];
				double dn, dp;

				if (bi < 0 || bi >= f->nx || bj >= f->ny)
					continue;
				dn = cell_lsb(f, bi, bj, 0) - cell_lsb(f, i, j, 0);
				dp = cell_lsb(f, bi, bj, 1) - cell_lsb(f, i, j, 1);
				if (fixed)
					pot2 += (i128)two_w(f, i, j, edge_d[k][0], edge_d[k][1]) * (int64_t)dn *
						(int64_t)dp;
				else
					pot2_f += (long double)two_w(f, i, j, edge_d[k][0], edge_d[k][1]) * dn * dp;
			}
		}
	}
	return fixed ? energy_exact(f, kin, pot2) : (double)(kin_f + (long double)f->e_eff * pot2_f / 2);
}

double bench_field_max_abs_lsb(const struct bench_field *f)
{
	double m = 0;
	int i, j;

	for (j = 0; j < f->ny; j++)
		for (i = 0; i < f->nx; i++)
			m = fmax(m, fabs(cell_lsb(f, i, j, 0)));
	return m;
}

double bench_field_max_step_lsb(const struct bench_field *f)
{
	double m = 0;
	int i, j;

	for (j = 0; j < f->ny; j++)
		for (i = 0; i < f->nx; i++)
			m = fmax(m, fabs(cell_lsb(f, i, j, 0) - cell_lsb(f, i, j, 1)));
	return m;
}
