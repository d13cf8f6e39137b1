/* Properties of ef32, the bench's edge-flux form of eq. (1) (ef32/ef32.c), against exact and float64
 * references: volume, energy, eigenmode error, the stability boundary, saturation, sleeping tiles. */
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

extern "C" {
#include "swell/shape.h"
#include "swell/wave.h"
#include "swell/wave_ref.h"
#include "ef32/ef32.h"
}

namespace {

constexpr double kLsbMm = 1.0 / SWELL_H_ONE_MM;

q30_t q30(double x) { return (q30_t)std::llround(x * SWELL_Q30_ONE); }

/* An ef32 field with its own storage. */
struct Field {
	std::vector<int32_t> store;
	ef32 w{};
	Field(int nx, int ny, double e, double t = 0, swell_stencil st = SWELL_STENCIL_PAPER) : store(EF32_WORDS(nx, ny))
	{
		swell_wave_params p{q30(e), q30(t), st};
		REQUIRE(ef32_init(&w, (uint16_t)nx, (uint16_t)ny, store.data(), store.size(), &p) == SWELL_OK);
	}
	int n() const { return w.nx * w.ny; }
	void random(uint32_t seed, double amp_mm)
	{
		std::mt19937 rng(seed);
		std::uniform_int_distribution<int32_t> d(-(int32_t)(amp_mm * SWELL_H_ONE_MM), (int32_t)(amp_mm * SWELL_H_ONE_MM));
		for (int a = 0; a < n(); a++)
			w.h[a] = d(rng);
		ef32_rest(&w);
	}
	/* E * 2^31 exactly, as a 128-bit integer. */
	__int128 energy() const
	{
		swell_energy en = ef32_energy(&w);
		return (__int128)en.kin * ((__int128)1 << 31) + (__int128)en.e_eff * en.pot2;
	}
	int32_t max_abs() const
	{
		int32_t m = 0;
		for (int a = 0; a < n(); a++)
			m = std::max(m, std::abs(w.h[a]));
		return m;
	}
};

double to_double(__int128 x) { return (double)x; }

/* The float64 reference of f's scheme at rest at its heights, h(n-1) = h - v (its e_eff and q). */
void ref_from_ef32(swell_wave_ref *r, const ef32 *w, double *storage)
{
	const int n = w->nx * w->ny;
	r->nx = w->nx;
	r->ny = w->ny;
	r->h = storage;
	r->hp = storage + n;
	r->next = storage + 2 * n;
	r->e_eff = (double)w->e_eff / SWELL_Q30_ONE;
	r->q = (double)w->q / SWELL_Q30_ONE;
	r->steps = 0;
	for (int a = 0; a < n; a++) {
		r->h[a] = (double)w->h[a] / SWELL_H_ONE_MM;
		r->hp[a] = r->h[a] - (double)w->v[a] / SWELL_H_ONE_MM;
	}
}

/* The (m, n) eigenmode's discrete angular step for e_eff: cos(omega) = 1 + e_eff S / 2. */
double discrete_omega(int nx, int ny, int m, int n, double e_eff)
{
	double a = m * M_PI / nx, b = n * M_PI / ny;
	double s = -8 + 2 * (1 + std::cos(a)) * (1 + std::cos(b));
	return std::acos(1 + e_eff * s / 2);
}

} // namespace

TEST_CASE("a seiche eigenmode follows the exact discrete solution to rounding error, both stencils", "[wave][eigenmode]")
{
	const int nx = 64, ny = 64, m = 2, n = 1, steps = 2000;
	const double amp_mm = 2.0;
	/* pool scene: g 9.81, dt 4 ms, depth 50 mm, dx 6.25 mm */
	q30_t e;
	REQUIRE(swell_wave_e_from_physical(9810, 4000, 50000, 6250, &e) == SWELL_OK);
	CHECK(std::fabs((double)e / SWELL_Q30_ONE - 9.81 * 0.004 * 0.004 * 0.05 / (0.00625 * 0.00625)) < 1e-8);

	for (swell_stencil st : {SWELL_STENCIL_PAPER, SWELL_STENCIL_CALIBRATED}) {
		Field f(nx, ny, (double)e / SWELL_Q30_ONE, 0, st);
		swell_shape_seiche(f.w.h, nx, ny, m, n, (int32_t)(amp_mm * SWELL_H_ONE_MM));
		ef32_rest(&f.w);
		std::vector<double> ref_store(SWELL_WAVE_REF_DOUBLES(nx, ny));
		swell_wave_ref r;
		ref_from_ef32(&r, &f.w, ref_store.data());

		const double e_eff = (double)f.w.e_eff / SWELL_Q30_ONE;
		const double om = discrete_omega(nx, ny, m, n, e_eff);
		/* continuous seiche: omega = sqrt(g d) pi sqrt((m/Lx)^2 + (n/Ly)^2), per 4 ms step */
		const double lx = nx * 0.00625, ly = ny * 0.00625;
		const double om_c = std::sqrt(9.81 * 0.05) * M_PI * std::hypot(m / lx, n / ly) * 0.004;
		double err_fixed = 0, err_ref = 0, err_cont = 0, l2_fixed = 0;
		for (int k = 1; k <= steps; k++) {
			ef32_step(&f.w);
			swell_wave_ref_step(&r);
			/* at rest at n = 0 means h(-1) = h(0): c_k = cos(omega (k + 1/2)) / cos(omega / 2) */
			double c = std::cos(om * (k + 0.5)) / std::cos(om / 2);
			double cc = std::cos(om_c * k);
			double l2 = 0;
			for (int j = 0; j < ny; j++)
				for (int i = 0; i < nx; i++) {
					double mode = amp_mm * std::cos(m * M_PI * (i + 0.5) / nx) *
						std::cos(n * M_PI * (j + 0.5) / ny);
					int a = j * nx + i;
					double hf = f.w.h[a] * kLsbMm;
					err_fixed = std::max(err_fixed, std::fabs(hf - c * mode));
					err_ref = std::max(err_ref, std::fabs(r.h[a] - c * mode));
					err_cont = std::max(err_cont, std::fabs(hf - cc * mode));
					l2 += (hf - c * mode) * (hf - c * mode);
				}
			l2_fixed = std::max(l2_fixed, std::sqrt(l2 / (nx * ny)));
		}
		const char *name = st == SWELL_STENCIL_PAPER ? "paper" : "calibrated";
		WARN("stencil " << name << ", mode (" << m << "," << n << "), " << steps << " steps, A = " << amp_mm
				<< " mm: fixed vs exact discrete Linf " << err_fixed << " mm (" << err_fixed / kLsbMm
				<< " LSB), L2 " << l2_fixed << " mm; float64 vs exact " << err_ref
				<< " mm; fixed vs continuous seiche Linf " << err_cont << " mm; omega_discrete/omega_continuous "
				<< om / om_c);
		/* float64 starts from the same integer field: the initial rounding (<= 0.5 LSB a cell) excites
		 * other modes by that much, nothing more */
		CHECK(err_ref < 3 * kLsbMm);
		/* fixed point: rounding of every flux increment, accumulated over 2000 steps (8 s): measured
		 * about 1e-3 of the amplitude; a wrong coefficient or wall weight would be of order 1 */
		CHECK(err_fixed < 2e-3 * amp_mm);
		if (st == SWELL_STENCIL_PAPER) {
			CHECK(om / om_c == Approx(std::sqrt(2.0)).epsilon(0.01)); /* waves sqrt(2) too fast */
		} else {
			CHECK(om / om_c == Approx(1.0).epsilon(0.01));
			/* calibrated: discretisation error after 8 s stays a fraction of the amplitude */
			CHECK(err_cont < 0.1 * amp_mm);
		}
	}
}

TEST_CASE("ef32 equals the float64 three-level eq. (1) to rounding, walls included", "[wave][reference]")
{
	struct Case {
		int nx, ny;
		double e, t;
		swell_stencil st;
	} cases[] = {{17, 9, 0.2, 0, SWELL_STENCIL_PAPER},
		     {9, 17, 0.49, 0, SWELL_STENCIL_PAPER},
		     {16, 16, 0.3, 0.05, SWELL_STENCIL_PAPER},
		     {12, 20, 0.9, 0.02, SWELL_STENCIL_CALIBRATED},
		     {2, 2, 0.45, 0, SWELL_STENCIL_PAPER}};
	for (const Case &c : cases) {
		Field f(c.nx, c.ny, c.e, c.t, c.st);
		f.random(11, 5.0);
		std::vector<double> rs(SWELL_WAVE_REF_DOUBLES(c.nx, c.ny));
		swell_wave_ref r;
		ref_from_ef32(&r, &f.w, rs.data());
		double worst = 0;
		for (int k = 0; k < 300; k++) {
			ef32_step(&f.w);
			swell_wave_ref_step(&r);
			for (int a = 0; a < f.n(); a++)
				worst = std::max(worst, std::fabs(f.w.h[a] * kLsbMm - r.h[a]));
		}
		INFO(c.nx << "x" << c.ny << " e " << c.e << " t " << c.t << ": worst difference " << worst
			  << " mm = " << worst / kLsbMm << " LSB after 300 steps");
		/* Rounding (and, with damping, the toward-zero rounding of the damping product, which damps
		 * by up to one extra LSB an edge a step) stays below 1% of the 5 mm field; a wrong wall
		 * weight or sign shows up as a difference of the order of the field itself. */
		CHECK(worst < 0.01 * 5.0);
	}
}

TEST_CASE("volume is conserved exactly over 1e6 cell-steps from random fields, with and without damping", "[wave][volume]")
{
	for (double t : {0.0, 0.001, 0.05, 0.5}) {
		for (swell_stencil st : {SWELL_STENCIL_PAPER, SWELL_STENCIL_CALIBRATED}) {
			const double lim = (double)swell_wave_e_limit(q30(t), st) / SWELL_Q30_ONE;
			Field f(32, 32, std::min(0.98 * lim, 1.9), t, st);
			f.random(1234, 20.0);
			const int64_t v0 = ef32_volume(&f.w);
			long long worst = 0;
			for (int k = 0; k < 1000; k++) { /* 1000 steps x 1024 cells */
				ef32_step(&f.w);
				worst = std::max(worst, std::llabs(ef32_volume(&f.w) - v0));
			}
			INFO("t " << t << " stencil " << st << ": worst volume drift " << worst << " LSB");
			CHECK(worst == 0);
			CHECK(f.w.saturations == 0u);
		}
	}
}

TEST_CASE("energy never increases with damping and stays bounded without", "[wave][energy]")
{
	SECTION("no damping: the exact integer energy drifts by rounding only")
	{
		Field f(32, 32, 0.45);
		f.random(5, 10.0);
		const double e0 = to_double(f.energy());
		double worst = 0;
		for (int k = 0; k < 5000; k++) {
			ef32_step(&f.w);
			worst = std::max(worst, std::fabs(to_double(f.energy()) - e0) / e0);
		}
		WARN("t = 0, e = 0.45, 5000 steps: worst relative energy drift " << worst);
		CHECK(e0 > 0);
		CHECK(worst < 1e-3);
	}
	SECTION("damping: energy is non-increasing at every step, down to the rounding floor")
	{
		/* Flux increments are rounded to nearest, so once flows are a few LSB the rounding can add
		 * up to ~1 LSB^2 an edge in a step. A rise is allowed only below that floor: 4 LSB^2 times
		 * the number of edges (in E * 2^31 units). */
		for (double t : {0.001, 0.01, 0.2}) {
			Field f(32, 32, 0.3, t);
			f.random(6, 10.0);
			__int128 prev = f.energy();
			const __int128 e0 = prev;
			int rises = 0, big_rises = 0;
			double worst_rise = 0;
			const __int128 floor_ = (__int128)4 * 4 * 32 * 32 * ((__int128)1 << 31);
			for (int k = 0; k < 3000; k++) {
				ef32_step(&f.w);
				__int128 now = f.energy();
				if (now > prev) {
					rises++;
					big_rises += now - prev > floor_;
					worst_rise = std::max(worst_rise, to_double(now - prev) / to_double(e0));
				}
				prev = now;
			}
			WARN("t " << t << ": " << rises
				  << " of 3000 steps where energy rose (all at the rounding "
				     "floor), worst rise "
				  << worst_rise << " of E0; final E/E0 " << to_double(prev) / to_double(e0));
			CHECK(big_rises == 0);
			CHECK(to_double(prev) < 0.1 * to_double(e0));
		}
	}
}

TEST_CASE("just under the stability limit stays bounded for 1e5 steps, at or over it is refused", "[wave][stability]")
{
	for (double t : {0.0, 0.1}) {
		const q30_t lim = swell_wave_e_limit(q30(t), SWELL_STENCIL_PAPER);
		std::vector<int32_t> store(EF32_WORDS(12, 12));
		ef32 w;
		swell_wave_params under{lim - 2, q30(t), SWELL_STENCIL_PAPER};
		REQUIRE(ef32_init(&w, 12, 12, store.data(), store.size(), &under) == SWELL_OK);
		std::mt19937 rng(99);
		for (int a = 0; a < 144; a++)
			w.h[a] = (int32_t)(rng() % (2 * SWELL_H_ONE_MM)) - SWELL_H_ONE_MM;
		ef32_rest(&w);
		int32_t start = 0, worst = 0;
		for (int a = 0; a < 144; a++)
			start = std::max(start, std::abs(w.h[a]));
		for (int k = 0; k < 100000; k++) {
			ef32_step(&w);
			if ((k & 255) == 0)
				for (int a = 0; a < 144; a++)
					worst = std::max(worst, std::abs(w.h[a]));
		}
		INFO("t " << t << ": e = limit - 2^-29, max |h| " << worst * kLsbMm << " mm from " << start * kLsbMm << " mm");
		CHECK(w.saturations == 0u);
		CHECK(worst < 20 * start);

		/* at the limit and just over: refused, state untouched */
		std::vector<int32_t> snap(store);
		for (q30_t e : {lim, lim + 2, lim + 1000}) {
			swell_wave_params over{e, q30(t), SWELL_STENCIL_PAPER};
			CHECK(swell_wave_check(&over) == SWELL_EUNSTABLE);
			ef32 fresh{};
			CHECK(ef32_init(&fresh, 12, 12, store.data(), store.size(), &over) == SWELL_EUNSTABLE);
			CHECK(fresh.h == nullptr);
		}
		CHECK(snap == store);
	}
	/* the analytic limit (1+q)/(4q) */
	CHECK((double)swell_wave_e_limit(0, SWELL_STENCIL_PAPER) / SWELL_Q30_ONE == Approx(0.5).epsilon(1e-9));
	CHECK((double)swell_wave_e_limit(q30(0.1), SWELL_STENCIL_PAPER) / SWELL_Q30_ONE == Approx(1.9 / 3.6).epsilon(1e-8));
	CHECK((double)swell_wave_e_limit(0, SWELL_STENCIL_CALIBRATED) / SWELL_Q30_ONE == Approx(1.0).epsilon(1e-9));
}

TEST_CASE("extreme inputs saturate at the int28 bounds (+-2048 mm) and never wrap", "[wave][saturation]")
{
	Field f(16, 16, 0.49);
	for (int j = 0; j < 16; j++)
		for (int i = 0; i < 16; i++) /* checkerboard at full scale: the fastest, largest mode */
			f.w.h[j * 16 + i] = ((i + j) & 1) ? SWELL_H_MAX : -SWELL_H_MAX;
	ef32_rest(&f.w);
	for (int k = 0; k < 2000; k++) {
		ef32_step(&f.w);
		for (int a = 0; a < f.n(); a++) {
			REQUIRE(f.w.h[a] <= SWELL_H_MAX);
			REQUIRE(f.w.h[a] >= SWELL_H_MIN);
		}
	}
	INFO("saturations " << f.w.saturations);
	CHECK(f.w.saturations > 0u);
	/* saturated initial shapes clamp too */
	std::vector<int32_t> h(64, SWELL_H_MAX - 5);
	swell_shape_gauss(h.data(), 8, 8, 4 << 16, 4 << 16, 2 << 16, SWELL_H_MAX);
	for (int32_t x : h)
		CHECK(x == SWELL_H_MAX);
}

TEST_CASE("sleeping tiles are lossless: bit-identical to the full update, splash, touches and all", "[wave][sleep]")
{
	for (double t : {0.0, 0.02}) {
		Field awake(45, 37, 0.3, t), sleepy(45, 37, 0.3, t);
		ef32_set_sleep(&awake.w, 0);
		/* one local splash in a calm pool */
		for (Field *f : {&awake, &sleepy}) {
			swell_shape_gauss(f->w.h, 45, 37, 10 << 16, 8 << 16, 1 << 16, 3 * SWELL_H_ONE_MM);
			ef32_rest(&f->w);
		}
		std::mt19937 rng(17);
		for (int k = 0; k < 3000; k++) {
			if (k % 97 == 50) { /* water moved in from outside */
				int i = (int)(rng() % 45), j = (int)(rng() % 37);
				int32_t d = (int32_t)(rng() % 2000) - 1000;
				for (Field *f : {&awake, &sleepy}) {
					f->w.h[(j * 45 + 44 - i)] += d;
					ef32_touched(&f->w, 44 - i, j);
				}
			}
			if (k % 89 == 30) { /* a second write, inside the grid */
				int i = (int)(rng() % 45), j = 12 + (int)(rng() % 20);
				int32_t d = (int32_t)(rng() % 4000) - 2000;
				for (Field *f : {&awake, &sleepy}) {
					f->w.h[j * 45 + i] += d;
					ef32_touched(&f->w, i, j);
				}
			}
			ef32_step(&awake.w);
			ef32_step(&sleepy.w);
			REQUIRE(ef32_checksum(&awake.w) == ef32_checksum(&sleepy.w));
		}
		CHECK(std::equal(awake.w.v, awake.w.v + awake.n(), sleepy.w.v));
		const double total = 3000.0 * 37 * sleepy.w.tiles_x;
		WARN("t " << t << ": " << sleepy.w.tiles_skipped << " of " << total << " tile-rows skipped ("
			  << 100.0 * sleepy.w.tiles_skipped / total << "%)");
		CHECK(awake.w.tiles_skipped == 0u);
		if (t > 0)
			CHECK(sleepy.w.tiles_skipped > 0u);
	}
	/* a calm pool costs nothing after the first two steps */
	Field calm(64, 64, 0.2);
	ef32_step(&calm.w);
	ef32_step(&calm.w);
	const uint32_t before = calm.w.tiles_skipped;
	for (int k = 0; k < 10; k++)
		ef32_step(&calm.w);
	CHECK(calm.w.tiles_skipped - before == 10u * 64 * 8);
}

TEST_CASE("ef32 gives the edge-flux form's former bits: the pool scene and the three cost scenes", "[wave][bits]")
{
	/* The controller self-test's scenes (64 x 64 pool, firmware/stm32f405/logic/scene.h) as the
	 * edge-flux form ran them when it was the library's: 200 undamped steps of the 2 mm splash, and 40
	 * damped steps (t = 0.001) of the calm, local and agitated pools. Every kernel gives these bits. */
	q30_t e;
	REQUIRE(swell_wave_e_from_physical(9810, 4000, 50000, 6250, &e) == SWELL_OK);
	const uint32_t want[4] = {0xa9eda8d4u, 0xa7a90a69u, 0x5debd93au, 0x8cb93cd2u};
	for (int sc = 0; sc < 4; sc++) {
		for (swell_wave_kernel k : {SWELL_KERNEL_REF, SWELL_KERNEL_FUSED, SWELL_KERNEL_AVX2}) {
			Field f(64, 64, (double)e / SWELL_Q30_ONE, sc ? 0.001 : 0);
			if (ef32_set_kernel(&f.w, k) != SWELL_OK)
				continue; /* AVX2 on a CPU without it */
			REQUIRE(f.w.p.damping == (sc ? 1073742 : 0)); /* t = 0.001 as the scene sets it */
			if (sc == 0)
				swell_shape_gauss(f.w.h, 64, 64, 32 << 16, 32 << 16, 3 << 16, 2 * SWELL_H_ONE_MM);
			if (sc == 2)
				swell_shape_gauss(f.w.h, 64, 64, 12 << 16, 12 << 16, 2 << 16, 2 * SWELL_H_ONE_MM);
			uint32_t x = 12345u;
			for (int a = 0; sc == 3 && a < 64 * 64; a++) { /* xorshift32, as the scene */
				x ^= x << 13;
				x ^= x >> 17;
				x ^= x << 5;
				f.w.h[a] = (int32_t)(x % (4u * SWELL_H_ONE_MM + 1u)) - 2 * SWELL_H_ONE_MM;
			}
			ef32_rest(&f.w);
			for (int s = 0; s < (sc ? 40 : 200); s++)
				ef32_step(&f.w);
			INFO("scene " << sc << " kernel " << swell_wave_kernel_name(k));
			CHECK(ef32_checksum(&f.w) == want[sc]);
		}
	}
}
