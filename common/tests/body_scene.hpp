// A pool with one object for the body tests: the reference scene of docs/design.md, section 4 (64 x 64 cells of
// 6.25 mm, 50 mm deep, solver at 250 Hz, device at 2500 Hz) unless a test asks for another.
#pragma once

#include <cstdint>
#include <vector>

extern "C" {
#include "swell/body.h"
#include "swell/body_free.h"
#include "swell/wave.h"
}

struct body_scene {
	std::vector<int32_t> store;
	swell_wave w{};
	swell_body b{};
	swell_body_params p{};
	swell_body_xform xf{};
	swell_body_scene sc{};
	uint64_t count = 0; // device ticks so far
	bool interpolate = true; // false: never tell the body of solver steps (it reads h(n) only)

	explicit body_scene(uint16_t n = 64, double damping = 0.0, uint32_t dx_um = 6250)
	{
		swell_wave_params wp{};
		q30_t e = 0;
		swell_wave_e_from_physical(9810, 4000, 50000, dx_um, &e);
		wp.e = e;
		wp.damping = (q30_t)(damping * SWELL_Q30_ONE);
		wp.stencil = SWELL_STENCIL_PAPER;
		store.assign(SWELL_WAVE_WORDS(n, n), 0);
		swell_wave_init(&w, n, n, store.data(), store.size(), &wp);
		p = default_params();
		xf = identity();
		sc = {dx_um, 2500, 250};
		swell_body_init(&b, &p, &xf, &sc, &w);
	}

	static swell_body_params default_params()
	{
		swell_body_params q{};
		q.a_um = 60000;
		q.b_um = 60000;
		q.h_um = 40000;
		q.mass_g = 60;
		q.rho_kg_m3 = 1000;
		q.g_mm_s2 = 9810;
		q.damper_uN_per_mm_s = 3000;
		q.deadband_um = 0;
		return q;
	}

	static swell_body_xform identity()
	{
		swell_body_xform x{};
		x.scale = SWELL_Q16_ONE;
		for (int k = 0; k < 3; k++) {
			x.axis[k] = (uint8_t)k;
			x.sign[k] = 1;
		}
		return x;
	}

	// One device tick: the solver steps first whenever a solver period starts.
	void tick(int32_t x, int32_t y, int32_t z, int32_t vz, swell_body_out *out)
	{
		if (count % b.ticks_per_step == 0 && count > 0) {
			swell_wave_step(&w);
			if (interpolate)
				swell_body_solver_stepped(&b, &w);
		}
		int32_t pos[3] = {x, y, z}, vel[3] = {0, 0, vz};
		swell_body_tick(&b, &w, pos, vel, out);
		count++;
	}
};
