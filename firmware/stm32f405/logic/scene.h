/* The reference scene of the controller self-test ("pool", docs/design.md): 64 x 64 cells, dx 6.25 mm,
 * depth 50 mm, dt 4 ms (e = g dt^2 d / dx^2 with g = 9.81 m/s^2), paper stencil, no damping, a
 * Gaussian bump of 2 mm, sigma 3 cells, at cell (32, 32), water at rest. Integer-only set-up, so the
 * image and the host start from the same bits (same as `swell-sim --grid 64x64 --dt 0.004
 * --depth 0.05 --dx 0.00625 --init gauss:32,32,3,2`). */
#ifndef SWELL_FW_SCENE_H
#define SWELL_FW_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"
#include "swell/pool.h"
#include "swell/wave.h"

#define FW_SCENE_NX SWELL_POOL_N
#define FW_SCENE_NY SWELL_POOL_N
#define FW_SCENE_WORDS SWELL_WAVE_WORDS(FW_SCENE_NX, FW_SCENE_NY)
#define FW_SCENE_G_MM_S2 9810u
#define FW_SCENE_DT_US 4000u
#define FW_SCENE_DEPTH_UM ((uint32_t)SWELL_POOL_DEPTH_UM)
#define FW_SCENE_DX_UM ((uint32_t)SWELL_POOL_DX_UM)

/* Bind storage (FW_SCENE_WORDS words) and set the initial field (undamped: the kernel runs with
 * fraction bits in u). */
enum swell_err fw_scene_init(struct swell_wave *w, int32_t *storage, size_t words);

/* The three cost scenes (calm, local, agitated), on the same pool with damping t = 0.001 (the demo's), so that
 * the damped kernel runs: CALM, the water at rest; LOCAL, one 2 mm splash of sigma 2 cells at
 * (12, 12), FW_COST_STEPS steps from its start; AGITATED, every cell random in [-2, 2] mm (a fixed
 * integer generator). */
enum fw_cost_scene {
	FW_COST_CALM,
	FW_COST_LOCAL,
	FW_COST_AGITATED,
	FW_COST_SCENES
};
#define FW_COST_STEPS 40u
#define FW_COST_DAMPING 1073742 /* t = 0.001 in Q1.30 */

extern const char *const fw_cost_scene_name[FW_COST_SCENES];

enum swell_err fw_cost_scene_init(struct swell_wave *w, int32_t *storage, size_t words, enum fw_cost_scene s);

#endif
