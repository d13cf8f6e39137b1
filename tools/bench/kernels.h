/* swell-bench kernels: the implementations of eq. (1) the benchmark compares, behind one interface.
 *
 * Host-only benchmark code (it allocates and uses float); nothing here runs on the controller.
 * The solver (swell/wave.h, velocity below) is what the controller runs; every other variant is
 * written here (ef32 in ef32/) so that the benchmark can compare them without touching the solver.
 *
 *   ef32         edge-flux form (ef32/ef32.h): int32 heights and flows (LSB 2^-16 mm), e w dh to
 *                nearest, damping toward zero; reference, fused and AVX2 kernels, sleeping tiles
 *   velocity     the solver, the controller's: one momentum a cell, separable L9, per-cell rounding and
 *                the exact global volume fixer (int27 heights, LSB 2^-16 mm); the kernel wave.c
 *                chooses (AVX2 where the CPU has it)
 *   vel-ref      the same with its scalar reference kernel, vel-fused with the fused kernel (the
 *                same bits as velocity: only the cost differs)
 *   ef16         edge-flux, int16 heights and flows (LSB 2^-10 mm, +-32 mm), same rounding
 *   tl32-floor   three-level eq. (1), int32 heights (LSB 2^-16 mm), both products floored (>>)
 *   tl32-rn      ... both products rounded to nearest (ties up)
 *   tl32-rz      ... both products rounded toward zero
 *   tl16-rn      three-level, int16 heights (LSB 2^-10 mm), nearest
 *   f32          plain float32 three-level C loop: the cost baseline
 *   f64          the same loop in float64
 * Fixed-point coefficients are Q1.30 and made exactly as wave.c makes them (e_eff even).
 * Three-level kernels keep ghost-padded arrays ((nx+2) x (ny+2)) and refill the mirrored ghosts
 * every step; the edge-flux kernels fold the walls into the edge weights (3/2 along a wall). */
#ifndef SWELL_BENCH_KERNELS_H
#define SWELL_BENCH_KERNELS_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"
#include "swell/wave.h"
#include "swell/wave_ref.h"
#include "ef32/ef32.h"

enum bench_impl {
	BENCH_EF32 = 0,
	BENCH_VELOCITY,
	BENCH_VEL_REF,
	BENCH_VEL_FUSED,
	BENCH_EF16,
	BENCH_TL32_FLOOR,
	BENCH_TL32_RN,
	BENCH_TL32_RZ,
	BENCH_TL16_RN,
	BENCH_F32,
	BENCH_F64,
	BENCH_IMPL_COUNT
};

struct bench_field {
	enum bench_impl impl;
	int nx, ny, px; /* px = nx + 2: padded row length of the three-level kernels */
	q30_t e_eff_q30; /* fixed-point coefficients (also set for float kernels, unused there) */
	q30_t q_q30;
	double e_eff, q; /* the coefficients actually used, as double (exact for fixed point) */
	float e_eff_f, q_f;
	double lsb_mm; /* 1 LSB in mm; float kernels report 2^-16 mm so pushes have one unit */
	int h_max; /* saturation bound in LSB (0: float, none) */
	uint32_t saturations;
	struct swell_wave w; /* the solver: velocity, vel-ref, vel-fused */
	struct ef32 ef; /* ef32 */
	void *mem;
	/* three-level fixed: padded h(n), h(n-1), scratch; int32 or int16 */
	int32_t *h32, *hp32, *hn32;
	int16_t *h16, *hp16, *hn16;
	/* edge-flux int16 */
	int16_t *fe16, *fn16, *fne16, *fnw16;
	int32_t *v32; /* ef16: last step's change per cell */
	q30_t c_1, c_half, c_wall; /* ef16 edge coefficients */
	/* float: padded */
	float *hf, *hpf, *hnf;
	double *hd, *hpd, *hnd;
};

/* Proposal for wave.c (bench-only here): e w dh rounded to nearest as the high word of (4 dh) c,
 * which is exactly (dh c + 2^29) >> 30 for |dh| <= 2^28 (|result| < 2^29): the 64-bit shift goes.
 * Measured on the STM32F405 image under QEMU: 143.4 -> 141.1 instructions per cell-step, same
 * checksum. */
static inline int32_t bench_mul_q30_rn_hi(int32_t dh, q30_t c)
{
	return (int32_t)(((int64_t)(dh * 4) * c + ((int64_t)1 << 31)) >> 32);
}

const char *bench_impl_name(enum bench_impl impl);
/* Parse a name as printed by bench_impl_name; BENCH_IMPL_COUNT when unknown. */
enum bench_impl bench_impl_parse(const char *name);
/* Storage bytes per cell the kernel keeps between steps (scratch included). */
size_t bench_impl_bytes_per_cell(enum bench_impl impl);
int bench_impl_is_fixed(enum bench_impl impl);
/* 1 for the solver (velocity, vel-ref, vel-fused); 1 for the solver or ef32 in bench_impl_wave. */
int bench_impl_velocity(enum bench_impl impl);
int bench_impl_wave(enum bench_impl impl);

/* Allocate a flat field at rest. e, t as doubles; fixed kernels quantise them to Q1.30 as
 * swell_wave_params would (round to nearest). Refuses what swell_wave_check refuses. */
enum swell_err bench_field_init(struct bench_field *f, enum bench_impl impl, int nx, int ny, double e, double t,
				enum swell_stencil stencil);
void bench_field_free(struct bench_field *f);

/* Bench-only: set e_eff and 1-t directly, bypassing the stability check, to map where runs stay
 * bounded outside the validated region (for the solver this writes the coefficient fields
 * of struct swell_wave, which no controller code may do). SWELL_ERANGE when the wall coefficient
 * 3/2 e_eff would not fit Q1.30. */
enum swell_err bench_field_force(struct bench_field *f, q30_t e_eff, q30_t q);

/* Heights in mm (rounded to nearest LSB, saturated), water at rest (h(n-1) = h(n)). */
void bench_field_set_mm(struct bench_field *f, const double *h_mm);
void bench_field_get_mm(const struct bench_field *f, double *h_mm);
/* r: the float64 reference of f's scheme (its e_eff and q) at rest at h_mm, in storage of
 * SWELL_WAVE_REF_DOUBLES(nx, ny) doubles. */
void bench_field_ref(const struct bench_field *f, const double *h_mm, struct swell_wave_ref *r, double *storage);
/* Add k LSB to cell (i, j) without touching h(n-1): an impulse, as an object pushing the water. */
void bench_field_add_lsb(struct bench_field *f, int i, int j, int32_t k);

void bench_field_step(struct bench_field *f);
void bench_field_steps(struct bench_field *f, long n);

/* sum(h) in LSB (exact for fixed kernels). */
double bench_field_volume_lsb(const struct bench_field *f);
/* E = kin + e_eff pot2 / 2 (docs/design.md, section 2) in LSB^2; computed exactly in 128-bit integers for fixed
 * kernels and rounded once to double; float kernels in double. */
double bench_field_energy(const struct bench_field *f);
/* max |h| and max |h(n) - h(n-1)| in LSB. */
double bench_field_max_abs_lsb(const struct bench_field *f);
double bench_field_max_step_lsb(const struct bench_field *f);

#endif
