/* Contracts of wave.h checked where they are easiest to break: parameters changed or sleeping turned
 * on while a step is in progress, and the stability limit against the coefficients that actually run. */
#include <catch2/catch.hpp>

#include <cstring>
#include <random>

#include "wave_field.hpp"

using namespace wave_test;

namespace {

/* A 2 x 2 pool whose columns slosh as one oscillator: h = (A, -A) in both rows, t = 0, e = 1/4. */
const int32_t kA = 4 * SWELL_H_ONE_MM;

Field sloshing(swell_wave_kernel k)
{
	Field f(2, 2, SWELL_Q30_ONE / 4, 0, SWELL_STENCIL_PAPER, k);
	f.w.h[0] = f.w.h[2] = kA;
	f.w.h[1] = f.w.h[3] = -kA;
	swell_wave_rest(&f.w);
	return f;
}

} // namespace

TEST_CASE("setting the same parameters in the middle of a step changes no bit of the water", "[wave][params][sleep]")
{
	for (swell_wave_kernel k : {SWELL_KERNEL_REF, SWELL_KERNEL_FUSED}) {
		Field plain = sloshing(k), reset = sloshing(k);
		const swell_wave_params same = reset.w.p;
		bool moved = false;
		for (int n = 1; n <= 12; n++) {
			swell_wave_step_rows(&plain.w, 2);
			swell_wave_step_rows(&reset.w, 2);
			if (n == 2) /* every edge of the step done, the finish still to come */
				REQUIRE(swell_wave_set_params(&reset.w, &same) == SWELL_OK);
			swell_wave_step_finish(&plain.w);
			swell_wave_step_finish(&reset.w);
			INFO("kernel " << swell_wave_kernel_name(k) << ", step " << n << ": column 0 at " << reset.w.h[0]
				       << " LSB, untouched run " << plain.w.h[0]);
			moved |= plain.w.h[0] != kA;
			REQUIRE(differs(plain, reset, false) == "");
		}
		CHECK(moved);
		CHECK(swell_wave_volume(&reset.w) == 0);
	}
}

TEST_CASE("turning tile sleeping on in the middle of a step stays lossless", "[wave][sleep]")
{
	Field awake = sloshing(SWELL_KERNEL_REF), switched = sloshing(SWELL_KERNEL_REF);
	swell_wave_set_sleep(&awake.w, 0);
	swell_wave_set_sleep(&switched.w, 0);
	for (int n = 1; n <= 12; n++) {
		swell_wave_step_rows(&awake.w, 2);
		swell_wave_step_rows(&switched.w, 2);
		if (n == 2) /* every edge of the step done, the finish still to come */
			swell_wave_set_sleep(&switched.w, 1);
		swell_wave_step_finish(&awake.w);
		swell_wave_step_finish(&switched.w);
		INFO("step " << n << ": column 0 at " << switched.w.h[0] << " LSB with sleeping turned on, " << awake.w.h[0]
			     << " without");
		REQUIRE(differs(awake, switched, false) == "");
	}
}

namespace {

/* Von Neumann stability of the coefficients that run (wave.h): e_eff < (1 + q) / (4 q), both Q1.30,
 * decided exactly in 128 bits. */
bool stable(int64_t e_eff, int64_t q)
{
	const __int128 one = (__int128)1 << 30;
	return (__int128)4 * e_eff * q < (one + q) * one;
}

/* What wave.h says runs: e (paper) or e / 2 (calibrated) made even, 1 - t made odd when t > 0. */
int64_t run_e_eff(q30_t e, swell_stencil st) { return (st == SWELL_STENCIL_CALIBRATED ? e / 2 : e) & ~1; }
int64_t run_q(q30_t t) { return t ? (SWELL_Q30_ONE - t) | 1 : SWELL_Q30_ONE; }

} // namespace

TEST_CASE("accepted parameters are stable in the coefficients that run and e_limit is the first "
	  "refused e, to the last LSB",
	  "[wave][stability][params]")
{
	/* found by search: stable with q = 1 - t, not with the odd q that runs */
	{
		const swell_wave_params p{608207736, 225437260, SWELL_STENCIL_PAPER};
		INFO("e " << p.e << " t " << p.damping
			  << ": stable with the q that runs: " << stable(run_e_eff(p.e, p.stencil), run_q(p.damping)));
		CHECK(swell_wave_check(&p) == (stable(run_e_eff(p.e, p.stencil), run_q(p.damping)) ? SWELL_OK : SWELL_EUNSTABLE));
	}
	std::mt19937_64 rng(20261201);
	int accepted = 0, refused = 0;
	for (int k = 0; k < 20000; k++) {
		const swell_stencil st = (k & 1) ? SWELL_STENCIL_CALIBRATED : SWELL_STENCIL_PAPER;
		/* damping up to 0.45 keeps the limit inside the coefficient range; half of them even */
		q30_t t = (q30_t)(rng() % (uint64_t)(0.45 * SWELL_Q30_ONE));
		if (k & 2)
			t &= ~1;
		const q30_t lim = swell_wave_e_limit(t, st);
		const q30_t below = lim - 1;
		const swell_wave_params at{lim, t, st}, under{below, t, st};
		INFO("t " << t << " stencil " << st << ": e_limit " << lim << "; model: e_limit - 1 "
			  << (stable(run_e_eff(below, st), run_q(t)) ? "stable" : "unstable") << ", e_limit "
			  << (stable(run_e_eff(lim, st), run_q(t)) ? "stable" : "unstable"));
		REQUIRE(stable(run_e_eff(below, st), run_q(t)));
		REQUIRE(!stable(run_e_eff(lim, st), run_q(t)));
		REQUIRE(swell_wave_check(&under) == SWELL_OK);
		REQUIRE(swell_wave_check(&at) == SWELL_EUNSTABLE);
		/* and around the limit, every accepted e runs stable coefficients */
		for (q30_t e = lim - 6; e <= lim + 6; e++) {
			const swell_wave_params p{e, t, st};
			const bool ok = swell_wave_check(&p) == SWELL_OK;
			REQUIRE(ok == stable(run_e_eff(e, st), run_q(t)));
			(ok ? accepted : refused)++;
		}
	}
	CHECK(accepted > 0);
	CHECK(refused > 0);
	/* the fields' own coefficients are the ones the model assumes */
	Field f(8, 8, 215723193, 1073742, SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
	CHECK(f.w.e_eff == run_e_eff(215723193, SWELL_STENCIL_PAPER));
	CHECK(f.w.q == run_q(1073742));
}

TEST_CASE("coming to rest in the middle of a step with rows finished ahead keeps h(n) and the volume", "[wave][finish][rest]")
{
	Field f(24, 24, q30(0.2), 0, SWELL_STENCIL_PAPER, SWELL_KERNEL_REF);
	std::mt19937 rng(3);
	for (int a = 0; a < f.n(); a++)
		f.w.h[a] = (int32_t)(rng() % (4 * SWELL_H_ONE_MM)) - 2 * SWELL_H_ONE_MM;
	swell_wave_rest(&f.w);
	for (int s = 0; s < 3; s++)
		swell_wave_step(&f.w);
	const int64_t v0 = swell_wave_volume(&f.w);
	std::vector<int32_t> hn(f.w.h, f.w.h + f.n());
	swell_wave_step_rows(&f.w, 17);
	REQUIRE(f.w.done_row == 16); /* rows 0..15 hold h(n+1) now */
	swell_wave_rest(&f.w);
	INFO("volume " << swell_wave_volume(&f.w) << " LSB after the rest, " << v0 << " before the step");
	CHECK(swell_wave_volume(&f.w) == v0);
	int differ = 0;
	for (int a = 0; a < f.n(); a++)
		differ += f.w.h[a] != hn[a];
	INFO(differ << " cells differ from h(n)");
	CHECK(differ == 0);
	CHECK(f.w.done_row == 0);
	CHECK(f.w.next_row == 0);
}

TEST_CASE("malformed parameters are refused with a reason and change nothing", "[wave][params]")
{
	Field f(8, 8, q30(0.2), 0, SWELL_STENCIL_PAPER, SWELL_KERNEL_AUTO);
	std::mt19937 rng(3);
	for (int a = 0; a < f.n(); a++)
		f.w.h[a] = (int32_t)(rng() % (2 * SWELL_H_ONE_MM)) - SWELL_H_ONE_MM;
	swell_wave_rest(&f.w);
	swell_wave before = f.w;
	std::vector<int32_t> snap(f.store);
	swell_wave_params bad[] = {
		{0, 0, SWELL_STENCIL_PAPER}, /* e = 0 */
		{-q30(0.1), 0, SWELL_STENCIL_PAPER}, /* e < 0 */
		{q30(0.2), -1, SWELL_STENCIL_PAPER}, /* t < 0 */
		{q30(0.2), SWELL_Q30_ONE, SWELL_STENCIL_PAPER}, /* t = 1 */
		{q30(0.2), 0, (swell_stencil)7}, /* unknown stencil */
		{q30(1.5), q30(0.9), SWELL_STENCIL_PAPER}, /* e_eff above 1: coefficient range */
	};
	enum swell_err want[] = {SWELL_ERANGE, SWELL_ERANGE, SWELL_ERANGE, SWELL_ERANGE, SWELL_EINVAL, SWELL_ERANGE};
	for (size_t k = 0; k < sizeof(bad) / sizeof(bad[0]); k++) {
		INFO("case " << k);
		CHECK(swell_wave_set_params(&f.w, &bad[k]) == want[k]);
	}
	CHECK(swell_wave_set_params(&f.w, nullptr) == SWELL_EINVAL);
	CHECK(std::memcmp(&before, &f.w, sizeof(before)) == 0);
	CHECK(snap == f.store);

	swell_wave w{};
	std::vector<int32_t> small(SWELL_WAVE_WORDS(8, 8) - 1);
	swell_wave_params ok{q30(0.2), 0, SWELL_STENCIL_PAPER};
	CHECK(swell_wave_init(&w, 8, 8, small.data(), small.size(), &ok) == SWELL_ESIZE);
	CHECK(swell_wave_init(&w, 1, 8, small.data(), small.size(), &ok) == SWELL_ESIZE);
	CHECK(swell_wave_init(&w, 8, 2000, small.data(), small.size(), &ok) == SWELL_ESIZE);
	CHECK(w.h == nullptr);
	q30_t e = 77;
	CHECK(swell_wave_e_from_physical(9810, 0, 50000, 6250, &e) == SWELL_ERANGE);
	CHECK(swell_wave_e_from_physical(9810, 400000, 50000, 6250, &e) == SWELL_ERANGE); /* e >= 2 */
	CHECK(e == 77);
}
