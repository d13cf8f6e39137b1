/* A known scene, encoded with the real common/ encoders into the packets a controller sends
 * (scene description, height quads of every tile, object pose and force, heartbeat). It is what the
 * gui tests and the built-in `pattern` source feed to the viewer, so that they exercise the same
 * decode path as live data without a controller. */
#ifndef SWELL_VIEW_GEN_H
#define SWELL_VIEW_GEN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"

struct gen_scene {
	uint16_t nx, ny;
	uint16_t dx_um;
	uint16_t depth_10um;
	uint8_t scene_id;
	/* a Gaussian bump on the water */
	int32_t bump_x_um, bump_y_um, bump_sigma_um, bump_amp_um;
	/* optional travelling ripple for the demo pattern: amplitude and wavelength, um; speed um/s */
	int32_t ripple_amp_um, ripple_len_um, ripple_speed_um_s;
	/* optional wake of the object (pattern wake): rings running out from its footprint's edge,
	 * amplitude and wavelength um, speed um/s, fading over two wavelengths */
	int32_t wake_amp_um, wake_len_um, wake_speed_um_s;
	/* object */
	int16_t obj_x_10um, obj_y_10um, obj_z_10um;
	uint8_t submersion_halfpct;
	int16_t fx_cN, fy_cN, fz_cN;
	/* optional bobbing of the object (pattern bob): z, submersion and fz move as sines of one period */
	uint32_t bob_period_us;
	int16_t bob_z_10um, bob_fz_cN;
	uint8_t state; /* heartbeat state, 3 = running */
	/* CTL_INFO with the scene description when info is set: firmware version, object a, b, H */
	bool info;
	uint8_t fw_version[3];
	uint16_t obj_100um[3];
};

/* The reference test scene: 64 x 64 cells of 6.25 mm, 50 mm deep, a 3 mm bump at (0.70, 0.50) of the
 * pool, the object at (0.30, 0.35) with its bottom 10 mm under the rest level, force (+1.5, -1.0, +0.8) N. */
void gen_default(struct gen_scene *s);

/* bump2: the mirror image of the default (bump left, object right, force the other way). */
void gen_mirror(struct gen_scene *s);
/* ripple: a smaller bump and a travelling ripple from the pool corner (animated). */
void gen_ripple(struct gen_scene *s);
/* bob: the default scene with the object bobbing: z = -10 + 6 sin(2 pi t / 2 s) mm, the submersion
 * following it (H = 50 mm), fz = 0.8 + 1.0 sin(2 pi t / 2 s) N, fx and fy as in the default. */
void gen_bob(struct gen_scene *s);
/* wake: bob with the object's waves: 1.2 mm rings of 40 mm wavelength running out from the
 * footprint at 0.1 m/s, no bump (the demo's largest wave and a bobbing object's wake). */
void gen_wake(struct gen_scene *s);
/* still: bob on a still pool (no bump, no waves): the reference the wake is compared with. */
void gen_still(struct gen_scene *s);
/* The same pool (0.4 m) in n x n cells (8..256): the benchmarks' bigger grids. */
void gen_cells(struct gen_scene *s, uint16_t n);
/* bump-info: the default scene from a controller that sends CTL_INFO: firmware 2.7.1, an object of
 * 100 x 60 x 40 mm (not the viewer's 50 mm default). */
void gen_info(struct gen_scene *s);

typedef void (*gen_emit_fn)(void *ctx, const uint8_t *pkt, size_t len);

/* The bob pattern's energy account at t_us (one ENERGY a heartbeat): created 0.5 mJ a second, D a
 * sine of +-2 mJ with the bob's period. */
void gen_energy_at(const struct gen_scene *s, uint64_t t_us, uint32_t *created_uJ, int32_t *balance_10uJ);

/* The packets of one controller frame at time t_us: heartbeat if `heartbeat`, scene (and CTL_INFO when
 * the scene has info) if `scene`, the height quads of every tile if `tiles`, object pose and force.
 * *seq is the packet sequence number, advanced per packet. Returns the number of packets, or 0 with err set. */
unsigned gen_frame(const struct gen_scene *s, uint64_t t_us, uint8_t frame, bool heartbeat, uint8_t hb_seq, bool scene,
		   bool tiles, uint8_t *seq, gen_emit_fn emit, void *ctx, enum swell_err *err);

#endif
