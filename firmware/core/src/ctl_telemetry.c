/* The controller core's telemetry to the host: heartbeat, scene, info, the object's pose and force,
 * and the heights, quads of four cells sent where they changed (docs/design.md). */
#include "ctl_priv.h"

#define HEARTBEAT_HZ 10u
#define SCENE_HZ 1u
#define INFO_HZ 1u
#define POSE_HZ 100u
/* Quads scanned a tick, except in the tick that ends a solver step: the period's heaviest (the
 * solver's finish) scans nothing, the heights it finished are scanned from the next tick on. A quad
 * whose stale bit is clear is passed unread; of the stale ones, QUAD_READS_PER_S / tick_hz are read a
 * tick (36 at 2500 Hz, 90 at 1000 Hz, about 50 instructions each on the M4): where every quad is
 * stale, a round over the 1024 quads of the reference pool takes 12.6 ms at 2500 Hz (nine scanning ticks
 * in ten) and 15.2 ms at 1000 Hz (three in four). */
#define QUAD_SCAN_PER_TICK 64u

static uint16_t sat16(uint32_t x)
{
	return x > 0xffffu ? 0xffffu : (uint16_t)x;
}

void ctl_send_heartbeat(struct swell_ctl *c)
{
	struct swell_msg m = ctl_msg(c, SWELL_MSG_HEARTBEAT);

	m.u.heartbeat.state = (uint8_t)c->state;
	m.u.heartbeat.err = (uint8_t)c->last_err;
	m.u.heartbeat.version = SWELL_PROTO_VERSION;
	m.u.heartbeat.seq = c->seq_hb++;
	m.u.heartbeat.bad_frames = sat16(c->n.bad_frames);
	m.u.heartbeat.overruns = sat16(c->n.overruns);
	ctl_push(c, SWELL_LINK_HOST, &m);
	ctl_push(c, SWELL_LINK_DEVICE, &m);
}

static void send_scene(struct swell_ctl *c)
{
	struct swell_msg m = ctl_msg(c, SWELL_MSG_SCENE);

	m.u.scene.nx = c->cfg.nx;
	m.u.scene.ny = c->cfg.ny;
	m.u.scene.h_shift = SWELL_PROTO_H_SHIFT;
	m.u.scene.dx_um = (uint16_t)c->cfg.dx_um;
	m.u.scene.depth_10um = (uint16_t)(c->cfg.depth_um / 10);
	m.u.scene.scene_id = c->scene_id;
	ctl_push(c, SWELL_LINK_HOST, &m);
}

/* Size on the wire: 0.1 mm, rounded to nearest, saturated to the field's 1 .. 8191. */
static uint16_t to_100um(uint32_t um)
{
	uint32_t v = (um + 50u) / 100u;

	return (uint16_t)(v < 1u ? 1u : v > 8191u ? 8191u : v);
}

static void send_info(struct swell_ctl *c)
{
	struct swell_msg m = ctl_msg(c, SWELL_MSG_CTL_INFO);

	m.u.ctl_info.fw_major = c->cfg.fw_version[0];
	m.u.ctl_info.fw_minor = c->cfg.fw_version[1];
	m.u.ctl_info.fw_patch = c->cfg.fw_version[2];
	m.u.ctl_info.obj_a_100um = to_100um(c->cfg.body.a_um);
	m.u.ctl_info.obj_b_100um = to_100um(c->cfg.body.b_um);
	m.u.ctl_info.obj_h_100um = to_100um(c->cfg.body.h_um);
	ctl_push(c, SWELL_LINK_HOST, &m);
	c->info_pending = 0;
	c->info_wait = ctl_period(c, INFO_HZ); /* the next one a second later, unless something changes */
}

static void send_pose(struct swell_ctl *c)
{
	struct swell_msg p = ctl_msg(c, SWELL_MSG_OBJECT_POSE), f = ctl_msg(c, SWELL_MSG_OBJECT_FORCE);
	int32_t half_pct = 0;

	if (c->cfg.body.h_um > 0)
		half_pct = (int32_t)(((int64_t)c->out.delta_lsb * 200) / swell_um_to_lsb((int64_t)c->cfg.body.h_um));
	p.u.object_pose.x_10um = ctl_to_10um(c->out.x_um);
	p.u.object_pose.y_10um = ctl_to_10um(c->out.y_um);
	p.u.object_pose.z_10um = ctl_to_10um(c->out.z_um);
	p.u.object_pose.submersion_halfpct = (uint8_t)swell_clamp(half_pct, 0, 200);
	p.u.object_pose.seq = c->seq_pose;
	f.u.object_force.fx_cN = ctl_force_cN(c, c->force_dev_uN[0]);
	f.u.object_force.fy_cN = ctl_force_cN(c, c->force_dev_uN[1]);
	f.u.object_force.fz_cN = ctl_force_cN(c, c->force_dev_uN[2]);
	f.u.object_force.seq = c->seq_pose++;
	f.u.object_force.limits = c->limits;
	ctl_push(c, SWELL_LINK_HOST, &p);
	ctl_push(c, SWELL_LINK_HOST, &f);
}

/* Read quad q into s[4] (cells outside the grid read 0): the heights of the last finished solver
 * step (swell_wave_h). Returns how many of its cells are in the grid (0: a quad of a partial tile
 * wholly outside), and sets *changed when any sample differs from the one last sent. */
static uint32_t quad_read(const struct swell_ctl *c, const struct swell_quad_at *at, int16_t s[4], int *changed)
{
	const uint32_t nx = c->cfg.nx, a = at->y * nx + at->x0;
	uint32_t k, cells = 0;

	*changed = 0;
	s[0] = s[1] = s[2] = s[3] = 0;
	if (at->y >= c->cfg.ny)
		return 0;
	if (at->x0 + 4 <= nx && !(a & 1u)) { /* a whole quad: its samples are two words of sent[] */
		int32_t x[4];
		uint32_t w0, w1;

		swell_wave_quad(&c->wave, a, x);
		w0 = swell_height_pair_to_samples(x[0], x[1]);
		w1 = swell_height_pair_to_samples(x[2], x[3]);

		s[0] = (int16_t)(uint16_t)w0;
		s[1] = (int16_t)(uint16_t)(w0 >> 16);
		s[2] = (int16_t)(uint16_t)w1;
		s[3] = (int16_t)(uint16_t)(w1 >> 16);
		*changed = w0 != c->sent[a >> 1] || w1 != c->sent[(a >> 1) + 1];
		return 4;
	}
	for (k = 0; k < 4 && at->x0 + k < nx; k++) {
		s[k] = swell_height_to_sample(swell_wave_h(&c->wave, a + k));
		*changed |= s[k] != ctl_sent_get(c, a + k);
		cells++;
	}
	return cells;
}

static void quad_send(struct swell_ctl *c, const struct swell_quad_at *at, const int16_t s[4], uint32_t cells)
{
	const uint32_t a = at->y * c->cfg.nx + at->x0;
	struct swell_msg m = swell_height_quad(at, c->n.solver_steps, s);
	uint32_t k;

	m.node = c->cfg.node;
	ctl_push(c, SWELL_LINK_HOST, &m);
	for (k = 0; k < cells; k++)
		ctl_sent_set(c, a + k, s[k]);
	c->n.quads_sent++;
}

/* The solver step just finished: the quads of every tile that moved may now differ from what was
 * last sent. */
void ctl_mark_moved_tiles(struct swell_ctl *c)
{
	const uint32_t tiles = (uint32_t)c->tiles_x * c->tiles_y;
	uint32_t t;

	for (t = 0; t < tiles; t++)
		if (swell_wave_tile_changed(&c->wave, t))
			c->quad_stale[t] = 0xffffu;
}

/* Water placed in the cells of footprint f in the middle of a step is in h(n) as a reader sees it at
 * once (swell/wave.h, velocity form): the quads of the tiles it covers may now differ from what was
 * last sent. */
static void mark_placed_tiles(struct swell_ctl *c, const struct swell_body_fp *f)
{
	const int32_t one = SWELL_BODY_FP_ONE;
	int32_t tx, ty;

	if (f->delta_lsb == 0 || f->x0 >= f->x1 || f->y0 >= f->y1)
		return;
	for (ty = f->y0 / one / SWELL_WAVE_TILE; ty <= (f->y1 - 1) / one / SWELL_WAVE_TILE; ty++)
		for (tx = f->x0 / one / SWELL_WAVE_TILE; tx <= (f->x1 - 1) / one / SWELL_WAVE_TILE; tx++)
			c->quad_stale[(uint32_t)ty * c->tiles_x + (uint32_t)tx] = 0xffffu;
}

/* The object's water in the cells was `before` and is now c->body.placed: where it changed, the tiles
 * it left and those it covers are stale for the telemetry. */
void ctl_mark_water_moved(struct swell_ctl *c, const struct swell_body_fp *before)
{
	const struct swell_body_fp *now = &c->body.placed;

	if (before->delta_lsb == now->delta_lsb && before->x0 == now->x0 && before->x1 == now->x1 &&
	    before->y0 == now->y0 && before->y1 == now->y1)
		return;
	mark_placed_tiles(c, before);
	mark_placed_tiles(c, now);
}

/* The quad was compared (and sent where it differed): its samples are what was last sent. */
static void quad_fresh(struct swell_ctl *c, uint32_t q)
{
	c->quad_stale[q / SWELL_QUADS_PER_TILE] &= (uint16_t) ~(1u << (q % SWELL_QUADS_PER_TILE));
}

/* HEIGHT_QUAD of quad `bit` of the tile at (at->x0, at->y) less that quad's offset, a whole quad at
 * cell a, from its samples as sent[] holds them (two words). Out of the scan's loop, which keeps its
 * registers for the reads. */
static __attribute__((noinline)) void quad_send_words(struct swell_ctl *c, struct swell_quad_at *at, uint32_t bit,
						      uint32_t a, uint32_t w0, uint32_t w1)
{
	const int16_t s[4] = { (int16_t)(uint16_t)w0, (int16_t)(uint16_t)(w0 >> 16), (int16_t)(uint16_t)w1,
			       (int16_t)(uint16_t)(w1 >> 16) };
	const uint32_t x_tile = at->x0 - 4u * at->half, y_tile = at->y - at->row;
	struct swell_msg m;

	at->row = bit >> 1;
	at->half = bit & 1u;
	at->x0 = x_tile + 4u * at->half;
	at->y = y_tile + at->row;
	m = swell_height_quad(at, c->n.solver_steps, s);
	m.node = c->cfg.node;
	ctl_push(c, SWELL_LINK_HOST, &m);
	c->sent[a >> 1] = w0;
	c->sent[(a >> 1) + 1] = w1;
	c->n.quads_sent++;
}

/* What a scan may still do in this tick (messages to send, stale quads to read), and the cells read. */
struct scan_left {
	uint32_t msgs, reads, cells;
};

/* scan_run over a tile wholly inside a grid of even width: every quad is four cells of one row and two
 * words of sent[], read as h(n) of the last finished step (swell_wave_quad), sent from the words. The
 * loop goes from stale bit to stale bit. */
static uint32_t scan_whole_tile(struct swell_ctl *c, uint32_t q, uint32_t run, struct scan_left *left,
				struct swell_quad_at *at)
{
	uint16_t *const stale_at = &c->quad_stale[q / SWELL_QUADS_PER_TILE];
	const uint32_t nx = c->cfg.nx, x_tile = at->x0 - 4u * at->half, y_tile = at->y - at->row;
	const uint32_t corner = y_tile * nx + x_tile, first = q % SWELL_QUADS_PER_TILE;
	const uint32_t *const sent = c->sent + corner / 2;
	/* the run's stale bits: [first, first + run) of the tile's */
	uint32_t todo = *stale_at & ((run < SWELL_QUADS_PER_TILE ? (1u << run) - 1u : 0xffffu) << first);
	uint32_t msgs = left->msgs, reads = left->reads, bit = first;

	while (todo && msgs && reads) {
		int32_t x[4];
		uint32_t o, w0, w1;

		bit = (uint32_t)__builtin_ctz(todo);
		todo &= todo - 1u;
		reads--;
		o = (bit >> 1) * nx + 4u * (bit & 1u);
		swell_wave_quad(&c->wave, corner + o, x);
		w0 = swell_height_pair_to_samples(x[0], x[1]);
		w1 = swell_height_pair_to_samples(x[2], x[3]);
		if (w0 != sent[o >> 1] || w1 != sent[(o >> 1) + 1]) {
			quad_send_words(c, at, bit, corner + o, w0, w1);
			msgs--;
		}
	}
	left->cells += 4u * (left->reads - reads);
	left->msgs = msgs;
	left->reads = reads;
	if (msgs && reads) { /* the run scanned whole: its stale bits all read */
		*stale_at &= (uint16_t) ~((run < SWELL_QUADS_PER_TILE ? (1u << run) - 1u : 0xffffu) << first);
		return run;
	}
	/* up to and with the quad that spent the last message or read */
	*stale_at &= (uint16_t) ~(((2u << bit) - 1u) & ~((1u << first) - 1u));
	return bit + 1u - first;
}

/* The stale quads of the run [q, q + run) of one tile read (the tile located once) and sent where they
 * changed, while the tick's messages and reads last. Returns how many of the run were scanned: all of
 * them, or up to and with the quad that spent the last message or read. A tile wholly inside a grid of
 * even width (every quad two words of sent[]) goes through scan_whole_tile. */
static uint32_t scan_run(struct swell_ctl *c, uint32_t q, uint32_t run, struct scan_left *left)
{
	uint16_t *const stale_at = &c->quad_stale[q / SWELL_QUADS_PER_TILE];
	struct swell_quad_at at = swell_quad_locate(q, c->tiles_x);
	const uint32_t x_tile = at.x0 - 4u * at.half, y_tile = at.y - at.row;
	uint32_t stale = *stale_at, k, n;
	int16_t s[4];
	int changed;

	if (!(c->cfg.nx & 1u) && x_tile + SWELL_PROTO_TILE <= c->cfg.nx && y_tile + SWELL_PROTO_TILE <= c->cfg.ny)
		return scan_whole_tile(c, q, run, left, &at);
	for (k = 0; k < run && left->msgs && left->reads; k++) {
		const uint32_t bit = (q + k) % SWELL_QUADS_PER_TILE;

		if (!(stale >> bit & 1u))
			continue;
		stale &= ~(1u << bit);
		left->reads--;
		at.row = bit >> 1;
		at.half = bit & 1u;
		at.x0 = x_tile + 4u * at.half;
		at.y = y_tile + at.row;
		n = quad_read(c, &at, s, &changed);
		left->cells += n;
		if (n && changed) {
			quad_send(c, &at, s, n);
			left->msgs--;
		}
	}
	*stale_at = (uint16_t)stale;
	return k;
}

/* Scan quads round-robin and send the ones whose samples changed: at most `scan` quads, `reads` of them
 * read, `budget` sent. A quad whose stale bit is clear is passed unread (it counts as scanned but not
 * read: the same quads go out as when every one is read), a tile's run of them in one test. A budget
 * left over sends one quad of a second, slower round-robin whatever its state, so that a quad lost on
 * the way is put right even where the water no longer moves (every quad within quads / tick_hz s).
 * Returns the cells read. */
static uint32_t send_heights(struct swell_ctl *c, uint32_t budget, uint32_t scan, uint32_t reads)
{
	struct scan_left left = { budget, reads, 0 };
	uint32_t scanned = 0, n;
	int16_t s[4];
	int changed;

	while (left.msgs && left.reads && scanned < scan) {
		const uint32_t q = c->quad_cursor, first = q % SWELL_QUADS_PER_TILE;
		const uint32_t rest = scan - scanned;
		uint32_t run = SWELL_QUADS_PER_TILE - first < rest ? SWELL_QUADS_PER_TILE - first : rest;
		/* the run's bits, from the tile's bits shifted down to the cursor: at most `rest` of them */
		const uint32_t bits = rest < SWELL_QUADS_PER_TILE ? (1u << rest) - 1u : 0xffffu;

		if ((uint32_t)c->quad_stale[q / SWELL_QUADS_PER_TILE] >> first & bits)
			run = scan_run(c, q, run, &left);
		/* else none of the tile's next run of quads can differ: passed whole */
		c->quad_cursor = q + run == c->quads ? 0 : q + run; /* quads: whole tiles, a run never wraps */
		scanned += run;
	}
	for (scanned = 0; left.msgs && scanned < 4; scanned++) { /* skip quads outside a partial tile */
		const uint32_t q = c->refresh_cursor;
		const struct swell_quad_at at = swell_quad_locate(q, c->tiles_x);

		c->refresh_cursor = q + 1 == c->quads ? 0 : q + 1;
		n = quad_read(c, &at, s, &changed);
		if (n) {
			quad_send(c, &at, s, n);
			quad_fresh(c, q);
			c->n.quads_refreshed++;
			break;
		}
	}
	return left.cells;
}

/* The energy account with the heartbeat (docs/energy.md): created and D of the run in progress or
 * the last one. */
static void send_energy(struct swell_ctl *c)
{
	struct swell_msg m = ctl_msg(c, SWELL_MSG_ENERGY);
	struct swell_energy_account e;

	(void)swell_ctl_energy(c, &e);
	m.u.energy.created_uJ = e.created_uJ > (int64_t)UINT32_MAX ? UINT32_MAX : (uint32_t)e.created_uJ;
	m.u.energy.balance_10uJ = (int32_t)(e.balance_uJ / 10 > 8388607            ? 8388607
						    : e.balance_uJ / 10 < -8388607 ? -8388607
										   : e.balance_uJ / 10);
	m.u.energy.acting = c->energy.acted;
	m.u.energy.passivity = c->cfg.passivity;
	c->energy.acted = 0;
	ctl_push(c, SWELL_LINK_HOST, &m);
}

/* The sends of the background part of tick t (docs/design.md). */
uint32_t ctl_telemetry(struct swell_ctl *c, uint32_t t, uint32_t budget)
{
	if (t % ctl_period(c, HEARTBEAT_HZ) == 0) {
		ctl_send_heartbeat(c);
		budget--;
	}
	if (budget && t % ctl_period(c, HEARTBEAT_HZ) == 3 % ctl_period(c, HEARTBEAT_HZ)) {
		send_energy(c);
		budget--;
	}
	if (budget && t % ctl_period(c, SCENE_HZ) == 1 % ctl_period(c, SCENE_HZ)) {
		send_scene(c);
		budget--;
	}
	if (c->info_wait)
		c->info_wait--;
	if (budget && (c->info_pending || c->info_wait == 0)) {
		send_info(c);
		budget--;
	}
	if (budget >= 2 && t % ctl_period(c, POSE_HZ) == 2 % ctl_period(c, POSE_HZ)) {
		send_pose(c);
		budget -= 2;
	}
	/* c->phase 0: this tick ended a step */
	return send_heights(c, budget, c->phase == 0 ? 0u : QUAD_SCAN_PER_TICK, c->quad_reads);
}
