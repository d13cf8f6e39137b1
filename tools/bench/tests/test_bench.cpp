// Unit tests of swell-bench's own kernels and measures: the benchmark's figures are only as good
// as its references, so each reference is checked against an independent one here.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

extern "C" {
#include "kernels.h"
#include "measure.h"
#include "swell/wave_ref.h"
}

static const enum bench_impl fixed_impls[] = {BENCH_EF32,    BENCH_EF16,    BENCH_TL32_FLOOR,
					      BENCH_TL32_RN, BENCH_TL32_RZ, BENCH_TL16_RN};

static std::vector<double> noise(int n, double amp, uint64_t seed)
{
	bench_rng r;
	std::vector<double> h(n);

	bench_rng_seed(&r, seed);
	for (auto &x : h)
		x = amp * (2 * bench_rng_uniform(&r) - 1);
	return h;
}

TEST_CASE("the (m,n) cosine mode is an exact eigenvector of L9 with mirrored walls", "[bench][eigen]")
{
	// f64 kernel on a non-square grid against the scalar recurrence of the mode's amplitude
	const int nx = 12, ny = 7;
	const int modes[][2] = {{1, 0}, {3, 2}, {11, 6}};

	for (auto &mn : modes) {
		bench_field f;
		bench_mode md;
		bench_amp am;
		std::vector<double> h(nx * ny), x(nx * ny);
		double linf = 0, l2;

		REQUIRE(bench_field_init(&f, BENCH_F64, nx, ny, 0.3, 0.05, SWELL_STENCIL_PAPER) == SWELL_OK);
		bench_mode_init(&md, nx, ny, mn[0], mn[1]);
		bench_mode_field(&md, 1.0, h.data());
		bench_field_set_mm(&f, h.data());
		bench_amp_init(&am, 1.0, f.e_eff, f.q, md.S);
		for (int k = 0; k < 200; k++) {
			bench_field_step(&f);
			bench_amp_step(&am);
			bench_field_get_mm(&f, h.data());
			bench_mode_field(&md, (double)am.s, x.data());
			double li;
			bench_err(h.data(), x.data(), nx * ny, &li, &l2);
			linf = std::fmax(linf, li);
		}
		INFO("mode (" << mn[0] << "," << mn[1] << "), S = " << md.S << ": L-inf " << linf << " mm");
		CHECK(linf < 1e-12);
		bench_field_free(&f);
	}
}

TEST_CASE("for t = 0 the amplitude recurrence equals cos(w (k+1/2)) / cos(w/2), cos w = 1 + e S / 2", "[bench][eigen]")
{
	bench_mode md;
	bench_amp am;

	bench_mode_init(&md, 64, 64, 1, 1);
	for (double e : {0.05, 0.2, 0.45}) {
		double w = bench_omega_discrete(e, md.S), worst = 0;

		bench_amp_init(&am, 1.0, e, 1.0, md.S);
		for (long k = 1; k <= 5000; k++) {
			bench_amp_step(&am);
			worst = std::fmax(worst, std::fabs((double)am.s - bench_amp_closed(1.0, w, k)));
		}
		INFO("e = " << e << ": worst difference " << worst);
		CHECK(worst < 1e-9);
	}
	// the calibrated stencil (e_eff = e/2) matches the continuous seiche for long waves
	bench_mode_init(&md, 256, 256, 1, 1);
	double ratio = bench_omega_discrete(0.1, md.S) / bench_omega_seiche(0.2, &md);
	INFO("calibrated w_d / w_c = " << ratio);
	CHECK(std::fabs(ratio - 1) < 1e-3);
	ratio = bench_omega_discrete(0.2, md.S) / bench_omega_seiche(0.2, &md);
	INFO("paper w_d / w_c = " << ratio);
	CHECK(std::fabs(ratio - std::sqrt(2.0)) < 1e-3);
}

TEST_CASE("the f64 bench kernel agrees with swell_wave_ref to 1e-12 mm", "[bench][ref]")
{
	const int n = 24;

	for (auto st : {SWELL_STENCIL_PAPER, SWELL_STENCIL_CALIBRATED}) {
		bench_field f;
		swell_wave_ref r;
		std::vector<double> rs(SWELL_WAVE_REF_DOUBLES(n, n)), h = noise(n * n, 1.0, 7), x(n * n);
		double linf, l2;

		REQUIRE(bench_field_init(&f, BENCH_F64, n, n, 0.4, 0.1, st) == SWELL_OK);
		bench_field_set_mm(&f, h.data());
		bench_field_ref(&f, h.data(), &r, rs.data());
		for (int k = 0; k < 300; k++) {
			bench_field_step(&f);
			swell_wave_ref_step(&r);
		}
		bench_field_get_mm(&f, x.data());
		bench_err(x.data(), r.h, n * n, &linf, &l2);
		INFO("stencil " << st << ": L-inf " << linf << " mm");
		CHECK(linf < 1e-12);
		bench_field_free(&f);
	}
}

TEST_CASE("fixed kernels track float64 of the same scheme within 400 LSB over 300 steps, except floor which drifts",
	  "[bench][fixed]")
{
	const int n = 32;

	for (auto impl : fixed_impls) {
		bench_field f;
		swell_wave_ref r;
		std::vector<double> rs(SWELL_WAVE_REF_DOUBLES(n, n)), h = noise(n * n, 1.0, 11), x(n * n);
		double linf = 0, l2;

		REQUIRE(bench_field_init(&f, impl, n, n, 0.3, 0.0, SWELL_STENCIL_PAPER) == SWELL_OK);
		bench_field_set_mm(&f, h.data());
		bench_field_get_mm(&f, h.data()); // the quantised start
		bench_field_ref(&f, h.data(), &r, rs.data());
		for (int k = 0; k < 300; k++) {
			bench_field_step(&f);
			swell_wave_ref_step(&r);
			bench_field_get_mm(&f, x.data());
			double li;
			bench_err(x.data(), r.h, n * n, &li, &l2);
			linf = std::fmax(linf, li);
		}
		INFO(bench_impl_name(impl) << ": L-inf " << linf << " mm = " << linf / f.lsb_mm << " LSB");
		CHECK(linf > 0); // rounding is visible: the comparison is live
		if (impl == BENCH_TL32_FLOOR)
			CHECK(linf / f.lsb_mm > 4000); // t = 0: the -1/2 LSB bias per step accumulates twice
		else
			CHECK(linf / f.lsb_mm < 400);
		bench_field_free(&f);
	}
}

TEST_CASE("a push moves no volume and the edge-flux kernels conserve volume exactly under pushes", "[bench][volume]")
{
	for (auto impl : fixed_impls) {
		bench_field f;
		bench_rng rng;

		REQUIRE(bench_field_init(&f, impl, 32, 32, 0.2, 0.02, SWELL_STENCIL_PAPER) == SWELL_OK);
		bench_rng_seed(&rng, 3);
		double v0 = bench_field_volume_lsb(&f);
		for (int k = 0; k < 400; k++) {
			int i0 = (int)(bench_rng_uniform(&rng) * 34) - 2, j0 = (int)(bench_rng_uniform(&rng) * 34) - 2;
			int32_t d = (int32_t)(bench_rng_uniform(&rng) * 200) - 100;
			double before = bench_field_volume_lsb(&f);

			bench_push(&f, i0, j0, 5, d);
			INFO(bench_impl_name(impl) << " push at (" << i0 << "," << j0 << ") depth " << d);
			REQUIRE(bench_field_volume_lsb(&f) == before);
			bench_field_step(&f);
		}
		double drift = bench_field_volume_lsb(&f) - v0;
		INFO(bench_impl_name(impl) << ": volume drift " << drift << " LSB");
		if (impl == BENCH_EF32 || impl == BENCH_EF16)
			CHECK(drift == 0);
		if (impl == BENCH_TL32_FLOOR)
			CHECK(drift < 0); // floor biases the mean level down, as docs/design.md (rounding traps) says
		bench_field_free(&f);
	}
}

TEST_CASE("bench energy: equal for all fixed kernels at rest, conserved by f64 at t = 0, with damping "
	  "changing by (1 - 1/q) <u_n, u_n + u_(n-1)>",
	  "[bench][energy]")
{
	const int n = 20;
	std::vector<double> h = noise(n * n, 1.0, 5);
	double e_ship;
	bench_field f;

	REQUIRE(bench_field_init(&f, BENCH_EF32, n, n, 0.3, 0.0, SWELL_STENCIL_PAPER) == SWELL_OK);
	bench_field_set_mm(&f, h.data());
	e_ship = bench_field_energy(&f); // from swell_wave_energy()
	bench_field_free(&f);
	REQUIRE(e_ship > 0);
	for (auto impl : {BENCH_TL32_RN, BENCH_TL32_FLOOR}) {
		REQUIRE(bench_field_init(&f, impl, n, n, 0.3, 0.0, SWELL_STENCIL_PAPER) == SWELL_OK);
		bench_field_set_mm(&f, h.data());
		CHECK(bench_field_energy(&f) == e_ship);
		bench_field_free(&f);
	}

	REQUIRE(bench_field_init(&f, BENCH_F64, n, n, 0.45, 0.0, SWELL_STENCIL_PAPER) == SWELL_OK);
	bench_field_set_mm(&f, h.data());
	double e0 = bench_field_energy(&f), worst = 0;
	for (int k = 0; k < 500; k++) {
		bench_field_step(&f);
		worst = std::fmax(worst, std::fabs(bench_field_energy(&f) - e0) / e0);
	}
	INFO("f64 t = 0: relative energy drift " << worst);
	CHECK(worst < 1e-12);
	bench_field_free(&f);

	// With damping, E changes by exactly (1 - 1/q) <u_n, u_n + u_(n-1)>, u_n = h(n) - h(n-1)
	// (derived from eq. (1)): negative on average, but it can rise for a step when u flips sign.
	REQUIRE(bench_field_init(&f, BENCH_F64, n, n, 0.45, 0.05, SWELL_STENCIL_PAPER) == SWELL_OK);
	bench_field_set_mm(&f, h.data());
	std::vector<double> cur(n * n), prev(h), u_prev(n * n, 0.0);
	double e_prev = bench_field_energy(&f), e_start = e_prev, worst_id = 0;
	for (int k = 0; k < 500; k++) {
		bench_field_step(&f);
		bench_field_get_mm(&f, cur.data());
		double dot = 0;
		for (int a = 0; a < n * n; a++) {
			double u = (cur[a] - prev[a]) / f.lsb_mm;
			dot += u * (u + u_prev[a]);
			u_prev[a] = u;
		}
		double en = bench_field_energy(&f);
		worst_id = std::fmax(worst_id, std::fabs((en - e_prev) - (1 - 1 / f.q) * dot) / e_start);
		e_prev = en;
		prev = cur;
	}
	INFO("f64 t = 0.05: identity off by " << worst_id << " of E0; E after 500 steps " << e_prev / e_start << " of E0");
	CHECK(worst_id < 1e-12);
	CHECK(e_prev < 0.01 * e_start);
	bench_field_free(&f);
}

TEST_CASE("the bounded classifier finds the analytic limit e < (1+q)/(4q) with the f64 kernel", "[bench][stability]")
{
	for (double t : {0.0, 0.3, 0.6}) {
		double lim = bench_e_limit(1 - t);
		for (double frac : {0.97, 1.03}) {
			bench_field f;
			double gain;

			REQUIRE(bench_field_init(&f, BENCH_F64, 16, 16, 0.1, 0.0, SWELL_STENCIL_PAPER) == SWELL_OK);
			REQUIRE(bench_field_force(&f, (q30_t)std::llround(frac * lim * SWELL_Q30_ONE),
						  SWELL_Q30_ONE - (q30_t)std::llround(t * SWELL_Q30_ONE)) == SWELL_OK);
			int b = bench_bounded(&f, 1.0, 2000, 1.5, 1, &gain);
			INFO("t = " << t << ", e_eff = " << frac << " x limit " << lim << ": gain " << gain);
			CHECK(b == (frac < 1 ? 1 : 0));
			bench_field_free(&f);
		}
	}
}

TEST_CASE("bench fields refuse what swell_wave_check refuses and coefficients that do not fit", "[bench][args]")
{
	bench_field f;

	CHECK(bench_field_init(&f, BENCH_TL32_RN, 16, 16, 0.6, 0.0, SWELL_STENCIL_PAPER) == SWELL_EUNSTABLE);
	CHECK(bench_field_init(&f, BENCH_F32, 1, 16, 0.2, 0.0, SWELL_STENCIL_PAPER) == SWELL_ESIZE);
	CHECK(bench_field_init(&f, (enum bench_impl)BENCH_IMPL_COUNT, 16, 16, 0.2, 0.0, SWELL_STENCIL_PAPER) == SWELL_EINVAL);
	REQUIRE(bench_field_init(&f, BENCH_EF32, 16, 16, 0.2, 0.0, SWELL_STENCIL_PAPER) == SWELL_OK);
	q30_t before = f.w.e_eff;
	CHECK(bench_field_force(&f, (q30_t)(1.34 * SWELL_Q30_ONE), SWELL_Q30_ONE) == SWELL_ERANGE);
	CHECK(f.w.e_eff == before);
	bench_field_free(&f);
	CHECK(bench_impl_parse("tl32-rn") == BENCH_TL32_RN);
	CHECK(bench_impl_parse("nope") == BENCH_IMPL_COUNT);
}

TEST_CASE("near the saturation bound every fixed kernel clamps instead of wrapping", "[bench][saturation]")
{
	const int n = 16;

	for (auto impl : fixed_impls) {
		bench_field f;
		std::vector<double> h(n * n);

		REQUIRE(bench_field_init(&f, impl, n, n, 0.45, 0.0, SWELL_STENCIL_PAPER) == SWELL_OK);
		for (int j = 0; j < n; j++)
			for (int i = 0; i < n; i++) // checkerboard at 99% of the bound: the fastest-growing shape
				h[j * n + i] = ((i + j) & 1 ? 0.99 : -0.99) * f.h_max * f.lsb_mm;
		bench_field_set_mm(&f, h.data());
		for (int k = 0; k < 200; k++)
			bench_field_step(&f);
		INFO(bench_impl_name(impl) << ": max|h| " << bench_field_max_abs_lsb(&f) << " of " << f.h_max << " LSB, "
					   << f.saturations << " saturations");
		CHECK(bench_field_max_abs_lsb(&f) <= f.h_max);
		CHECK(f.saturations > 0);
		bench_field_free(&f);
	}
}

TEST_CASE("the high-word multiply proposed for wave.c equals swell_mul_q30_rn for every flow input", "[bench][fixed]")
{
	// |dh| <= 2 SWELL_H_MAX (a difference of two saturated heights), c in (0, 2) Q1.30
	bench_rng r;
	long mismatches = 0;
	const int32_t dmax = 2 * SWELL_H_MAX;
	const int32_t edges[] = {0, 1, -1, 2, -2, dmax, -dmax, dmax - 1, -dmax + 1, 12345, -12345};
	const q30_t cs[] = {1, 2, SWELL_Q30_ONE / 2, SWELL_Q30_ONE, INT32_MAX, INT32_MAX - 1, 858993459};

	bench_rng_seed(&r, 2026);
	for (int32_t d : edges)
		for (q30_t c : cs)
			mismatches += bench_mul_q30_rn_hi(d, c) != swell_mul_q30_rn(d, c);
	for (int k = 0; k < 2000000; k++) {
		int32_t d = (int32_t)(bench_rng_next(&r) % (2 * (uint64_t)dmax + 1)) - dmax;
		q30_t c = (q30_t)(bench_rng_next(&r) % (uint64_t)INT32_MAX) + 1;

		if (k & 1)
			d >>= (int)(bench_rng_next(&r) % 28); // small differences too: where rounding matters
		mismatches += bench_mul_q30_rn_hi(d, c) != swell_mul_q30_rn(d, c);
	}
	INFO(mismatches << " mismatches");
	CHECK(mismatches == 0);
}
