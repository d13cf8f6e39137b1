/* What the wave tests that compare two solvers bit for bit share: a field with its own storage, the
 * kernels this CPU has, and the first place where two fields differ. */
#ifndef SWELL_TESTS_WAVE_FIELD_HPP
#define SWELL_TESTS_WAVE_FIELD_HPP

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

extern "C" {
#include "swell/wave.h"
}

namespace wave_test {

inline q30_t q30(double x) { return (q30_t)std::llround(x * SWELL_Q30_ONE); }

struct Field {
	std::vector<int32_t> store;
	swell_wave w{};
	Field(int nx, int ny, q30_t e, q30_t t, swell_stencil st, swell_wave_kernel k) : store(SWELL_WAVE_WORDS(nx, ny))
	{
		swell_wave_params p{e, t, st};
		REQUIRE(swell_wave_init(&w, (uint16_t)nx, (uint16_t)ny, store.data(), store.size(), &p) == SWELL_OK);
		REQUIRE(swell_wave_set_kernel(&w, k) == SWELL_OK);
	}
	int n() const { return w.nx * w.ny; }
	/* h(n) of cell a while a step is in progress (rows finished ahead hold h(n+1)) */
	int32_t h_last(int a) const { return swell_wave_h(&w, (size_t)a); }
};

/* The kernels besides the reference this CPU runs: fused always, avx2 where the CPU has it. */
inline std::vector<swell_wave_kernel> fast_kernels()
{
	std::vector<swell_wave_kernel> ks{SWELL_KERNEL_FUSED};
	Field probe(8, 8, q30(0.2), 0, SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
	if (swell_wave_set_kernel(&probe.w, SWELL_KERNEL_AVX2) == SWELL_OK)
		ks.push_back(SWELL_KERNEL_AVX2);
	return ks;
}

inline std::string cell_diff(const char *what, int i, int32_t a, int32_t b)
{
	return std::string(what) + "[" + std::to_string(i) + "] " + std::to_string(a) + " vs " + std::to_string(b);
}

/* Everything that must agree (heights, momentum, residuals, fixer, flags and counts), with where it
 * first differs; all = false: the cells only (between slices, where flags are still being written).
 * "" when the two are the same bits. */
inline std::string differs(const Field &a, const Field &b, bool all = true)
{
	for (int i = 0; i < a.n(); i++) {
		if (a.w.h[i] != b.w.h[i])
			return cell_diff("h", i, a.w.h[i], b.w.h[i]);
	}
	if (a.w.done_row != b.w.done_row || a.w.next_row != b.w.next_row)
		return "rows done " + std::to_string(a.w.done_row) + " vs " + std::to_string(b.w.done_row);
	for (int i = 0; i < a.n(); i++)
		if (a.w.u[i] != b.w.u[i])
			return cell_diff("u", i, a.w.u[i], b.w.u[i]);
	if (!all)
		return "";
	if (a.w.vel_sum != b.w.vel_sum || a.w.vel_sum_h != b.w.vel_sum_h) /* the residuals in progress */
		return "residuals " + std::to_string(a.w.vel_sum) + ", " + std::to_string(a.w.vel_sum_h) + " vs " +
			std::to_string(b.w.vel_sum) + ", " + std::to_string(b.w.vel_sum_h);
	if (a.w.fixed_lsb != b.w.fixed_lsb || a.w.fix_cursor != b.w.fix_cursor) /* the fixers' state */
		return "fixer " + std::to_string(a.w.fixed_lsb) + " vs " + std::to_string(b.w.fixed_lsb);
	if (std::memcmp(a.w.tile, b.w.tile, (size_t)a.w.tiles_x * a.w.tiles_y) != 0)
		return "tile flags";
	if (a.w.saturations != b.w.saturations)
		return "saturations " + std::to_string(a.w.saturations) + " vs " + std::to_string(b.w.saturations);
	if (a.w.tiles_skipped != b.w.tiles_skipped)
		return "tiles skipped " + std::to_string(a.w.tiles_skipped) + " vs " + std::to_string(b.w.tiles_skipped);
	if (a.w.steps != b.w.steps)
		return "steps " + std::to_string(a.w.steps) + " vs " + std::to_string(b.w.steps);
	return "";
}

/* One comparison case: grid, e and t, stencil, the splash's amplitude (0: random heights) and
 * whether tiles may sleep. */
struct Case {
	int nx, ny;
	double e, t;
	swell_stencil st;
	double amp_mm;
	int sleep;
};

} // namespace wave_test

#endif
