/* The velocity form's AVX2 kernel (common/src/wave_vel_avx2.c) and its finishing pass against the
 * scalar reference, bit for bit, on CPUs that have AVX2 (skipped elsewhere). */
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <string>

#include "wave_field.hpp"

extern "C" {
#include "swell/shape.h"
#include "swell/wave.h"
}

using wave_test::differs;
using wave_test::Field;
using wave_test::q30;

namespace {

bool have_avx2()
{
	Field probe(8, 8, q30(0.2), 0, SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
	return swell_wave_set_kernel(&probe.w, SWELL_KERNEL_AVX2) == SWELL_OK;
}

/* A stable e for damping t and the stencil: a random fraction (from lo) of the way to the limit, at
 * most e_max. */
q30_t stable_e(std::mt19937 &rng, q30_t t, swell_stencil st, double e_max, double lo = 0.02)
{
	const double lim = (double)swell_wave_e_limit(t, st) / SWELL_Q30_ONE;
	std::uniform_real_distribution<double> frac(lo, 0.999);
	return q30(std::min(frac(rng) * lim, e_max));
}

/* Heights: uniform in +-amp LSB, or (amp < 0) each cell at one of the int27 bounds. */
void fill(Field &f, std::mt19937 &rng, int32_t amp)
{
	std::uniform_int_distribution<int32_t> d(-std::abs(amp), std::abs(amp));
	std::bernoulli_distribution top(0.5);
	for (int a = 0; a < f.n(); a++)
		f.w.h[a] = amp < 0 ? (top(rng) ? SWELL_HV_MAX : SWELL_HV_MIN) : d(rng);
	swell_wave_rest(&f.w);
}

} // namespace

TEST_CASE("velocity form: the AVX2 kernel is bit-identical to the reference after every slice and step: random "
	  "fields and coefficients, damped and undamped, both stencils, pushes, saturation, ragged and narrow grids",
	  "[wave][velocity][kernels][avx2]")
{
	if (!have_avx2())
		return; /* this CPU has no AVX2: the kernel is never chosen */
	/* widths: a tile, one cell short of and past whole tiles, more than a run of 8 tiles */
	const int grids[][2] = {{2, 2},  {3, 7},   {7, 9},  {8, 8},   {9, 17},  {13, 21}, {16, 16},
				{17, 8}, {31, 12}, {40, 3}, {64, 64}, {67, 11}, {130, 6}};
	std::mt19937 rng(20261202);
	long cells = 0;
	int runs = 0;

	for (const auto &g : grids) {
		const int nx = g[0], ny = g[1];
		for (int k = 0; k < 8; k++) {
			const swell_stencil st = k % 2 ? SWELL_STENCIL_CALIBRATED : SWELL_STENCIL_PAPER;
			const q30_t t = k % 4 < 2 || k == 7 ? 0 : q30(std::uniform_real_distribution<double>(1e-4, 0.7)(rng));
			/* 2 mm, 500 mm, or every cell at a bound with e near the limit (saturates) */
			const int32_t amp = k < 4 ? 2 * SWELL_H_ONE_MM : k < 6 ? 500 * SWELL_H_ONE_MM : -1;
			const q30_t e = stable_e(rng, t, st, 1.999, amp < 0 ? 0.9 : 0.02);
			Field ref(nx, ny, e, t, st, SWELL_KERNEL_REF);
			Field vec(nx, ny, e, t, st, SWELL_KERNEL_AVX2);
			std::mt19937 frng(rng());

			swell_wave_set_sleep(&ref.w, k != 5);
			swell_wave_set_sleep(&vec.w, k != 5);
			fill(ref, frng, amp);
			std::copy(ref.w.h, ref.w.h + ref.n(), vec.w.h);
			swell_wave_rest(&vec.w);
			INFO(nx << "x" << ny << " e " << e << " t " << t << " stencil " << st << " amp " << amp);
			for (int s = 0; s < 24; s++) {
				std::uniform_int_distribution<int> rows(1, ny), ci(0, nx - 1), cj(0, ny - 1);
				const int slice = rows(frng);
				swell_wave_step_rows(&ref.w, slice);
				swell_wave_step_rows(&vec.w, slice);
				if (s % 3 == 0) { /* water in and out between slices, as the body's coupling does */
					const int i = ci(frng), j = cj(frng), i2 = ci(frng), j2 = cj(frng);
					const int32_t d = std::uniform_int_distribution<int32_t>(-40000, 40000)(frng);
					for (Field *f : {&ref, &vec}) {
						swell_wave_add(&f->w, i, j, d);
						swell_wave_add(&f->w, i2, j2, -d);
					}
				}
				(void)rows(frng); /* the draw the finish ahead took: the same slices as before */
				{
					const std::string d = differs(ref, vec, false);
					INFO("step " << s << ", after a slice of " << slice << " rows: " << d);
					REQUIRE(d.empty());
				}
				if (s == 12) { /* new coefficients mid-run: u is rescaled to other fraction bits */
					swell_wave_params p{stable_e(frng, t, st, 1.999), t, st};
					REQUIRE(swell_wave_set_params(&ref.w, &p) == SWELL_OK);
					REQUIRE(swell_wave_set_params(&vec.w, &p) == SWELL_OK);
				}
				swell_wave_step(&ref.w);
				swell_wave_step(&vec.w);
				const std::string d = differs(ref, vec);
				INFO("step " << s << ": " << d);
				REQUIRE(d.empty());
				cells += ref.n();
			}
			CHECK(swell_wave_checksum(&ref.w) == swell_wave_checksum(&vec.w));
			if (amp < 0)
				CHECK(ref.w.saturations > 0);
			runs++;
		}
	}
	CHECK(runs == (int)(sizeof(grids) / sizeof(grids[0])) * 8);
	WARN(runs << " runs, " << cells << " cell-steps a kernel");
}

TEST_CASE("velocity form: the AVX2 kernel is bit-identical to the reference where tiles sleep: splashes in a calm "
	  "pool, rows of awake and sleeping tiles (runs split at sleeping tiles and after 8), clamps in runs side by "
	  "side, wide and ragged grids",
	  "[wave][velocity][kernels][avx2][sleep]")
{
	if (!have_avx2())
		return; /* this CPU has no AVX2: the kernel is never chosen */
	/* widths past two runs of 8 tiles, ragged or not; heights of a few bands */
	const int grids[][2] = {{150, 40}, {136, 24}, {67, 30}, {200, 17}};
	std::mt19937 rng(20261203);
	long skipped = 0, sats = 0;

	for (const auto &g : grids) {
		const int nx = g[0], ny = g[1], tiles = (nx + SWELL_WAVE_TILE - 1) / SWELL_WAVE_TILE;
		for (int k = 0; k < 4; k++) {
			const swell_stencil st = k % 2 ? SWELL_STENCIL_CALIBRATED : SWELL_STENCIL_PAPER;
			const q30_t t = k == 1 ? q30(0.02) : 0;
			/* k >= 2: e near the limit, so that a cell at the int27 bound clamps its neighbours' u */
			const q30_t e = stable_e(rng, t, st, 1.999, k < 2 ? 0.3 : 0.9);
			Field ref(nx, ny, e, t, st, SWELL_KERNEL_REF);
			Field vec(nx, ny, e, t, st, SWELL_KERNEL_AVX2);
			std::mt19937 frng(rng());
			std::uniform_int_distribution<int> ci(0, nx - 1), cj(0, ny - 1);

			if (k < 2) { /* two splashes in a calm pool */
				swell_shape_gauss(ref.w.h, (uint16_t)nx, (uint16_t)ny, ci(frng) * SWELL_Q16_ONE,
						  cj(frng) * SWELL_Q16_ONE, 2 * SWELL_Q16_ONE, 3 * SWELL_H_ONE_MM);
				swell_shape_gauss(ref.w.h, (uint16_t)nx, (uint16_t)ny, ci(frng) * SWELL_Q16_ONE,
						  cj(frng) * SWELL_Q16_ONE, 2 * SWELL_Q16_ONE, -2 * SWELL_H_ONE_MM);
				swell_wave_rest(&ref.w);
				std::copy(ref.w.h, ref.w.h + ref.n(), vec.w.h);
				swell_wave_rest(&vec.w);
			}
			INFO(nx << "x" << ny << " e " << e << " t " << t << " stencil " << st);
			for (int s = 0; s < 40; s++) {
				if (k >= 2 && s % 8 == 4) {
					/* a comb of cells at the bound along a row of a sleeping pool: every second
					 * tile wakes one run longer than 8 tiles, every fourth runs of three with a
					 * sleeping tile between them */
					const int step = s % 16 == 4 ? 2 : 4, j = cj(frng);
					for (int tx = frng() % 2; tx < tiles - 3; tx += step)
						for (Field *f : {&ref, &vec})
							swell_wave_add(&f->w, tx * SWELL_WAVE_TILE + 3, j, SWELL_HV_MAX);
				} else if (k < 2 && s % 6 == 5) {
					const int i = ci(frng), j = cj(frng);
					const int32_t d = std::uniform_int_distribution<int32_t>(-9000, 9000)(frng);
					for (Field *f : {&ref, &vec})
						swell_wave_add(&f->w, i, j, d);
				}
				const int slice = std::uniform_int_distribution<int>(1, ny)(frng);
				swell_wave_step_rows(&ref.w, slice);
				swell_wave_step_rows(&vec.w, slice);
				{
					const std::string d = differs(ref, vec, false);
					INFO("step " << s << ", after a slice of " << slice << " rows: " << d);
					REQUIRE(d.empty());
				}
				swell_wave_step(&ref.w);
				swell_wave_step(&vec.w);
				const std::string d = differs(ref, vec);
				INFO("step " << s << ": " << d);
				REQUIRE(d.empty());
				if (k >= 2 && s % 8 == 7) /* the pool calm again, to sleep before the next comb */
					for (Field *f : {&ref, &vec}) {
						std::fill(f->w.h, f->w.h + f->n(), 0);
						swell_wave_rest(&f->w);
					}
			}
			skipped += ref.w.tiles_skipped;
			sats += ref.w.saturations;
		}
	}
	/* the cases reach what they are for: sleeping tiles beside awake ones, and clamps */
	CHECK(skipped > 0);
	CHECK(sats > 0);
	WARN(skipped << " tile-rows skipped, " << sats << " saturations");
}

TEST_CASE("velocity form, AVX2: at e_eff = 1 (C = 2^31 does not fit VPMULDQ) the fused path gives the same bits, and "
	  "the automatic choice is AVX2",
	  "[wave][velocity][kernels][avx2]")
{
	if (!have_avx2())
		return; /* this CPU has no AVX2: the kernel is never chosen */
	/* paper e = 1 is stable only with damping; C = e_eff 2^(F+1) = 2^31 at F = 0 takes the fused path */
	Field ref(24, 10, SWELL_Q30_ONE, q30(0.7), SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
	Field vec(24, 10, SWELL_Q30_ONE, q30(0.7), SWELL_STENCIL_PAPER, SWELL_KERNEL_AVX2);
	std::mt19937 rng(7);
	fill(ref, rng, 300 * SWELL_H_ONE_MM);
	std::copy(ref.w.h, ref.w.h + ref.n(), vec.w.h);
	swell_wave_rest(&vec.w);
	for (int s = 0; s < 20; s++) {
		swell_wave_step(&ref.w);
		swell_wave_step(&vec.w);
		const std::string d = differs(ref, vec);
		INFO("step " << s << ": " << d);
		REQUIRE(d.empty());
	}
	CHECK(ref.w.fixed_lsb > 0);

	Field a(16, 16, q30(0.2), 0, SWELL_STENCIL_PAPER, SWELL_KERNEL_AUTO);
	CHECK(a.w.kernel == SWELL_KERNEL_AVX2);
}
