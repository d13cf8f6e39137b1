/* The controller core; the tick, the states and the telemetry: docs/design.md. */
#include "swell/ctl.h"

#include <string.h>

#include "swell/crc.h"
#include "swell/param.h"
#include "swell/pool.h"

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
#define QUAD_READS_PER_S 90000u
/* Relative costs for spreading a solver step (the velocity form) over its ticks, in instructions
 * measured on the Cortex-M4 image (damped and undamped, every tile awake): a cell of a kernel row with
 * its row driver and the height update one row behind about 32, the body's ceiling scan of a cell
 * while the object is out of the water about 7 (LDM groups of eight), the step's end (the last row's
 * heights, the two fixers of up to 64 cells each, the tile flags, the period's coupling) about 12 k. */
#define COST_CELL 32u
#define COST_SCAN_CELL 7u
#define COST_END 12000u
#define NEVER_SENT INT16_MIN

/* the telemetry's stale bits follow the solver's tiles: a wire tile is a sleeping tile */
_Static_assert(SWELL_PROTO_TILE == SWELL_WAVE_TILE && SWELL_QUADS_PER_TILE == 16, "a tile's quads: 16 bits");

static const struct swell_ctl_config pool_config = {
	.nx = SWELL_POOL_N,
	.ny = SWELL_POOL_N,
	.dx_um = SWELL_POOL_DX_UM,
	.depth_um = SWELL_POOL_DEPTH_UM,
	/* e = 9.81 * 0.004^2 * 0.05 / 0.00625^2 = 0.200909 */
	.wave = { .e = SWELL_PARAM_DEF_WAVE_E,
		  .damping = SWELL_PARAM_DEF_WAVE_DAMPING,
		  .stencil = (enum swell_stencil)SWELL_PARAM_DEF_WAVE_STENCIL },
	.body = { .a_um = SWELL_PARAM_DEF_BODY_A_UM,
		  .b_um = SWELL_PARAM_DEF_BODY_B_UM,
		  .h_um = SWELL_PARAM_DEF_BODY_H_UM,
		  .mass_g = SWELL_PARAM_DEF_BODY_MASS_G,
		  .rho_kg_m3 = 1000,
		  .g_mm_s2 = 9810,
		  .damper_uN_per_mm_s = SWELL_PARAM_DEF_BODY_DAMPER,
		  .deadband_um = 0 },
	/* device frame: x, y horizontal, z up, origin over the pool centre at rest level */
	.xform = { .offset_um = { 200000, 200000, 0 },
		   .scale = SWELL_Q16_ONE,
		   .axis = { 0, 1, 2 },
		   .sign = { 1, 1, 1 } },
	.safety = { .gain = SWELL_PARAM_DEF_FORCE_GAIN,
		    .f_max_uN = SWELL_PARAM_DEF_FORCE_MAX_UN,
		    .rate_uN_per_s = SWELL_PARAM_DEF_FORCE_RATE,
		    .tick_hz = SWELL_POOL_TICK_HZ },
	.tick_hz = SWELL_POOL_TICK_HZ,
	.solver_hz = SWELL_POOL_SOLVER_HZ,
	.silent_ticks = SWELL_PARAM_DEF_SILENT_TICKS,
	.recover_ticks = 250,
	.host_budget = 16,
	.node = 0,
	.autorun = SWELL_PARAM_DEF_AUTORUN,
	.force_mode = SWELL_PARAM_DEF_FORCE_MODE,
	.frame_axes = SWELL_PARAM_DEF_FRAME_AXES,
	.frame_flip = SWELL_PARAM_DEF_FRAME_FLIP,
	.hm_inertia_g = SWELL_PARAM_DEF_HM_INERTIA,
};

void swell_ctl_default_config(struct swell_ctl_config *cfg)
{
	*cfg = pool_config;
}

const char *swell_ctl_state_name(enum swell_ctl_state s)
{
	return swell_state_name((unsigned)s);
}

static size_t sent_words(uint16_t nx, uint16_t ny)
{
	return ((size_t)nx * ny + 1) / 2;
}

/* The telemetry's stale-quad bits: 16 a tile, two tiles a word. */
static size_t stale_words(uint16_t nx, uint16_t ny)
{
	return ((size_t)SWELL_TILES(nx) * SWELL_TILES(ny) + 1) / 2;
}

size_t swell_ctl_arena_words(uint16_t nx, uint16_t ny)
{
	return SWELL_WAVE_VEL_WORDS(nx, ny) + sent_words(nx, ny) + stale_words(nx, ny);
}

static struct swell_body_scene body_scene(const struct swell_ctl_config *cfg)
{
	struct swell_body_scene sc = { cfg->dx_um, cfg->tick_hz, cfg->solver_hz };

	return sc;
}

static struct swell_fsafety_params safety_params(const struct swell_ctl_config *cfg)
{
	struct swell_fsafety_params p = cfg->safety;

	p.tick_hz = cfg->tick_hz;
	return p;
}

/* frame.axes and frame.flip from the frame's axes and signs, and back (a code that is not three
 * different axes: SWELL_EINVAL, nothing changed). */
static uint16_t frame_axes_code(const struct swell_body_xform *xf)
{
	return (uint16_t)((xf->axis[0] + 1u) * 100u + (xf->axis[1] + 1u) * 10u + xf->axis[2] + 1u);
}

static uint8_t frame_flip_code(const struct swell_body_xform *xf)
{
	return (uint8_t)((xf->sign[0] < 0) | (xf->sign[1] < 0) << 1 | (xf->sign[2] < 0) << 2);
}

enum swell_err swell_ctl_check(const struct swell_ctl_config *cfg)
{
	struct swell_body_scene sc;
	struct swell_fsafety_params sp;
	enum swell_err err;

	if (!cfg)
		return SWELL_EINVAL;
	if (cfg->nx < SWELL_WAVE_MIN_SIDE || cfg->ny < SWELL_WAVE_MIN_SIDE || cfg->nx > SWELL_GRID_MAX ||
	    cfg->ny > SWELL_GRID_MAX)
		return SWELL_ESIZE; /* the wire carries grids up to 256 x 256 */
	if (cfg->dx_um < 100 || cfg->dx_um > 65535 || cfg->depth_um < 10 || cfg->depth_um > 655350)
		return SWELL_ERANGE;
	if (cfg->tick_hz < SWELL_TICK_HZ_MIN || cfg->tick_hz > SWELL_TICK_HZ_MAX || cfg->solver_hz == 0 ||
	    cfg->tick_hz % cfg->solver_hz != 0 || cfg->tick_hz / cfg->solver_hz < 2 ||
	    cfg->tick_hz / cfg->solver_hz > SWELL_BODY_MAX_K)
		return SWELL_ERANGE;
	if (cfg->silent_ticks < 1 || cfg->silent_ticks > 10000 || cfg->recover_ticks < 1 || cfg->host_budget < 1 ||
	    cfg->host_budget > SWELL_CTL_QUEUE / 2 || cfg->node > SWELL_NODE_MAX || cfg->autorun > 1 ||
	    cfg->force_mode > SWELL_FORCE_EFFECT)
		return SWELL_ERANGE;
	if (cfg->frame_axes != frame_axes_code(&cfg->xform) || cfg->frame_flip != frame_flip_code(&cfg->xform))
		return SWELL_EINVAL;
	/* the effects act along the device's z: the pool's z must be it, unscaled (swell/effect.h) */
	if (cfg->force_mode == SWELL_FORCE_EFFECT &&
	    (cfg->xform.axis[2] != 2 || cfg->xform.sign[2] != 1 || cfg->xform.scale != SWELL_Q16_ONE))
		return SWELL_EINVAL;
	err = swell_wave_check(&cfg->wave);
	if (err != SWELL_OK)
		return err;
	sc = body_scene(cfg);
	err = swell_body_check(&cfg->body, &cfg->xform, &sc);
	if (err != SWELL_OK)
		return err;
	sp = safety_params(cfg);
	return swell_fsafety_check(&sp);
}

/* Ticks between two sends of something sent hz times a second (at least every tick). */
static uint32_t period(const struct swell_ctl *c, uint32_t hz)
{
	uint32_t p = c->cfg.tick_hz / hz;

	return p ? p : 1;
}

static int16_t sent_get(const struct swell_ctl *c, uint32_t a)
{
	return (int16_t)(uint16_t)(c->sent[a >> 1] >> ((a & 1u) * 16));
}

static void sent_set(struct swell_ctl *c, uint32_t a, int16_t v)
{
	uint32_t shift = (a & 1u) * 16;

	c->sent[a >> 1] = (c->sent[a >> 1] & ~(0xffffu << shift)) | ((uint32_t)(uint16_t)v << shift);
}

size_t swell_ctl_arena_words_apart(uint16_t nx, uint16_t ny)
{
	return SWELL_WAVE_VEL_WORDS(nx, ny) - (size_t)nx * ny + sent_words(nx, ny) + stale_words(nx, ny);
}

size_t swell_ctl_apart_words(uint16_t nx, uint16_t ny)
{
	return (size_t)nx * ny;
}

/* apart: NULL, or the block for the solver's momentum u alone (the sent samples stay in the arena,
 * after the solver's h and flags). */
static enum swell_err init_at(struct swell_ctl *c, const struct swell_ctl_config *cfg, int32_t *arena, size_t words,
			      int32_t *apart, size_t apart_words)
{
	struct swell_body_scene sc;
	struct swell_fsafety_params sp;
	enum swell_err err;
	uint32_t a, n;
	int k;

	if (!c || !arena)
		return SWELL_EINVAL;
	err = swell_ctl_check(cfg);
	if (err != SWELL_OK)
		return err;
	if (apart ? words < swell_ctl_arena_words_apart(cfg->nx, cfg->ny) ||
			    apart_words < swell_ctl_apart_words(cfg->nx, cfg->ny)
		  : words < swell_ctl_arena_words(cfg->nx, cfg->ny))
		return SWELL_ESIZE;

	memset(c, 0, sizeof(*c));
	c->cfg = *cfg;
	sc = body_scene(cfg);
	sp = safety_params(cfg);
	n = (uint32_t)cfg->nx * cfg->ny;
	/* checked above: none of these can fail */
	if (apart) {
		swell_wave_init_vel_apart(&c->wave, cfg->nx, cfg->ny, arena, SWELL_WAVE_VEL_WORDS(cfg->nx, cfg->ny) - n,
					  apart, n, &cfg->wave);
		c->sent = (uint32_t *)(arena + SWELL_WAVE_VEL_WORDS(cfg->nx, cfg->ny) - n);
		c->quad_stale = (uint16_t *)(c->sent + sent_words(cfg->nx, cfg->ny));
	} else {
		swell_wave_init_form(&c->wave, cfg->nx, cfg->ny, arena, SWELL_WAVE_VEL_WORDS(cfg->nx, cfg->ny),
				     &cfg->wave, SWELL_FORM_VELOCITY);
		c->sent = (uint32_t *)(arena + SWELL_WAVE_VEL_WORDS(cfg->nx, cfg->ny));
		c->quad_stale = (uint16_t *)(c->sent + sent_words(cfg->nx, cfg->ny));
	}
	swell_body_init(&c->body, &cfg->body, &cfg->xform, &sc, &c->wave);
	for (k = 0; k < 3; k++)
		swell_fsafety_init(&c->safety[k], &sp);

	for (a = 0; a < n; a++)
		sent_set(c, a, NEVER_SENT);
	c->ticks_per_step = cfg->tick_hz / cfg->solver_hz;
	c->tiles_x = (uint16_t)SWELL_TILES(cfg->nx);
	c->tiles_y = (uint16_t)SWELL_TILES(cfg->ny);
	c->quads = (uint32_t)c->tiles_x * c->tiles_y * SWELL_QUADS_PER_TILE;
	c->quad_reads = QUAD_READS_PER_S / cfg->tick_hz > 0 ? QUAD_READS_PER_S / cfg->tick_hz : 1u;
	for (a = 0; a < (uint32_t)c->tiles_x * c->tiles_y; a++)
		c->quad_stale[a] = 0xffffu; /* nothing sent yet */
	c->fp_cells = (cfg->body.a_um / cfg->dx_um + 2) * (cfg->body.b_um / cfg->dx_um + 2);
	c->since_dev = UINT32_MAX;
	c->state = SWELL_CTL_BOOT;
	c->info_pending = 1;
	{
		uint32_t geo[4] = { cfg->nx, cfg->ny, cfg->dx_um, cfg->depth_um };

		c->scene_id = (uint8_t)swell_crc32(0, geo, sizeof(geo));
	}
	return SWELL_OK;
}

enum swell_err swell_ctl_init(struct swell_ctl *c, const struct swell_ctl_config *cfg, int32_t *arena, size_t words)
{
	return init_at(c, cfg, arena, words, NULL, 0);
}

enum swell_err swell_ctl_init_apart(struct swell_ctl *c, const struct swell_ctl_config *cfg, int32_t *arena,
				    size_t words, int32_t *apart, size_t apart_words)
{
	return apart ? init_at(c, cfg, arena, words, apart, apart_words) : SWELL_EINVAL;
}

/* ---- queues ---- */

static void push(struct swell_ctl *c, enum swell_ctl_link l, const struct swell_msg *m)
{
	struct swell_ctl_queue *q = &c->q[l];

	if (q->count == SWELL_CTL_QUEUE) { /* the port is not draining: the oldest goes */
		q->head = (uint16_t)((q->head + 1) % SWELL_CTL_QUEUE);
		q->count--;
		q->dropped++;
	}
	q->m[(q->head + q->count) % SWELL_CTL_QUEUE] = *m;
	q->count++;
}

size_t swell_ctl_tx(struct swell_ctl *c, enum swell_ctl_link link, struct swell_msg *out, size_t cap)
{
	struct swell_ctl_queue *q = &c->q[link];
	size_t k = 0;

	while (k < cap && q->count) {
		out[k++] = q->m[q->head];
		q->head = (uint16_t)((q->head + 1) % SWELL_CTL_QUEUE);
		q->count--;
	}
	return k;
}

static struct swell_msg msg(const struct swell_ctl *c, enum swell_msg_type type)
{
	struct swell_msg m;

	memset(&m, 0, sizeof(m));
	m.type = (uint8_t)type;
	m.node = c->cfg.node;
	return m;
}

static void send_heartbeat(struct swell_ctl *c);

/* ---- parameters ---- */

static void answer(struct swell_ctl *c, uint16_t id, uint8_t seq, enum swell_err err, int32_t value)
{
	struct swell_msg m;

	if (err == SWELL_OK) {
		m = msg(c, SWELL_MSG_PARAM_ACK);
		m.u.param_ack.id = id;
		m.u.param_ack.value = value;
		m.u.param_ack.seq = seq;
	} else {
		m = msg(c, SWELL_MSG_PARAM_NACK);
		m.u.param_nack.id = id;
		m.u.param_nack.err = (uint8_t)err;
		m.u.param_nack.seq = seq;
		c->n.params_refused++;
	}
	push(c, SWELL_LINK_HOST, &m);
}

/* The parameter table as the core needs it: each row's range, group, access and accessors (one pair
 * of functions a row, expanded from swell/param_table.h): an RW row's field is in the configuration,
 * an RO row's in the controller (what it measures; its setter is never called). */
struct param {
	uint16_t id;
	uint8_t group, when, access;
	int32_t min, max;
	int32_t (*get)(const struct swell_ctl *c);
	void (*set)(struct swell_ctl_config *g, int32_t v);
};

#define PARAM_AT_RW(c, member) ((c)->cfg.member)
#define PARAM_AT_RO(c, member) ((c)->member)
#define PARAM_SET_RW(g, member, ctype, v) ((g)->member = (ctype)(v))
#define PARAM_SET_RO(g, member, ctype, v) ((void)(g), (void)(v))
#define SWELL_X(NAME, id, name, member, ctype, group, min, max, def, factor, unit, access, when, desc) \
	static int32_t get_##NAME(const struct swell_ctl *c)                                           \
	{                                                                                              \
		return (int32_t)PARAM_AT_##access(c, member);                                          \
	}                                                                                              \
	static void set_##NAME(struct swell_ctl_config *g, int32_t v)                                  \
	{                                                                                              \
		PARAM_SET_##access(g, member, ctype, v);                                               \
	}
SWELL_PARAMS(SWELL_X)
#undef SWELL_X

static const struct param params[] = {
#define SWELL_X(NAME, id, name, member, ctype, group, min, max, def, factor, unit, access, when, desc) \
	{ id, SWELL_PGROUP_##group, SWELL_PWHEN_##when, SWELL_PACCESS_##access, min, max, get_##NAME, set_##NAME },
	SWELL_PARAMS(SWELL_X)
#undef SWELL_X
};

/* frame.axes and frame.flip back into the frame's axes and signs (a code that is not three
 * different axes: SWELL_EINVAL). */
static enum swell_err frame_decode(struct swell_ctl_config *g)
{
	const unsigned a[3] = { g->frame_axes / 100u - 1u, g->frame_axes / 10u % 10u - 1u, g->frame_axes % 10u - 1u };
	int k;

	if (a[0] > 2 || a[1] > 2 || a[2] > 2 || a[0] == a[1] || a[0] == a[2] || a[1] == a[2] || g->frame_flip > 7)
		return SWELL_EINVAL;
	for (k = 0; k < 3; k++) {
		g->xform.axis[k] = (uint8_t)a[k];
		g->xform.sign[k] = (int8_t)(g->frame_flip >> k & 1u ? -1 : 1);
	}
	return SWELL_OK;
}

static const struct param *param_find(uint16_t id)
{
	size_t k;

	for (k = 0; k < sizeof(params) / sizeof(params[0]); k++)
		if (params[k].id == id)
			return &params[k];
	return NULL;
}

/* The current value of a parameter; SWELL_EUNKNOWN for an id that is not one. */
static enum swell_err param_get(const struct swell_ctl *c, uint16_t id, int32_t *v)
{
	const struct param *p = param_find(id);

	if (id == SWELL_PARAM_COMMAND)
		return SWELL_EINVAL; /* write only */
	if (!p)
		return SWELL_EUNKNOWN;
	*v = p->get(c);
	return SWELL_OK;
}

static enum swell_err command(struct swell_ctl *c, int32_t v)
{
	switch (v) {
	case SWELL_CMD_STOP:
		c->run_request = 0;
		c->host_stop = 1; /* a stop from the host holds with autorun too, until RUN */
		return SWELL_OK;
	case SWELL_CMD_RUN:
		c->run_request = 1;
		c->host_stop = 0;
		return SWELL_OK;
	case SWELL_CMD_CLEAR:
		if (c->state != SWELL_CTL_FAULT)
			return SWELL_ESTATE;
		c->clear_request = 1;
		return SWELL_OK;
	default:
		return SWELL_ERANGE;
	}
}

/* Apply one parameter: its raw range first, then a whole candidate configuration, then the changed
 * part goes to its module, whose own setter validates again (the body refuses a change while the
 * object displaces water: the table's DRY rule); nothing changes unless everything accepts it. */
static enum swell_err param_set(struct swell_ctl *c, uint16_t id, int32_t v)
{
	const struct param *p = param_find(id);
	struct swell_ctl_config g = c->cfg;
	struct swell_fsafety_params sp;
	enum swell_err err = SWELL_OK;
	int k;

	if (id == SWELL_PARAM_COMMAND)
		return command(c, v);
	if (!p)
		return SWELL_EUNKNOWN;
	if (v < p->min || v > p->max)
		return SWELL_ERANGE;
	if (p->access == SWELL_PACCESS_RO)
		return SWELL_EINVAL; /* measured, not set */
	if (p->when == SWELL_PWHEN_IDLE && c->state == SWELL_CTL_RUNNING)
		return SWELL_ESTATE;
	p->set(&g, v);
	if (p->group == SWELL_PGROUP_FRAME && (err = frame_decode(&g)) != SWELL_OK)
		return err;
	err = swell_ctl_check(&g);
	if (err != SWELL_OK)
		return err;

	switch (p->group) {
	case SWELL_PGROUP_WAVE:
		err = swell_wave_set_params(&c->wave, &g.wave);
		break;
	case SWELL_PGROUP_BODY:
	case SWELL_PGROUP_SIZE:
	case SWELL_PGROUP_FRAME: /* the body refuses a new frame while the object displaces water */
		err = swell_body_set_params(&c->body, &g.body, &g.xform);
		if (err == SWELL_OK) {
			c->fp_cells = (g.body.a_um / g.dx_um + 2) * (g.body.b_um / g.dx_um + 2);
			c->info_pending |= p->group == SWELL_PGROUP_SIZE; /* CTL_INFO carries the size */
		}
		break;
	case SWELL_PGROUP_SAFETY:
		sp = safety_params(&g);
		for (k = 0; k < 3 && err == SWELL_OK; k++)
			err = swell_fsafety_set(&c->safety[k], &sp); /* same params: all or none fail */
		break;
	default:
		break;
	}
	if (err != SWELL_OK)
		return err;
	c->cfg = g;
	c->n.params_set++;
	return SWELL_OK;
}

/* ---- input ---- */

void swell_ctl_rx(struct swell_ctl *c, enum swell_ctl_link from, const struct swell_msg *m)
{
	enum swell_err err;
	int32_t v = 0;
	uint32_t lost;

	if (from == SWELL_LINK_DEVICE) {
		switch (m->type) {
		case SWELL_MSG_DEVICE_POS:
			c->pos_um[0] = (int32_t)m->u.device_pos.x_10um * 10;
			c->pos_um[1] = (int32_t)m->u.device_pos.y_10um * 10;
			c->pos_um[2] = (int32_t)m->u.device_pos.z_10um * 10;
			c->dev_status = m->u.device_pos.status;
			/* seq counts device ticks; in effect mode the device reports once an update, so a
			 * sample is lost only when a whole update period more is skipped */
			c->dev_step = c->dev_seq.started ? (uint8_t)(m->u.device_pos.seq - c->dev_seq.last) : 1u;
			lost = swell_seq_track(&c->dev_seq, m->u.device_pos.seq);
			c->n.dev_lost += c->cfg.force_mode == SWELL_FORCE_EFFECT ? lost / c->ticks_per_step : lost;
			c->dev_heard = 1;
			c->dev_count++;
			return;
		case SWELL_MSG_DEVICE_VEL:
			c->vel_um_s[0] = (int32_t)m->u.device_vel.vx_100ums * 100;
			c->vel_um_s[1] = (int32_t)m->u.device_vel.vy_100ums * 100;
			c->vel_um_s[2] = (int32_t)m->u.device_vel.vz_100ums * 100;
			c->dev_heard = 1;
			return;
		case SWELL_MSG_DEVICE_FORCE:
			c->dev_heard = 1;
			return;
		default:
			c->n.ignored++;
			return;
		}
	}
	switch (m->type) {
	case SWELL_MSG_PARAM_SET:
		err = param_set(c, m->u.param_set.id, m->u.param_set.value);
		v = m->u.param_set.value; /* a command (write only) is echoed as given */
		if (err == SWELL_OK && m->u.param_set.id != SWELL_PARAM_COMMAND)
			err = param_get(c, m->u.param_set.id, &v); /* the value now in force */
		answer(c, m->u.param_set.id, m->u.param_set.seq, err, v);
		return;
	case SWELL_MSG_PARAM_GET:
		err = param_get(c, m->u.param_get.id, &v);
		answer(c, m->u.param_get.id, m->u.param_get.seq, err, v);
		return;
	case SWELL_MSG_ENTER_BOOTLOADER:
		if (c->state == SWELL_CTL_RUNNING) {
			c->n.ignored++; /* never while the force loop runs */
			return;
		}
		swell_ctl_zero_force(c);
		c->bootloader_request = 1;
		send_heartbeat(c); /* the last word before the reboot: state and counters */
		return;
	default:
		c->n.ignored++;
		return;
	}
}

void swell_ctl_link_down(struct swell_ctl *c, enum swell_ctl_link link)
{
	if (link != SWELL_LINK_DEVICE)
		return;
	c->dev_heard = 0;
	c->dev_back = 0;
	if (c->since_dev < swell_ctl_silent_limit(c))
		c->since_dev = swell_ctl_silent_limit(c);
}

uint32_t swell_ctl_silent_limit(const struct swell_ctl *c)
{
	const uint32_t two_updates = 2u * c->ticks_per_step;

	/* effect mode: the device reports once an update, so never less than two update periods */
	if (c->cfg.force_mode == SWELL_FORCE_EFFECT && !c->cfg.cmd_every_tick && c->cfg.silent_ticks < two_updates)
		return two_updates;
	return c->cfg.silent_ticks;
}

int swell_ctl_device_lost(const struct swell_ctl *c)
{
	return c->since_dev >= swell_ctl_silent_limit(c);
}

int swell_ctl_background_due(const struct swell_ctl *c)
{
	return c->bg_pending;
}

int swell_ctl_bootloader_requested(const struct swell_ctl *c)
{
	return c->bootloader_request;
}

void swell_ctl_overrun(struct swell_ctl *c)
{
	c->n.overruns++;
}

void swell_ctl_bad_frames(struct swell_ctl *c, uint32_t n)
{
	c->n.bad_frames = c->n.bad_frames + n < c->n.bad_frames ? UINT32_MAX : c->n.bad_frames + n;
}

/* ---- output ---- */

static int16_t to_cN(int32_t uN)
{
	int32_t cN = (uN >= 0 ? uN + 5000 : uN - 5000) / 10000;

	return (int16_t)swell_clamp(cN, -25000, 25000);
}

static int16_t to_10um(int32_t um)
{
	int32_t t = (um >= 0 ? um + 5 : um - 5) / 10;

	return (int16_t)swell_clamp(t, -30000, 30000);
}

/* A limited force on the wire: to the nearest cN, but no more than the whole cN within f_max (a limit
 * that is not a whole number of cN would otherwise be passed by up to 0.5 cN). */
static int16_t force_cN(const struct swell_ctl *c, int32_t uN)
{
	const int32_t lim = (int32_t)(c->cfg.safety.f_max_uN / 10000u);

	return (int16_t)swell_clamp(to_cN(uN), -lim, lim);
}

/* The tick's FORCE_CMD. Effect mode: none while RUNNING (the effect sets are the device's keepalive,
 * at the update rate), or with cmd_every_tick an enabled one with zero force; otherwise a disabled one
 * with zero force every tick, on which the device drops its effects; and from swell_ctl_zero_force
 * (stop: 1) always a disabled one. */
static void send_force(struct swell_ctl *c, int stop)
{
	struct swell_msg m = msg(c, SWELL_MSG_FORCE_CMD);
	const int running = c->state == SWELL_CTL_RUNNING;

	if (c->cfg.force_mode == SWELL_FORCE_STREAM) {
		m.u.force_cmd.fx_cN = force_cN(c, c->force_dev_uN[0]);
		m.u.force_cmd.fy_cN = force_cN(c, c->force_dev_uN[1]);
		m.u.force_cmd.fz_cN = force_cN(c, c->force_dev_uN[2]);
		m.u.force_cmd.enable = running;
	} else if (running && !stop && !c->cfg.cmd_every_tick) {
		return;
	} else {
		m.u.force_cmd.enable = running && !stop;
	}
	m.u.force_cmd.seq = c->seq_force++;
	push(c, SWELL_LINK_DEVICE, &m);
}

void swell_ctl_zero_force(struct swell_ctl *c)
{
	int k;

	for (k = 0; k < 3; k++)
		c->force_dev_uN[k] = swell_fsafety_apply(&c->safety[k], 0, 0);
	send_force(c, 1);
}

static uint16_t sat16(uint32_t x)
{
	return x > 0xffffu ? 0xffffu : (uint16_t)x;
}

static void send_heartbeat(struct swell_ctl *c)
{
	struct swell_msg m = msg(c, SWELL_MSG_HEARTBEAT);

	m.u.heartbeat.state = (uint8_t)c->state;
	m.u.heartbeat.err = (uint8_t)c->last_err;
	m.u.heartbeat.version = SWELL_PROTO_VERSION;
	m.u.heartbeat.seq = c->seq_hb++;
	m.u.heartbeat.bad_frames = sat16(c->n.bad_frames);
	m.u.heartbeat.overruns = sat16(c->n.overruns);
	push(c, SWELL_LINK_HOST, &m);
	push(c, SWELL_LINK_DEVICE, &m);
}

static void send_scene(struct swell_ctl *c)
{
	struct swell_msg m = msg(c, SWELL_MSG_SCENE);

	m.u.scene.nx = c->cfg.nx;
	m.u.scene.ny = c->cfg.ny;
	m.u.scene.h_shift = SWELL_PROTO_H_SHIFT;
	m.u.scene.dx_um = (uint16_t)c->cfg.dx_um;
	m.u.scene.depth_10um = (uint16_t)(c->cfg.depth_um / 10);
	m.u.scene.scene_id = c->scene_id;
	push(c, SWELL_LINK_HOST, &m);
}

/* Size on the wire: 0.1 mm, rounded to nearest, saturated to the field's 1 .. 8191. */
static uint16_t to_100um(uint32_t um)
{
	uint32_t v = (um + 50u) / 100u;

	return (uint16_t)(v < 1u ? 1u : v > 8191u ? 8191u : v);
}

static void send_info(struct swell_ctl *c)
{
	struct swell_msg m = msg(c, SWELL_MSG_CTL_INFO);

	m.u.ctl_info.fw_major = c->cfg.fw_version[0];
	m.u.ctl_info.fw_minor = c->cfg.fw_version[1];
	m.u.ctl_info.fw_patch = c->cfg.fw_version[2];
	m.u.ctl_info.obj_a_100um = to_100um(c->cfg.body.a_um);
	m.u.ctl_info.obj_b_100um = to_100um(c->cfg.body.b_um);
	m.u.ctl_info.obj_h_100um = to_100um(c->cfg.body.h_um);
	push(c, SWELL_LINK_HOST, &m);
	c->info_pending = 0;
	c->info_wait = period(c, INFO_HZ); /* the next one a second later, unless something changes */
}

static void send_pose(struct swell_ctl *c)
{
	struct swell_msg p = msg(c, SWELL_MSG_OBJECT_POSE), f = msg(c, SWELL_MSG_OBJECT_FORCE);
	int32_t half_pct = 0;

	if (c->cfg.body.h_um > 0)
		half_pct = (int32_t)(((int64_t)c->out.delta_lsb * 200) / swell_um_to_lsb((int64_t)c->cfg.body.h_um));
	p.u.object_pose.x_10um = to_10um(c->out.x_um);
	p.u.object_pose.y_10um = to_10um(c->out.y_um);
	p.u.object_pose.z_10um = to_10um(c->out.z_um);
	p.u.object_pose.submersion_halfpct = (uint8_t)swell_clamp(half_pct, 0, 200);
	p.u.object_pose.seq = c->seq_pose;
	f.u.object_force.fx_cN = force_cN(c, c->force_dev_uN[0]);
	f.u.object_force.fy_cN = force_cN(c, c->force_dev_uN[1]);
	f.u.object_force.fz_cN = force_cN(c, c->force_dev_uN[2]);
	f.u.object_force.seq = c->seq_pose++;
	f.u.object_force.limits = c->limits;
	push(c, SWELL_LINK_HOST, &p);
	push(c, SWELL_LINK_HOST, &f);
}

/* Two wire samples as sent[] holds them: the first in the low half. */
static inline uint32_t sample_pair(int32_t h0, int32_t h1)
{
	return (uint32_t)(uint16_t)swell_height_to_sample(h0) | (uint32_t)(uint16_t)swell_height_to_sample(h1) << 16;
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
		/* swell_wave_h of the four cells, one row: one test whether the row is finished ahead */
		const int32_t *h = c->wave.h + a;
		int32_t x0 = h[0], x1 = h[1], x2 = h[2], x3 = h[3];
		uint32_t w0, w1;

		if (at->y < c->wave.done_row) { /* h(n) = h - dh(u) */
			const int32_t *u = c->wave.u + a;

			x0 -= swell_wave_vel_dh(&c->wave, u[0]);
			x1 -= swell_wave_vel_dh(&c->wave, u[1]);
			x2 -= swell_wave_vel_dh(&c->wave, u[2]);
			x3 -= swell_wave_vel_dh(&c->wave, u[3]);
		}
		w0 = sample_pair(x0, x1);
		w1 = sample_pair(x2, x3);

		s[0] = (int16_t)(uint16_t)w0;
		s[1] = (int16_t)(uint16_t)(w0 >> 16);
		s[2] = (int16_t)(uint16_t)w1;
		s[3] = (int16_t)(uint16_t)(w1 >> 16);
		*changed = w0 != c->sent[a >> 1] || w1 != c->sent[(a >> 1) + 1];
		return 4;
	}
	for (k = 0; k < 4 && at->x0 + k < nx; k++) {
		s[k] = swell_height_to_sample(swell_wave_h(&c->wave, a + k));
		*changed |= s[k] != sent_get(c, a + k);
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
	push(c, SWELL_LINK_HOST, &m);
	for (k = 0; k < cells; k++)
		sent_set(c, a + k, s[k]);
	c->n.quads_sent++;
}

/* The solver step just finished: the quads of every tile that moved may now differ from what was
 * last sent. */
static void mark_moved_tiles(struct swell_ctl *c)
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
static void mark_water_moved(struct swell_ctl *c, const struct swell_body_fp *before)
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
	push(c, SWELL_LINK_HOST, &m);
	c->sent[a >> 1] = w0;
	c->sent[(a >> 1) + 1] = w1;
	c->n.quads_sent++;
}

/* Two heights of the core's field (|h| < 2^28: SSAT 27 in the solver) as the two samples sent[] holds
 * for them: swell_height_to_sample with its rounding, floor((h + 2^(s-1)) / 2^s) saturated to 12 bits,
 * in one shift of h + 2^(s-1) (no overflow for such h) and a pack of the two halves. */
static inline uint32_t field_pair(int32_t h0, int32_t h1)
{
	const int shift = 16 - SWELL_PROTO_H_SHIFT;
	const int32_t half = (int32_t)1 << (shift - 1);
	int32_t s0 = (h0 + half) >> shift, s1 = (h1 + half) >> shift;

#if defined(__ARM_FEATURE_SAT)
	s0 = __ssat(s0, 12);
	s1 = __ssat(s1, 12);
#else
	s0 = swell_clamp(s0, -2048, 2047);
	s1 = swell_clamp(s1, -2048, 2047);
#endif
	return (uint32_t)(uint16_t)s0 | (uint32_t)s1 << 16;
}

/* What a scan may still do in this tick (messages to send, stale quads to read), and the cells read. */
struct scan_left {
	uint32_t msgs, reads, cells;
};

/* scan_run over a tile wholly inside a grid of even width: every quad is four cells of one row and two
 * words of sent[], read as h(n) of the last finished step (h - dh(u) in the tile's rows finished
 * ahead, swell_wave_h), sent from the words. The tile's pointers and its rows finished ahead are found once,
 * and the loop goes from stale bit to stale bit. */
static uint32_t scan_whole_tile(struct swell_ctl *c, uint32_t q, uint32_t run, struct scan_left *left,
				struct swell_quad_at *at)
{
	uint16_t *const stale_at = &c->quad_stale[q / SWELL_QUADS_PER_TILE];
	const uint32_t nx = c->cfg.nx, x_tile = at->x0 - 4u * at->half, y_tile = at->y - at->row;
	const uint32_t corner = y_tile * nx + x_tile, done = c->wave.done_row, first = q % SWELL_QUADS_PER_TILE;
	const int32_t *const h = c->wave.h + corner, *const u = c->wave.u + corner;
	const uint32_t *const sent = c->sent + corner / 2;
	/* quads of rows finished ahead: bits below 2 (done_row - y_tile) */
	const uint32_t ahead = done <= y_tile ? 0 : done - y_tile >= SWELL_PROTO_TILE ? 16u : 2u * (done - y_tile);
	/* the run's stale bits: [first, first + run) of the tile's */
	uint32_t todo = *stale_at & ((run < SWELL_QUADS_PER_TILE ? (1u << run) - 1u : 0xffffu) << first);
	uint32_t msgs = left->msgs, reads = left->reads, bit = first;

	while (todo && msgs && reads) {
		const int32_t *hq;
		uint32_t o, w0, w1;

		bit = (uint32_t)__builtin_ctz(todo);
		todo &= todo - 1u;
		reads--;
		o = (bit >> 1) * nx + 4u * (bit & 1u);
		hq = h + o;
		if (bit < ahead) { /* h(n) = h - dh(u) */
			const int32_t *const uq = u + o;
			const struct swell_wave *const w = &c->wave;

			w0 = field_pair(hq[0] - swell_wave_vel_dh(w, uq[0]), hq[1] - swell_wave_vel_dh(w, uq[1]));
			w1 = field_pair(hq[2] - swell_wave_vel_dh(w, uq[2]), hq[3] - swell_wave_vel_dh(w, uq[3]));
		} else {
			w0 = field_pair(hq[0], hq[1]);
			w1 = field_pair(hq[2], hq[3]);
		}
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

/* ---- the tick ---- */

static void enter(struct swell_ctl *c, enum swell_ctl_state s, enum swell_err why)
{
	if (s == SWELL_CTL_FAULT) {
		c->last_err = why;
		c->n.faults++;
		c->run_request = 0;
	}
	c->clear_request = 0;
	c->state = s;
}

static void supervise(struct swell_ctl *c)
{
	const int estop = (c->dev_status & SWELL_DEV_ESTOP) != 0, powered = (c->dev_status & SWELL_DEV_POWERED) != 0;
	int alive;

	if (c->dev_heard) {
		c->since_dev = 0;
		/* back = heard with the e-stop released: autorun's recovery counts from the release */
		if (estop)
			c->dev_back = 0;
		else if (c->dev_back < UINT32_MAX)
			c->dev_back++;
	} else {
		if (c->since_dev < UINT32_MAX)
			c->since_dev++;
		c->dev_back = 0;
	}
	c->dev_heard = 0;
	alive = c->since_dev < swell_ctl_silent_limit(c);
	/* dev.rate: DEVICE_POS counted over each whole second of ticks */
	if (++c->dev_window >= c->cfg.tick_hz) {
		c->dev_rate_hz = (uint16_t)(c->dev_count > UINT16_MAX ? UINT16_MAX : c->dev_count);
		c->dev_count = 0;
		c->dev_window = 0;
	}

	switch (c->state) {
	case SWELL_CTL_BOOT:
		enter(c, SWELL_CTL_IDLE, SWELL_OK);
		break;
	case SWELL_CTL_IDLE:
		if (alive)
			enter(c, SWELL_CTL_ARMED, SWELL_OK);
		break;
	case SWELL_CTL_ARMED:
		if (!alive)
			enter(c, SWELL_CTL_IDLE, SWELL_OK);
		else if ((c->run_request || (c->cfg.autorun && !c->host_stop)) && powered && !estop &&
			 !c->bootloader_request)
			enter(c, SWELL_CTL_RUNNING, SWELL_OK); /* never again once the reboot is on its way */
		break;
	case SWELL_CTL_RUNNING:
		if (!alive)
			enter(c, SWELL_CTL_FAULT, SWELL_ETIMEOUT);
		else if (estop)
			enter(c, SWELL_CTL_FAULT, SWELL_ESTOP);
		else if (!c->run_request && (!c->cfg.autorun || c->host_stop))
			enter(c, SWELL_CTL_ARMED, SWELL_OK);
		break;
	case SWELL_CTL_FAULT:
		if (alive && !estop && (c->clear_request || (c->cfg.autorun && c->dev_back >= c->cfg.recover_ticks)))
			enter(c, SWELL_CTL_IDLE, SWELL_OK);
		break;
	}
}

/* Effect mode, RUNNING: at each solver step (and on the first tick of RUNNING) the set for this
 * tick's state goes out; every tick the force it produces at the device's state is what the safety
 * stage watches (*f_dev_uN, device axes), so telemetry and the limit flags show what is asked for. */
static void effect_update(struct swell_ctl *c, int32_t f_dev_uN[3])
{
	struct swell_msg m[3];
	int k;

	if (c->phase == 0 || !c->effect_sent) {
		c->effect.seq++;
		swell_effect_from_body(&c->effect, &c->body, &c->out, c->cfg.xform.offset_um[2], c->cfg.safety.f_max_uN,
				       c->cfg.safety.rate_uN_per_s);
		swell_effect_encode(&c->effect, c->cfg.node, m);
		for (k = 0; k < 3; k++)
			push(c, SWELL_LINK_DEVICE, &m[k]);
		c->effect_sent = 1;
	}
	f_dev_uN[0] = f_dev_uN[1] = 0;
	f_dev_uN[2] = swell_effect_force_uN(&c->effect, to_10um(c->pos_um[2]), c->vel_um_s[2] / 100);
}

static uint32_t force_law(struct swell_ctl *c)
{
	const int running = c->state == SWELL_CTL_RUNNING;
	uint32_t before = 0, after = 0, rate_before = 0, rate_after = 0, work = 1;
	int32_t f_dev_uN[3] = { 0, 0, 0 };
	int k;

	if (c->state == SWELL_CTL_ARMED || running) {
		swell_body_tick_force(&c->body, &c->wave, c->pos_um, c->vel_um_s, &c->out);
		work = c->out.skipped ? 1 : c->fp_cells;
		for (k = 0; k < 3; k++)
			f_dev_uN[k] = c->out.f_dev_uN[k];
	}
	if (running && c->cfg.force_mode == SWELL_FORCE_EFFECT)
		effect_update(c, f_dev_uN);
	if (!running)
		c->effect_sent = 0;
	for (k = 0; k < 3; k++) {
		before += c->safety[k].force_limited;
		rate_before += c->safety[k].rate_limited;
		c->force_dev_uN[k] = swell_fsafety_apply(&c->safety[k], running ? f_dev_uN[k] : 0, running);
		after += c->safety[k].force_limited;
		rate_after += c->safety[k].rate_limited;
	}
	c->limits = (uint8_t)((after != before ? 1u : 0u) | (rate_after != rate_before ? 2u : 0u));
	send_force(c, 0);
	return work;
}

/* The solver step spread over the K ticks of its period: tick k does the momentum of its share of
 * rows (by the relative costs above, the period's rows and its end in K equal parts: after tick k < K-1
 * the rows that fit (k+1) parts, the rest on tick K-1 with the step's end), whose heights become
 * h(n+1) one row behind (wave.h, velocity form), and the body's ceiling scan of the rows that hold h(n+1) (while the object is out of the
 * water); tick K-1 also completes the step (the last row's heights, the fixers, the tile flags) and
 * then places the period's coupling into h(n+1). The force law in between reads h(n) and the solver's
 * change in every row (wave.h: h - dh(u) in rows below done_row), so it never sees a half-finished
 * step. */
static uint32_t solver_slice(struct swell_ctl *c)
{
	struct swell_wave *w = &c->wave;
	const uint32_t done0 = w->done_row, k = c->phase, kk = c->ticks_per_step;
	/* a row's cost, and the period's: the rows and the step's end */
	const uint32_t row = w->nx * (c->body.wet ? COST_CELL : COST_CELL + COST_SCAN_CELL);
	const uint32_t total = row * w->ny + COST_END;
	const uint32_t fit = k + 1 < kk ? total / kk * (k + 1) / row : w->ny;
	const uint32_t target = fit < w->ny ? fit : w->ny;
	const uint32_t rows = target > w->next_row ? target - w->next_row : 0;
	struct swell_body_fp placed;
	uint32_t work;

	swell_wave_step_rows(w, (int)rows);
	if (k + 1 < kk) {
		swell_body_scan_ahead(&c->body, w);
		work = (rows + (w->done_row - done0)) * w->nx;
	} else {
		swell_wave_step_finish(w);
		mark_moved_tiles(c);
		/* the period's coupling, kept back, into h(n+1): the tiles it wrote are stale too */
		placed = c->body.placed;
		swell_body_place(&c->body, w);
		mark_water_moved(c, &placed);
		swell_body_solver_stepped(&c->body, w);
		c->n.solver_steps++;
		/* the rows, the last row's heights and the ceiling scan of the rows left */
		work = (rows + 2u * (w->ny - done0)) * w->nx;
	}
	c->phase = c->phase + 1 == c->ticks_per_step ? 0 : c->phase + 1;
	return work;
}

void swell_ctl_tick_force(struct swell_ctl *c)
{
	if (c->bg_pending)
		c->n.overruns++; /* the last background part has not finished: the force path goes first */
	c->n.ticks++;
	supervise(c);
	c->work_force = force_law(c);
	c->bg_pending = 1;
}

void swell_ctl_tick_background(struct swell_ctl *c)
{
	const uint32_t t = c->n.ticks - 1;
	uint32_t budget = c->cfg.host_budget, work = c->work_force;
	struct swell_body_fp placed;

	if (!c->bg_pending)
		return;
	/* the force part's coupling, before the field moves on; while the object stays in the water its
	 * cells are written once a period, at the step's end (swell_body_couple_later); written now, the
	 * tiles it left and those it covers are stale for the telemetry */
	placed = c->body.placed;
	swell_body_couple_later(&c->body, &c->wave);
	mark_water_moved(c, &placed);
	work += solver_slice(c);
	if (t % period(c, HEARTBEAT_HZ) == 0) {
		send_heartbeat(c);
		budget--;
	}
	if (budget && t % period(c, SCENE_HZ) == 1 % period(c, SCENE_HZ)) {
		send_scene(c);
		budget--;
	}
	if (c->info_wait)
		c->info_wait--;
	if (budget && (c->info_pending || c->info_wait == 0)) {
		send_info(c);
		budget--;
	}
	if (budget >= 2 && t % period(c, POSE_HZ) == 2 % period(c, POSE_HZ)) {
		send_pose(c);
		budget -= 2;
	}
	/* c->phase 0: this tick ended a step */
	work += send_heights(c, budget, c->phase == 0 ? 0u : QUAD_SCAN_PER_TICK, c->quad_reads);

	c->n.work = work;
	if (work > c->n.work_max)
		c->n.work_max = work;
	c->bg_pending = 0;
}

void swell_ctl_tick(struct swell_ctl *c)
{
	swell_ctl_tick_force(c);
	swell_ctl_tick_background(c);
}
