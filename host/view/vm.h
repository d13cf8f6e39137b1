/* The view model: everything swell-view shows, and nothing it invents. The decoder side fills it from
 * received frames (scene description, height tiles, object pose and force, heartbeat, link events);
 * the renderer and the HUD only read it. Host-only C11 (heights are float mm for the GPU).
 *
 * Robustness rules, each with a state the HUD shows:
 * - late join: until a scene description arrives, tiles and poses are counted and dropped
 *   (VIEW_WAIT_SCENE);
 * - loss: gaps in the stream sequence are counted as dropped frames;
 * - reordering: heights from a frame older (by stream position) than the data already held for
 *   those cells are dropped (counted late);
 * - controller restart: the decoder calls vm_restart (heartbeat back in the boot state), or a scene
 *   description that differs arrives: the heights are cleared and the viewer waits for the scene
 *   again (VIEW_RESTARTED);
 * - link unplug/replug: the link side reports down/up (VIEW_LINK_DOWN); silence longer than
 *   stale_us is VIEW_STALE. */
#ifndef SWELL_VIEW_VM_H
#define SWELL_VIEW_VM_H

#include <stdbool.h>
#include <stdint.h>

#include "swell/err.h"
#include "swell/proto.h"

#define VIEW_MAX_SIDE 1024
#define VIEW_MAX_TILE 64
#define VIEW_RATE_WINDOW_US 1000000u /* rates are counted over one second */
#define VIEW_RESTART_SHOW_US 3000000u
#define VIEW_LATENCY_WINDOW_US \
	2000000u /* the best path is the best of the last 2 to 4 s */ /* how long "controller restarted" stays on screen */

enum view_status {
	VIEW_LINK_DOWN, /* the link reports no connection (unplugged, socket error) */
	VIEW_WAIT_SCENE, /* connected, no scene description yet */
	VIEW_RESTARTED, /* the controller restarted; waiting for its new scene */
	VIEW_STALE, /* a scene is known but nothing arrived for stale_us */
	VIEW_LIVE,
};

struct view_scene {
	uint16_t nx, ny; /* cells */
	uint32_t dx_um; /* cell side */
	uint32_t depth_um; /* rest depth */
	uint8_t tile_w, tile_h; /* cells a tile */
	uint8_t scene_id; /* the controller changes it whenever the scene changes */
};

struct view_object {
	bool valid;
	int32_t x_um, y_um, z_um; /* centre of the box bottom, pool coordinates (origin: pool corner,
				      * z = 0 the rest surface, up positive) */
	uint32_t a_um, b_um, h_um; /* footprint x, y and height */
	int32_t fx_cN, fy_cN, fz_cN; /* force on the object, the one the device renders */
};

struct view_stats {
	uint32_t frames; /* good frames accepted */
	uint32_t bad; /* rejected by the decoder (CRC, truncated, unknown, out of range) */
	uint32_t dropped; /* missing sequence numbers, in gaps up to VM_LOSS_WINDOW */
	uint32_t resyncs; /* jumps beyond it (another sender, a restarted count): one each, not losses */
	uint32_t late; /* reordered frames older than what is shown */
	uint32_t ignored; /* frames that arrived before the scene description */
	uint32_t pieces; /* height pieces accepted (vm_cells calls: quads on the wire) */
	uint32_t cells; /* height samples accepted */
	uint32_t restarts; /* controller restarts seen */
	uint32_t link_drops; /* link up -> down transitions */
	float frame_hz, piece_hz; /* over the last full rate window */
	float latency_ms; /* one-way delay above the best seen (see vm_clock) */
	bool latency_valid;
};

struct view_model {
	enum view_status status;
	bool link_up;
	bool have_scene;
	struct view_scene scene;
	uint16_t tiles_x, tiles_y;
	float *h_mm; /* nx * ny heights above rest, row-major (j * nx + i) */
	uint32_t *cell_pos; /* stream position of the data held for each cell (0: none yet) */
	uint8_t *dirty; /* one flag a tile: heights changed since the renderer last took it */
	uint32_t dirty_count;
	struct view_object obj;
	char ctrl_state[16]; /* controller state name from the heartbeat, "?" until one arrives */
	uint8_t ctrl_error; /* enum swell_err the controller reports */
	uint16_t ctrl_bad, ctrl_overruns; /* the controller's own counters */
	/* CTL_INFO: the controller's firmware version and the object size it simulates (obj.a/b/h_um
	 * follow it once one has arrived; until then they are the viewer's --object fallback) */
	bool have_info;
	uint8_t fw_version[3];
	struct view_stats st;
	/* bookkeeping */
	bool have_seq;
	uint32_t seq_next;
	uint32_t late_run; /* late frames in a row */
	uint64_t last_rx_us, restart_us, window_us;
	bool have_window;
	uint32_t window_frames, window_pieces;
	int64_t best_offset_us, prev_best_us;
	uint64_t best_since_us;
	bool have_offset, have_prev_best;
	float lat_avg_us;
	uint64_t stale_us;
};

/* Initialise empty (link down, no scene). stale_us: silence after which the data is called stale. */
void vm_init(struct view_model *m, uint64_t stale_us);
void vm_free(struct view_model *m);

/* Link events from the link layer. */
void vm_link(struct view_model *m, bool up, uint64_t now_us);

/* A gap in a sequence of at most this many numbers is counted as lost; a longer jump is one
 * resynchronisation (the rule of every loss counter: swell_seq_loss). */
#define VM_LOSS_WINDOW SWELL_SEQ_WINDOW

/* gap numbers missing before the one just received: dropped, or one resync beyond the window. */
void vm_gap(struct view_model *m, uint32_t gap);

/* A frame passed the decoder: `seq` is its stream sequence number (modulo 2^seq_bits). Counts loss
 * and marks the data fresh. Returns false for a frame older than the newest seen (late, reordered):
 * it is counted late and no longer lost; its contents are still good, and the per-item order (tile
 * frame numbers, pose sequence numbers) decides what of it is shown. */
bool vm_frame(struct view_model *m, uint32_t seq, unsigned seq_bits, uint64_t now_us);
/* A frame the decoder rejected. */
void vm_bad(struct view_model *m);

/* Scene description. A different scene than the one held counts as a controller restart (the
 * heights are cleared). SWELL_ERANGE for sizes out of range; nothing changes then. */
enum swell_err vm_scene(struct view_model *m, const struct view_scene *s, uint64_t now_us);

/* n heights of one row of tile (tx, ty), from cell (col, row) of the tile, in LSB of 2^-16 mm, from
 * the frame at stream position `pos` (the decoder's unwrapped packet sequence, or arrival order;
 * never 0). Cells already holding data from a later position keep it (a reordered frame): counted
 * late, SWELL_ESTATE if no cell was taken. SWELL_ESTATE before a scene, SWELL_ERANGE for cells
 * outside the tile or the grid. */
enum swell_err vm_cells(struct view_model *m, uint16_t tx, uint16_t ty, uint16_t col, uint16_t row, uint16_t n,
			uint32_t pos, const int32_t *h_lsb);

/* Object pose and force. SWELL_ESTATE before a scene. */
enum swell_err vm_object(struct view_model *m, const struct view_object *o);

/* A frame without a sequence number (classic CAN): marks the data fresh and counts it. */
void vm_rx(struct view_model *m, uint64_t now_us);

/* Heartbeat: state name, last error, the controller's bad-frame and overrun counters. */
void vm_heartbeat(struct view_model *m, const char *state, uint8_t error, uint16_t bad, uint16_t overruns);

/* Controller info: firmware version (major, minor, patch) and the object's size in um, which from
 * now on replaces the fallback size in obj (valid or not). */
void vm_ctl_info(struct view_model *m, const uint8_t version[3], uint32_t a_um, uint32_t b_um, uint32_t h_um);

/* The controller restarted: drop the scene and heights, wait for a new scene description. */
void vm_restart(struct view_model *m, uint64_t now_us);

/* Clock sample: the controller's time of a frame (e.g. heartbeat count x period) against the local
 * receive time. The latency estimate is how far the offset exceeds the smallest offset seen in the
 * last 2 to 4 s (the best path; the window lets clock drift through), smoothed. It cannot see the
 * constant part of the delay, and the HUD says so ("over best"); a controller that falls behind its
 * own schedule (overruns) shows as delay, which it is. */
void vm_clock(struct view_model *m, uint64_t ctrl_us, uint64_t rx_us);

/* Advance time: rates, staleness, how long a restart stays shown. */
void vm_tick(struct view_model *m, uint64_t now_us);

/* Tile dirty flags: the renderer uploads those and clears them. */
bool vm_tile_dirty(const struct view_model *m, uint16_t tx, uint16_t ty);
void vm_tile_clean(struct view_model *m, uint16_t tx, uint16_t ty);

/* Cells of tile (tx, ty): origin and size, clipped at the grid's edge. */
void vm_tile_rect(const struct view_model *m, uint16_t tx, uint16_t ty, uint16_t *i0, uint16_t *j0, uint16_t *w,
		  uint16_t *h);

const char *vm_status_str(enum view_status s);

#endif
