/* The controller core's tick and states: the configuration, start-up, the queues, what comes in, the
 * supervisor, the force law and its command (docs/design.md). The parameters are in ctl_param.c, the
 * telemetry in ctl_telemetry.c, the solver step's slicing in ctl_solver.c. */
#include "swell/ctl.h"

#include <string.h>

#include "ctl_priv.h"
#include "swell/crc.h"
#include "swell/param.h"
#include "swell/pool.h"

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
	.passivity = SWELL_PARAM_DEF_FORCE_PASSIVITY,
	.pc_delay = SWELL_PARAM_DEF_FORCE_PC_DELAY,
	.pc_damping_uN_per_mm_s = SWELL_PARAM_DEF_FORCE_PC_DAMPING,
	.energy_water = 0, /* swell-ctl sets it; the STM32F405 image has no room for the pass */
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
	return SWELL_WAVE_WORDS(nx, ny) + sent_words(nx, ny) + stale_words(nx, ny);
}

static struct swell_body_scene body_scene(const struct swell_ctl_config *cfg)
{
	return (struct swell_body_scene){ cfg->dx_um, cfg->tick_hz, cfg->solver_hz };
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
	    cfg->force_mode > SWELL_FORCE_EFFECT || cfg->passivity > 1 || cfg->energy_water > 1 ||
	    cfg->pc_delay >= SWELL_CTL_PC_RING || cfg->pc_damping_uN_per_mm_s > 1000000)
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
	sp = ctl_safety_params(cfg);
	return swell_fsafety_check(&sp);
}

size_t swell_ctl_arena_words_apart(uint16_t nx, uint16_t ny)
{
	return SWELL_WAVE_WORDS(nx, ny) - (size_t)nx * ny + sent_words(nx, ny) + stale_words(nx, ny);
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
	sp = ctl_safety_params(cfg);
	n = (uint32_t)cfg->nx * cfg->ny;
	/* checked above: none of these can fail */
	if (apart) {
		swell_wave_init_vel_apart(&c->wave, cfg->nx, cfg->ny, arena, SWELL_WAVE_WORDS(cfg->nx, cfg->ny) - n,
					  apart, n, &cfg->wave);
		c->sent = (uint32_t *)(arena + SWELL_WAVE_WORDS(cfg->nx, cfg->ny) - n);
	} else {
		swell_wave_init(&c->wave, cfg->nx, cfg->ny, arena, SWELL_WAVE_WORDS(cfg->nx, cfg->ny), &cfg->wave);
		c->sent = (uint32_t *)(arena + SWELL_WAVE_WORDS(cfg->nx, cfg->ny));
	}
	c->quad_stale = (uint16_t *)(c->sent + sent_words(cfg->nx, cfg->ny));
	swell_body_init(&c->body, &cfg->body, &cfg->xform, &sc, &c->wave);
	for (k = 0; k < 3; k++)
		swell_fsafety_init(&c->safety[k], &sp);

	for (a = 0; a < n; a++)
		ctl_sent_set(c, a, NEVER_SENT);
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

void ctl_push(struct swell_ctl *c, enum swell_ctl_link l, const struct swell_msg *m)
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

/* ---- input ---- */

void swell_ctl_rx(struct swell_ctl *c, enum swell_ctl_link from, const struct swell_msg *m)
{
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
	case SWELL_MSG_PARAM_GET:
		ctl_param_msg(c, m);
		return;
	case SWELL_MSG_ENTER_BOOTLOADER:
		if (c->state == SWELL_CTL_RUNNING) {
			c->n.ignored++; /* never while the force loop runs */
			return;
		}
		swell_ctl_zero_force(c);
		c->bootloader_request = 1;
		ctl_send_heartbeat(c); /* the last word before the reboot: state and counters */
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

/* The tick's FORCE_CMD. Effect mode: none while RUNNING (the effect sets are the device's keepalive,
 * at the update rate), or with cmd_every_tick an enabled one with zero force; otherwise a disabled one
 * with zero force every tick, on which the device drops its effects; and from swell_ctl_zero_force
 * (stop: 1) always a disabled one. */
static void send_force(struct swell_ctl *c, int stop)
{
	struct swell_msg m = ctl_msg(c, SWELL_MSG_FORCE_CMD);
	const int running = c->state == SWELL_CTL_RUNNING;

	if (c->cfg.force_mode == SWELL_FORCE_STREAM) {
		m.u.force_cmd.fx_cN = ctl_force_cN(c, c->force_dev_uN[0]);
		m.u.force_cmd.fy_cN = ctl_force_cN(c, c->force_dev_uN[1]);
		m.u.force_cmd.fz_cN = ctl_force_cN(c, c->force_dev_uN[2]);
		m.u.force_cmd.enable = running;
	} else if (running && !stop && !c->cfg.cmd_every_tick) {
		return;
	} else {
		m.u.force_cmd.enable = running && !stop;
	}
	m.u.force_cmd.seq = c->seq_force++;
	ctl_push(c, SWELL_LINK_DEVICE, &m);
}

void swell_ctl_zero_force(struct swell_ctl *c)
{
	int k;

	for (k = 0; k < 3; k++)
		c->force_dev_uN[k] = swell_fsafety_apply(&c->safety[k], 0, 0);
	send_force(c, 1);
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
			ctl_push(c, SWELL_LINK_DEVICE, &m[k]);
		c->effect_sent = 1;
	}
	f_dev_uN[0] = f_dev_uN[1] = 0;
	f_dev_uN[2] = swell_effect_force_uN(&c->effect, ctl_to_10um(c->pos_um[2]), c->vel_um_s[2] / 100);
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
	ctl_energy_force(c, running, f_dev_uN);
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
	ctl_energy_account(c);
	placed = c->body.placed;
	swell_body_couple_later(&c->body, &c->wave);
	ctl_mark_water_moved(c, &placed);
	work += ctl_solver_slice(c);
	work += ctl_telemetry(c, t, budget);

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
