/* Contracts of wave.h checked where they are easiest to break: parameters changed or sleeping turned
 * on while a step is in progress. */
#include <catch2/catch.hpp>

#include "wave_field.hpp"

using namespace wave_test;

namespace {

/* A 2 x 2 pool whose columns slosh as one oscillator: h = (A, -A) in both rows, t = 0, e = 1/4. Every
 * edge product is exact (A a multiple of 4 LSB); the total flow into column 0 is F(n+1) = F(n) - x(n)
 * and x(n+1) = x(n) + F(n+1): x = A, 0, -A, -A, 0, A, A, ... (period 6), and every flow is exactly 0
 * after step 3 although it was -3A/4 (E) and -A/4 (NE) after step 2. */
const int32_t kA = 4 * SWELL_H_ONE_MM;

Field sloshing(swell_wave_kernel k)
{
	Field f(2, 2, SWELL_Q30_ONE / 4, 0, SWELL_STENCIL_PAPER, k);
	f.w.h[0] = f.w.h[2] = kA;
	f.w.h[1] = f.w.h[3] = -kA;
	swell_wave_rest(&f.w);
	return f;
}

/* x(n) of column 0 for n = 1 .. steps, the exact sequence above */
int32_t exact_x(int n)
{
	static const int32_t x[6] = {kA, 0, -kA, -kA, 0, kA};
	return x[n % 6];
}

} // namespace

TEST_CASE("setting the same parameters in the middle of a step changes no bit of the water",
	  "[wave][params][sleep]")
{
	for (swell_wave_kernel k : {SWELL_KERNEL_REF, SWELL_KERNEL_FUSED}) {
		Field plain = sloshing(k), reset = sloshing(k);
		const swell_wave_params same = reset.w.p;
		for (int n = 1; n <= 12; n++) {
			swell_wave_step_rows(&plain.w, 2);
			swell_wave_step_rows(&reset.w, 2);
			if (n == 2) /* every edge of the step done, the finish still to come */
				REQUIRE(swell_wave_set_params(&reset.w, &same) == SWELL_OK);
			swell_wave_step_finish(&plain.w);
			swell_wave_step_finish(&reset.w);
			INFO("kernel " << swell_wave_kernel_name(k) << ", step " << n << ": column 0 at "
				       << reset.w.h[0] << " LSB, untouched run " << plain.w.h[0] << ", exact "
				       << exact_x(n));
			REQUIRE(plain.w.h[0] == exact_x(n));
			REQUIRE(differs(plain, reset, false) == "");
		}
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
		INFO("step " << n << ": column 0 at " << switched.w.h[0] << " LSB with sleeping turned on, "
			     << awake.w.h[0] << " without, exact " << exact_x(n));
		REQUIRE(awake.w.h[0] == exact_x(n));
		REQUIRE(differs(awake, switched, false) == "");
	}
}

