/* The velocity form's rest property (docs/fixed-point.md, "The velocity form"): damped water comes
 * to rest. After random pushes and 4000 free damped steps, h and u must stay exactly as they are over
 * each of the next 16 steps (a limit cycle of any period up to 16 fails it, whatever its phase). */
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "wave_field.hpp"

using wave_test::Field;
using wave_test::q30;

namespace {

/* Random pushes that conserve volume: +k under one square footprint, -k under another, as the body's
 * coupling does; the footprint's side is at most a quarter of the pool's. */
void push(Field &f, std::mt19937 &rng, int32_t k)
{
	const int side = std::max(2, std::min(f.w.nx, f.w.ny) / 4);
	std::uniform_int_distribution<int> xi(0, f.w.nx - side), yj(0, f.w.ny - side);
	const int x0 = xi(rng), y0 = yj(rng), x1 = xi(rng), y1 = yj(rng);

	for (int j = 0; j < side; j++)
		for (int i = 0; i < side; i++) {
			swell_wave_add(&f.w, x0 + i, y0 + j, k);
			swell_wave_add(&f.w, x1 + i, y1 + j, -k);
		}
}

/* The first step of the 16 after the free run where h or u changed (0 when none did), and the largest
 * |h| change a step over them. */
struct Motion {
	int first = 0;
	int32_t max_dh = 0, max_du = 0;
};

Motion motion_over(Field &f, int steps)
{
	const std::vector<int32_t> h(f.w.h, f.w.h + f.n()), u(f.w.u, f.w.u + f.n());
	Motion m;

	for (int s = 1; s <= steps; s++) {
		swell_wave_step(&f.w);
		for (int a = 0; a < f.n(); a++) {
			const int32_t dh = std::abs(f.w.h[a] - h[(size_t)a]), du = std::abs(f.w.u[a] - u[(size_t)a]);
			if ((dh || du) && !m.first)
				m.first = s;
			m.max_dh = std::max(m.max_dh, dh);
			m.max_du = std::max(m.max_du, du);
		}
	}
	return m;
}

struct Pool {
	int nx, ny, seeds;
};

} // namespace

TEST_CASE("velocity form: damped water comes to rest (h and u unchanged over 16 steps after 4000 free "
	  "steps): many seeds, e 0.05 to 0.45, t 0.001 and 0.02, both stencils",
	  "[wave][velocity][rest]")
{
	/* 16 seeds on small pools (one 8 x 8 tile and ragged 20 x 12), 2 more on 64 x 64 */
	const Pool pools[] = {{16, 16, 6}, {24, 24, 6}, {20, 12, 4}, {64, 64, 2}};
	int cases = 0, failed = 0;
	std::ostringstream fails;

	for (swell_stencil st : {SWELL_STENCIL_PAPER, SWELL_STENCIL_CALIBRATED})
		for (double e : {0.05, 0.2, 0.35, 0.45})
			for (double t : {0.001, 0.02})
				for (const Pool &p : pools)
					for (int seed = 0; seed < p.seeds; seed++) {
						Field f(p.nx, p.ny, q30(e), q30(t), st, SWELL_KERNEL_FUSED);
						std::mt19937 rng((uint32_t)(1000 * p.nx + seed));
						/* pushes up to +-0.3 mm at t 0.02, +-0.03 mm at t 0.001 (whose linear decay
						 * over 4000 steps is only e^-2: larger waves are still decaying, not cycling) */
						const int32_t kmax = t < 0.01 ? 1966 : 19661;
						std::uniform_int_distribution<int32_t> k(-kmax, kmax);
						int32_t moved = 0;

						for (int s = 0; s < 200; s++) {
							if (s % 4 == 0)
								push(f, rng, k(rng));
							swell_wave_step(&f.w);
							for (int a = 0; a < f.n(); a++)
								moved = std::max(moved, std::abs(swell_wave_dh(&f.w, (size_t)a)));
						}
						REQUIRE(moved > 0); /* the pushes did move the water */
						for (int s = 0; s < 4000; s++)
							swell_wave_step(&f.w);
						const Motion m = motion_over(f, 16);
						cases++;
						if (m.first) {
							failed++;
							fails << "\n  " << (st == SWELL_STENCIL_PAPER ? "paper" : "calibrated")
							      << " e " << e << " t " << t << " " << p.nx << "x" << p.ny
							      << " seed " << seed << ": moves at step " << m.first
							      << " of 16, |dh| " << m.max_dh << " |du| " << m.max_du << " LSB";
						}
						CHECK(f.w.saturations == 0);
					}
	INFO(failed << " of " << cases << " cases still move after 4000 free steps:" << fails.str());
	CHECK(cases == 2 * 4 * 2 * 18);
	CHECK(failed == 0);
}
