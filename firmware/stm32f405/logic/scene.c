#include "scene.h"

#include "swell/shape.h"

enum swell_err fw_scene_init(struct swell_wave *w, int32_t *storage, size_t words)
{
	struct swell_wave_params p = {.damping = 0, .stencil = SWELL_STENCIL_PAPER};
	enum swell_err err;

	err = swell_wave_e_from_physical(FW_SCENE_G_MM_S2, FW_SCENE_DT_US, FW_SCENE_DEPTH_UM,
					 FW_SCENE_DX_UM, &p.e);
	if (err != SWELL_OK)
		return err;
	err = swell_wave_init(w, FW_SCENE_NX, FW_SCENE_NY, storage, words, &p);
	if (err != SWELL_OK)
		return err;
	swell_shape_gauss(w->h, w->nx, w->ny, 32 * SWELL_Q16_ONE, 32 * SWELL_Q16_ONE, 3 * SWELL_Q16_ONE,
			  2 * SWELL_H_ONE_MM);
	swell_wave_rest(w);
	return SWELL_OK;
}
