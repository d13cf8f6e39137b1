/* swell-view rendering: OpenGL 3.3 core profile, prototypes from <GL/glcorearb.h> against libGL
 * (no loader). 3.3 core is what Mesa's llvmpipe under Xvfb and every lab PC of the last decade give;
 * it has the pieces used here (float textures sampled in the vertex shader, framebuffer objects with
 * multisampling, instancing-free VBOs) and no fixed-function state.
 *
 * Everything is drawn into an offscreen multisampled framebuffer of a fixed size, resolved, then
 * blitted to the window (if any) or read back for a screenshot, so headless and windowed output are
 * the same pixels. Heights live in a float texture the size of the grid; only tiles the view model
 * marks dirty are uploaded (glTexSubImage2D), and the water mesh samples it in the vertex shader. */
#ifndef SWELL_VIEW_RENDER_H
#define SWELL_VIEW_RENDER_H

#include <stdbool.h>
#include <stdint.h>

#include "canvas.h"
#include "vm.h"

#define RENDER_HUD_ITEMS 24

/* orbit: the mouse camera; top: straight down, shaded, pool fitted (tests); map: straight down, a
 * height map in the colour scale with the object's footprint outlined */
enum render_view {
	RENDER_ORBIT,
	RENDER_TOP,
	RENDER_MAP
};

/* water: the pool as light shows it (normals from the received heights, sun highlight, sky by
 * Fresnel, the tiled floor through the water with its caustics, the object's contact ring and
 * shadow); flat: one body colour with sun and sky only. Both draw the same heights. */
enum render_shading {
	RENDER_SHADE_WATER,
	RENDER_SHADE_FLAT
};

#define RENDER_OVERLAYS 2 /* CPU-drawn pictures over the scene: the charts, the colour legend */

struct render_opts {
	int w, h; /* framebuffer size, pixels */
	enum render_view view;
	enum render_shading shading;
	bool colour_scale; /* colour the water by height (blue - white - red over +-h_range_mm) */
	float h_range_mm;
	bool hud;
	float zscale; /* vertical exaggeration of the water heights */
	float force_mm_per_N; /* force arrow length */
	int msaa; /* samples a pixel (0: none; -1: 4, or 0 on a software renderer), capped
				* to what GL offers */
};

struct render_text {
	int x, y; /* pixels from the top-left; negative x: from the right edge */
	uint8_t r, g, b;
	bool panel; /* dark panel behind */
	char s[512];
};

struct render_cam {
	float yaw, pitch; /* radians */
	float dist; /* metres */
	float pan_x, pan_y; /* metres, target offset */
};

struct render_overlay {
	bool on;
	int x, y, w, h; /* placement, pixels from the top-left */
	int tex_w, tex_h; /* texture storage size */
	unsigned tex;
};

struct render {
	struct render_opts o;
	int scene_right; /* pixels at the right edge kept free of the scene (the charts' panel) */
	float obj_box[4]; /* the object's footprint as drawn: centre x, y and half sizes, m (half x 0: none) */
	float obj_z[2]; /* its bottom and top as drawn, m */
	float obj_water_mm; /* the water under the object as drawn (held with the heights while frozen) */
	struct render_overlay ov[RENDER_OVERLAYS];
	struct render_cam cam;
	bool cam_set;
	/* GL objects */
	unsigned prog_lit, prog_water, prog_hud;
	unsigned fbo_ms, rb_ms_col, rb_ms_depth, fbo_res, rb_res_col;
	unsigned vao_water, vbo_water, ibo_water, vao_lit, vbo_lit, vao_hud, tex_h, tex_hud;
	int water_nx, water_ny, water_indices;
	int samples;
	/* geometry scratch */
	float *lit; /* pos3 nrm3 col3 per vertex */
	int lit_n, lit_cap;
	/* HUD */
	struct canvas hud; /* the HUD picture, the framebuffer's size */
	struct render_text text[RENDER_HUD_ITEMS];
	int ntext;
	struct render_text hud_text[RENDER_HUD_ITEMS]; /* what the HUD texture holds */
	int hud_ntext;
	/* counters */
	uint64_t tiles_uploaded, texels_uploaded;
	uint32_t tiles_uploaded_last;
};

/* With a current GL 3.3 context. Returns false (and says why on stderr) when GL lacks something. */
bool render_init(struct render *r, const struct render_opts *o);
void render_free(struct render *r);

/* Change the framebuffer size (window resize). */
bool render_resize(struct render *r, int w, int h);

/* Upload the dirty tiles (unless frozen: the pause key) and draw one frame. */
void render_frame(struct render *r, struct view_model *m, bool frozen);

/* HUD text for the next frames: replaced as a whole. */
void render_text_clear(struct render *r);
void render_text_add(struct render *r, int x, int y, uint8_t cr, uint8_t cg, uint8_t cb, bool panel, const char *s);

/* Show an RGBA picture (w x h, top row first, straight alpha) with its top-left corner at pixel (x, y)
 * over the scene in every frame from now on; off: no longer. */
void render_overlay(struct render *r, int slot, const uint8_t *rgba, int w, int h, int x, int y);
void render_overlay_off(struct render *r, int slot);

/* Wait until GL has carried out every command so far (frame-time measurement). */
void render_finish(struct render *r);

/* Copy the last frame to the bound window framebuffer of size win_w x win_h. */
void render_blit(struct render *r, int win_w, int win_h);

/* Read the last frame, RGB, top row first, w * h * 3 bytes. */
void render_read(struct render *r, uint8_t *rgb);

/* Camera: reset to the default view of the current scene, orbit, zoom. */
void render_cam_reset(struct render *r, const struct view_model *m);
void render_cam_orbit(struct render *r, float dyaw, float dpitch);
void render_cam_zoom(struct render *r, float factor);

#endif
