#include "scene.h"

#include "swell/shape.h"

/* The scene's grid at rest level with the paper's stencil and the given damping. */
static enum swell_err scene_wave(struct swell_wave *w, int32_t *storage, size_t words, q30_t damping)
{
	struct swell_wave_params p = { .damping = damping, .stencil = SWELL_STENCIL_PAPER };
	enum swell_err err;

	err = swell_wave_e_from_physical(FW_SCENE_G_MM_S2, FW_SCENE_DT_US, FW_SCENE_DEPTH_UM, FW_SCENE_DX_UM, &p.e);
	return err != SWELL_OK ? err : swell_wave_init(w, FW_SCENE_NX, FW_SCENE_NY, storage, words, &p);
}

enum swell_err fw_scene_init(struct swell_wave *w, int32_t *storage, size_t words)
{
	enum swell_err err = scene_wave(w, storage, words, 0);

	if (err != SWELL_OK)
		return err;
	swell_shape_gauss(w->h, w->nx, w->ny, 32 * SWELL_Q16_ONE, 32 * SWELL_Q16_ONE, 3 * SWELL_Q16_ONE,
			  2 * SWELL_H_ONE_MM);
	swell_wave_rest(w);
	return SWELL_OK;
}

const char *const fw_cost_scene_name[FW_COST_SCENES] = { "calm", "local", "agitated" };

enum swell_err fw_cost_scene_init(struct swell_wave *w, int32_t *storage, size_t words, enum fw_cost_scene s)
{
	enum swell_err err =
		(unsigned)s < FW_COST_SCENES ? scene_wave(w, storage, words, FW_COST_DAMPING) : SWELL_EINVAL;
	uint32_t x = 12345u;
	int a;

	if (err != SWELL_OK)
		return err;
	if (s == FW_COST_LOCAL)
		swell_shape_gauss(w->h, w->nx, w->ny, 12 * SWELL_Q16_ONE, 12 * SWELL_Q16_ONE, 2 * SWELL_Q16_ONE,
				  2 * SWELL_H_ONE_MM);
	if (s == FW_COST_AGITATED) {
		for (a = 0; a < FW_SCENE_NX * FW_SCENE_NY; a++) { /* xorshift32 */
			x ^= x << 13;
			x ^= x >> 17;
			x ^= x << 5;
			w->h[a] = (int32_t)(x % (4u * SWELL_H_ONE_MM + 1u)) - 2 * SWELL_H_ONE_MM;
		}
	}
	swell_wave_rest(w);
	return SWELL_OK;
}
