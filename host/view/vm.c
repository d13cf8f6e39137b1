/* The view model, see vm.h. */
#include "vm.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/wave.h"

#define LATE_WINDOW 256 /* at most this far behind (and a quarter of half the range) is late */

void vm_init(struct view_model *m, uint64_t stale_us)
{
	memset(m, 0, sizeof(*m));
	m->status = VIEW_LINK_DOWN;
	m->stale_us = stale_us;
	strcpy(m->ctrl_state, "?");
}

static void drop_scene(struct view_model *m)
{
	free(m->h_mm);
	free(m->cell_pos);
	free(m->dirty);
	m->h_mm = NULL;
	m->cell_pos = NULL;
	m->dirty = NULL;
	m->have_scene = false;
	m->dirty_count = 0;
	m->tiles_x = m->tiles_y = 0;
	memset(&m->scene, 0, sizeof(m->scene));
	m->obj.valid = false;
}

void vm_free(struct view_model *m)
{
	drop_scene(m);
}

void vm_restart(struct view_model *m, uint64_t now_us)
{
	drop_scene(m);
	m->st.restarts++;
	m->restart_us = now_us ? now_us : 1;
	m->have_seq = m->have_offset = m->have_prev_best = false;
	m->st.latency_valid = false;
}

void vm_link(struct view_model *m, bool up, uint64_t now_us)
{
	if (m->link_up && !up)
		m->st.link_drops++;
	if (!m->link_up && up) {
		/* A replugged link starts a new stream: sequence numbers and clock start over. */
		m->have_seq = m->have_offset = m->have_prev_best = false;
		m->last_rx_us = now_us;
	}
	m->link_up = up;
	vm_tick(m, now_us);
}

void vm_gap(struct view_model *m, uint32_t gap)
{
	m->st.dropped += swell_seq_loss(gap, &m->st.resyncs);
}

bool vm_frame(struct view_model *m, uint32_t seq, unsigned seq_bits, uint64_t now_us)
{
	uint32_t mask = seq_bits >= 32 ? 0xffffffffu : (1u << seq_bits) - 1u;
	uint32_t half = mask / 2u + 1u;

	vm_rx(m, now_us); /* a frame, late or not: data proves the link is up */
	seq &= mask;
	if (m->have_seq) {
		uint32_t ahead = (seq - m->seq_next) & mask;
		uint32_t behind = (m->seq_next - seq) & mask;
		/* Only a little behind is late (reordered); a packet far "behind" is a jump forward past a
		 * burst of loss, and a run of late ones means the sender started counting again. */
		uint32_t window = half / 4 < LATE_WINDOW ? half / 4 : LATE_WINDOW;
		if (ahead != 0 && behind <= window && ++m->late_run < 8) {
			/* a reordered frame: it was counted lost when its successor came */
			m->st.late++;
			if (m->st.dropped > 0)
				m->st.dropped--;
			return false;
		}
		/* a jump beyond the window (another sender, a run of late ones: the sender restarted its
		 * count) is one resynchronisation, not hundreds lost */
		if (ahead > window)
			ahead = UINT32_MAX; /* past a short sequence's own window: a jump all the same */
		m->st.dropped += swell_seq_loss(ahead, &m->st.resyncs);
	}
	m->late_run = 0;
	m->have_seq = true;
	m->seq_next = (seq + 1u) & mask;
	return true;
}

void vm_bad(struct view_model *m)
{
	m->st.bad++;
}

static bool scene_equal(const struct view_scene *a, const struct view_scene *b)
{
	return a->nx == b->nx && a->ny == b->ny && a->dx_um == b->dx_um && a->depth_um == b->depth_um &&
		a->tile_w == b->tile_w && a->tile_h == b->tile_h && a->scene_id == b->scene_id;
}

enum swell_err vm_scene(struct view_model *m, const struct view_scene *s, uint64_t now_us)
{
	if (!s || s->nx < 2 || s->ny < 2 || s->nx > VIEW_MAX_SIDE || s->ny > VIEW_MAX_SIDE || s->dx_um == 0 ||
	    s->tile_w == 0 || s->tile_h == 0 || s->tile_w > VIEW_MAX_TILE || s->tile_h > VIEW_MAX_TILE)
		return SWELL_ERANGE;
	if (m->have_scene && scene_equal(&m->scene, s))
		return SWELL_OK;

	uint16_t tx = (uint16_t)((s->nx + s->tile_w - 1) / s->tile_w);
	uint16_t ty = (uint16_t)((s->ny + s->tile_h - 1) / s->tile_h);
	size_t cells = (size_t)s->nx * s->ny, tiles = (size_t)tx * ty;
	float *h = calloc(cells, sizeof(*h));
	uint32_t *pos = calloc(cells, sizeof(*pos));
	uint8_t *dirty = calloc(tiles, 1);
	if (!h || !pos || !dirty) {
		free(h);
		free(pos);
		free(dirty);
		return SWELL_ESIZE;
	}
	if (m->have_scene)
		vm_restart(m, now_us); /* a different scene: the controller was restarted or reconfigured */
	m->h_mm = h;
	m->cell_pos = pos;
	m->dirty = dirty;
	m->scene = *s;
	m->tiles_x = tx;
	m->tiles_y = ty;
	/* The flat surface is the first thing to show: every tile starts dirty. */
	memset(m->dirty, 1, tiles);
	m->dirty_count = (uint32_t)tiles;
	m->have_scene = true;
	return SWELL_OK;
}

void vm_tile_rect(const struct view_model *m, uint16_t tx, uint16_t ty, uint16_t *i0, uint16_t *j0, uint16_t *w,
		  uint16_t *h)
{
	uint32_t x = (uint32_t)tx * m->scene.tile_w, y = (uint32_t)ty * m->scene.tile_h;
	uint32_t cw = m->scene.tile_w, ch = m->scene.tile_h;

	if (x + cw > m->scene.nx)
		cw = m->scene.nx - x;
	if (y + ch > m->scene.ny)
		ch = m->scene.ny - y;
	*i0 = (uint16_t)x;
	*j0 = (uint16_t)y;
	*w = (uint16_t)cw;
	*h = (uint16_t)ch;
}

enum swell_err vm_cells(struct view_model *m, uint16_t tx, uint16_t ty, uint16_t col, uint16_t row, uint16_t n,
			uint32_t pos, const int32_t *h_lsb)
{
	if (!m->have_scene) {
		m->st.ignored++;
		return SWELL_ESTATE;
	}
	if (!h_lsb || pos == 0 || tx >= m->tiles_x || ty >= m->tiles_y)
		return SWELL_ERANGE;
	uint16_t i0, j0, w, h;
	vm_tile_rect(m, tx, ty, &i0, &j0, &w, &h);
	if (row >= h || n == 0 || (uint32_t)col + n > w)
		return SWELL_ERANGE;
	size_t at = (size_t)(j0 + row) * m->scene.nx + i0 + col;
	float *dst = m->h_mm + at;
	uint32_t *held = m->cell_pos + at;
	bool changed = false, took = false, late = false;
	for (uint16_t c = 0; c < n; c++) {
		if (held[c] != 0 && (int32_t)(pos - held[c]) < 0) {
			late = true; /* newer data is already here */
			continue;
		}
		float v = (float)h_lsb[c] / (float)SWELL_H_ONE_MM;
		changed |= dst[c] != v;
		dst[c] = v;
		held[c] = pos;
		took = true;
	}
	if (late)
		m->st.late++;
	if (!took)
		return SWELL_ESTATE;
	size_t t = (size_t)ty * m->tiles_x + tx;
	if (changed && !m->dirty[t]) { /* the same heights again (a refresh) upload nothing */
		m->dirty[t] = 1;
		m->dirty_count++;
	}
	m->st.cells += n;
	m->st.pieces++;
	m->window_pieces++;
	return SWELL_OK;
}

enum swell_err vm_object(struct view_model *m, const struct view_object *o)
{
	if (!m->have_scene) {
		m->st.ignored++;
		return SWELL_ESTATE;
	}
	m->obj = *o;
	return SWELL_OK;
}

void vm_rx(struct view_model *m, uint64_t now_us)
{
	m->last_rx_us = now_us;
	m->link_up = true;
	m->st.frames++;
	m->window_frames++;
}

void vm_ctl_info(struct view_model *m, const uint8_t version[3], uint32_t a_um, uint32_t b_um, uint32_t h_um)
{
	m->have_info = true;
	memcpy(m->fw_version, version, sizeof(m->fw_version));
	m->obj.a_um = a_um;
	m->obj.b_um = b_um;
	m->obj.h_um = h_um;
}

void vm_heartbeat(struct view_model *m, const char *state, uint8_t error, uint16_t bad, uint16_t overruns)
{
	m->ctrl_error = error;
	m->ctrl_bad = bad;
	m->ctrl_overruns = overruns;
	snprintf(m->ctrl_state, sizeof(m->ctrl_state), "%s", state && state[0] ? state : "?");
}

void vm_clock(struct view_model *m, uint64_t ctrl_us, uint64_t rx_us)
{
	int64_t off = (int64_t)(rx_us - ctrl_us);

	if (m->have_offset && rx_us - m->best_since_us >= VIEW_LATENCY_WINDOW_US) {
		/* Start a new window; the previous window's best still counts until this one is full. */
		m->prev_best_us = m->best_offset_us;
		m->have_prev_best = true;
		m->best_offset_us = off;
		m->best_since_us = rx_us;
	}
	if (!m->have_offset || off < m->best_offset_us) {
		m->best_offset_us = off;
		if (!m->have_offset)
			m->best_since_us = rx_us;
		m->have_offset = true;
	}
	int64_t best = m->best_offset_us;
	if (m->have_prev_best && m->prev_best_us < best)
		best = m->prev_best_us;
	float excess = (float)(off - best);
	m->lat_avg_us = m->st.latency_valid ? m->lat_avg_us + 0.05f * (excess - m->lat_avg_us) : excess;
	m->st.latency_ms = m->lat_avg_us / 1000.0f;
	m->st.latency_valid = true;
}

void vm_tick(struct view_model *m, uint64_t now_us)
{
	if (!m->have_window) {
		m->window_us = now_us;
		m->have_window = true;
	}
	if (now_us - m->window_us >= VIEW_RATE_WINDOW_US) {
		float s = (float)(now_us - m->window_us) / 1e6f;
		m->st.frame_hz = (float)m->window_frames / s;
		m->st.piece_hz = (float)m->window_pieces / s;
		m->window_frames = m->window_pieces = 0;
		m->window_us = now_us;
	}
	if (!m->link_up)
		m->status = VIEW_LINK_DOWN;
	else if (!m->have_scene)
		m->status = m->restart_us ? VIEW_RESTARTED : VIEW_WAIT_SCENE;
	else if (now_us - m->last_rx_us > m->stale_us)
		m->status = VIEW_STALE;
	else
		m->status = VIEW_LIVE;
}

bool vm_tile_dirty(const struct view_model *m, uint16_t tx, uint16_t ty)
{
	return m->have_scene && tx < m->tiles_x && ty < m->tiles_y && m->dirty[(size_t)ty * m->tiles_x + tx];
}

void vm_tile_clean(struct view_model *m, uint16_t tx, uint16_t ty)
{
	if (vm_tile_dirty(m, tx, ty)) {
		m->dirty[(size_t)ty * m->tiles_x + tx] = 0;
		m->dirty_count--;
	}
}

const char *vm_status_str(enum view_status s)
{
	static const char *const names[] = { [VIEW_LINK_DOWN] = "LINK DOWN",
					     [VIEW_WAIT_SCENE] = "WAITING FOR SCENE DESCRIPTION",
					     [VIEW_RESTARTED] = "CONTROLLER RESTARTED - WAITING FOR SCENE",
					     [VIEW_STALE] = "NO DATA - STALE",
					     [VIEW_LIVE] = "LIVE" };

	return (unsigned)s < sizeof(names) / sizeof(names[0]) ? names[s] : "?";
}
