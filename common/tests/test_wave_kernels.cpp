/* The solver's kernels (swell_wave_set_kernel) against the scalar reference, bit for bit: heights,
 * v, every flow (through the checksum), the accumulator between slices, sleeping-tile flags and the
 * saturation count. The Cortex-M4 kernel is checked the same way under QEMU (label qemu-arm). */
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

extern "C" {
#include "swell/shape.h"
#include "swell/wave.h"
}

#include "wave_field.hpp"

using namespace wave_test;

namespace {

/* The same run on the reference and on kernel k: random heights (or a splash), steps split into
 * slices of varying size, water added and cells written between slices. */
void run_pair(const Case &c, swell_wave_kernel k, uint32_t seed, int steps)
{
	Field ref(c.nx, c.ny, q30(c.e), q30(c.t), c.st, SWELL_KERNEL_REF);
	Field fast(c.nx, c.ny, q30(c.e), q30(c.t), c.st, k);
	std::mt19937 rng(seed);
	const int32_t amp = (int32_t)std::min<double>(c.amp_mm * SWELL_H_ONE_MM, SWELL_H_MAX);
	std::uniform_int_distribution<int32_t> d(-amp, amp);
	const bool splash = seed % 2 == 0;

	for (int a = 0; a < ref.n(); a++)
		ref.w.h[a] = splash ? 0 : d(rng);
	if (splash)
		swell_shape_gauss(ref.w.h, ref.w.nx, ref.w.ny, (c.nx / 3) << 16, (c.ny / 2) << 16, 2 << 16, amp);
	std::memcpy(fast.w.h, ref.w.h, sizeof(int32_t) * ref.n());
	swell_wave_rest(&ref.w);
	swell_wave_rest(&fast.w);
	swell_wave_set_sleep(&ref.w, c.sleep);
	swell_wave_set_sleep(&fast.w, c.sleep);

	for (int s = 0; s < steps; s++) {
		int left = c.ny;
		while (left > 0) {
			const int rows = 1 + (int)(rng() % 9);
			left = swell_wave_step_rows(&ref.w, rows);
			REQUIRE(swell_wave_step_rows(&fast.w, rows) == left);
			if (rng() % 4 == 0) { /* an object pushing water in between slices */
				const int i = (int)(rng() % c.nx), j = (int)(rng() % c.ny);
				const int32_t dh = d(rng) / 4;
				swell_wave_add(&ref.w, i, j, dh);
				swell_wave_add(&fast.w, i, j, dh);
			}
			if (rng() % 16 == 0) { /* a cell written from outside */
				const int a = (int)(rng() % ref.n());
				ref.w.h[a] = fast.w.h[a] = d(rng);
				swell_wave_touched(&ref.w, a % c.nx, a / c.nx);
				swell_wave_touched(&fast.w, a % c.nx, a / c.nx);
			}
			const std::string diff = differs(ref, fast, false);
			INFO(swell_wave_kernel_name(k)
			     << " " << c.nx << "x" << c.ny << " e " << c.e << " t " << c.t << " stencil " << c.st << " amp "
			     << c.amp_mm << " mm sleep " << c.sleep << " seed " << seed << ": step " << s << ", " << left
			     << " rows left: " << diff);
			REQUIRE(diff.empty());
		}
		swell_wave_step_finish(&ref.w);
		swell_wave_step_finish(&fast.w);
		const std::string diff = differs(ref, fast);
		INFO(swell_wave_kernel_name(k) << " " << c.nx << "x" << c.ny << " e " << c.e << " t " << c.t << " seed " << seed
					       << ": after step " << s << ": " << diff);
		REQUIRE(diff.empty());
	}
}

} // namespace

TEST_CASE("every kernel is bit-identical to the scalar reference: random fields, splashes, slices, "
	  "additions, damping, both stencils, walls, ragged grids",
	  "[wave][kernel]")
{
	const Case cases[] = {
		{64, 64, 0.2, 0.0, SWELL_STENCIL_PAPER, 20, 1}, /* the reference scene, undamped */
		{64, 64, 0.2, 0.01, SWELL_STENCIL_PAPER, 20, 1}, /* damped */
		{48, 40, 0.4, 0.3, SWELL_STENCIL_CALIBRATED, 5, 1}, /* calibrated */
		{45, 37, 0.3, 0.02, SWELL_STENCIL_PAPER, 2, 1}, /* ragged: the last tile column is 5 wide */
		{16, 9, 0.49, 0.0, SWELL_STENCIL_PAPER, 100, 0}, /* near the limit, no sleeping */
		{24, 24, 0.9, 0.7, SWELL_STENCIL_PAPER, 50, 1}, /* c_wall >= 2^29 (the M4's second mode) */
		{8, 8, 0.25, 0.1, SWELL_STENCIL_PAPER, 10, 1}, /* one tile: both walls in it */
		{2, 2, 0.3, 0.0, SWELL_STENCIL_PAPER, 10, 1}, /* the smallest grid */
		{17, 3, 0.3, 0.05, SWELL_STENCIL_CALIBRATED, 10, 0}, /* narrow and ragged */
	};
	for (swell_wave_kernel k : fast_kernels())
		for (const Case &c : cases)
			for (uint32_t seed = 1; seed <= 4; seed++)
				run_pair(c, k, seed, 80);
}

TEST_CASE("every kernel saturates exactly like the reference: full-scale checkerboards at the "
	  "stability limit",
	  "[wave][kernel][saturation]")
{
	for (swell_wave_kernel k : fast_kernels()) {
		for (double t : {0.0, 0.3}) {
			const q30_t e = swell_wave_e_limit(q30(t), SWELL_STENCIL_PAPER) - 2;
			Field ref(16, 16, e, q30(t), SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
			Field fast(16, 16, e, q30(t), SWELL_STENCIL_PAPER, k);
			for (int j = 0; j < 16; j++)
				for (int i = 0; i < 16; i++)
					ref.w.h[j * 16 + i] = fast.w.h[j * 16 + i] = ((i + j) & 1) ? SWELL_H_MAX : SWELL_H_MIN;
			swell_wave_rest(&ref.w);
			swell_wave_rest(&fast.w);
			for (int s = 0; s < 500; s++) {
				swell_wave_step(&ref.w);
				swell_wave_step(&fast.w);
				const std::string diff = differs(ref, fast);
				INFO(swell_wave_kernel_name(k) << " t " << t << " step " << s << ": " << diff);
				REQUIRE(diff.empty());
			}
			INFO(swell_wave_kernel_name(k) << " t " << t);
			CHECK(ref.w.saturations > 0u); /* the case does reach the bounds */
		}
	}
}

TEST_CASE("kernel selection: unknown kernels are refused and change nothing, AUTO picks one that "
	  "exists",
	  "[wave][kernel]")
{
	Field f(16, 16, q30(0.2), 0, SWELL_STENCIL_PAPER, SWELL_KERNEL_AUTO);
	const uint8_t chosen = f.w.kernel;
	CHECK(chosen != SWELL_KERNEL_AUTO);
	CHECK(swell_wave_kernel_name((swell_wave_kernel)chosen) != nullptr);
	CHECK(swell_wave_set_kernel(&f.w, (swell_wave_kernel)9) == SWELL_EINVAL);
	CHECK(f.w.kernel == chosen);
	CHECK(swell_wave_set_kernel(nullptr, SWELL_KERNEL_REF) == SWELL_EINVAL);
	CHECK(swell_wave_kernel_name(SWELL_KERNEL_AUTO) == nullptr);
	CHECK(std::string(swell_wave_kernel_name(SWELL_KERNEL_REF)) == "ref");
}

TEST_CASE("velocity form: the heights one row behind, where a kernel folds them into its pass, are the reference's "
	  "after every slice: slices of 1 to 9 rows across bands, narrow and ragged rows, bands half asleep under "
	  "awake ones, rows that clamp counted once",
	  "[wave][kernel][velocity]")
{
	/* widths under a vector, a cell short of and past whole tiles; heights of one band and a few */
	const int widths[] = {2, 3, 5, 7, 8, 9, 15, 16, 17, 23, 64, 67};
	const int heights[] = {2, 3, 8, 9, 17, 24};
	std::mt19937 rng(20261207);
	long sats = 0, skipped = 0;

	for (swell_wave_kernel k : fast_kernels())
		for (int nx : widths)
			for (int ny : heights)
				for (int c = 0; c < 3; c++) {
					/* c 0: a calm pool with pushes at the bands' first and last rows (tiles
					 * asleep beside awake ones); c 1: the same damped; c 2: every cell at an
					 * int27 bound near the stability limit (h and u clamp) */
					const q30_t t = c == 1 ? q30(0.02) : 0;
					const q30_t e = c == 2 ? swell_wave_e_limit(t, SWELL_STENCIL_PAPER) - 2 : q30(0.2);
					Field ref(nx, ny, e, t, SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
					Field fast(nx, ny, e, t, SWELL_STENCIL_PAPER, k);
					std::mt19937 frng(rng());

					for (int a = 0; a < ref.n(); a++)
						ref.w.h[a] = c == 2 ? ((a % nx + a / nx) % 2 ? SWELL_HV_MAX : SWELL_HV_MIN) : 0;
					std::memcpy(fast.w.h, ref.w.h, sizeof(int32_t) * ref.n());
					swell_wave_rest(&ref.w);
					swell_wave_rest(&fast.w);
					for (int s = 0; s < 12; s++) {
						int left = ny;
						if (c < 2 && s % 4 == 0) { /* the last row of a band, the next's first */
							const int i = (int)(frng() % nx),
								  b = (int)(frng() % ny) / SWELL_WAVE_TILE;
							for (int j :
							     {b * SWELL_WAVE_TILE + SWELL_WAVE_TILE - 1, b * SWELL_WAVE_TILE})
								for (Field *f : {&ref, &fast})
									swell_wave_add(&f->w, i, j, (s % 8 ? -1 : 1) * 40000);
						}
						while (left > 0) {
							const int rows = 1 + (int)(frng() % 9);
							left = swell_wave_step_rows(&ref.w, rows);
							REQUIRE(swell_wave_step_rows(&fast.w, rows) == left);
							const std::string d = differs(ref, fast, false);
							INFO(swell_wave_kernel_name(k)
							     << " " << nx << "x" << ny << " case " << c << " step " << s << ", "
							     << left << " rows left: " << d);
							REQUIRE(d.empty());
							REQUIRE(ref.w.saturations == fast.w.saturations);
						}
						swell_wave_step_finish(&ref.w);
						swell_wave_step_finish(&fast.w);
						const std::string d = differs(ref, fast);
						INFO(swell_wave_kernel_name(k) << " " << nx << "x" << ny << " case " << c
									       << " after step " << s << ": " << d);
						REQUIRE(d.empty());
					}
					sats += ref.w.saturations;
					skipped += ref.w.tiles_skipped;
				}
	/* the cases reach what they are for: clamps, and tiles asleep */
	CHECK(sats > 0);
	CHECK(skipped > 0);
}
