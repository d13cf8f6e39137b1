#include "swell/ctl_pool.h"

#include "swell/scene.h"

enum swell_err fw_pool_place(uint16_t nx, uint16_t ny, const struct fw_mem *m, struct fw_pool_at *p)
{
	struct fw_pool_at r = { 0 };

	if (!m || !p)
		return SWELL_EINVAL;
	if (swell_ctl_arena_words(nx, ny) <= m->sram_words) {
		r.sram_words = swell_ctl_arena_words(nx, ny);
	} else if (m->fast && swell_ctl_arena_words_apart(nx, ny) <= m->sram_words &&
		   swell_ctl_apart_words(nx, ny) <= m->fast_words) {
		r.apart = 1;
		r.sram_words = swell_ctl_arena_words_apart(nx, ny);
		r.fast_words = swell_ctl_apart_words(nx, ny);
	} else {
		return SWELL_ESIZE;
	}
	*p = r;
	return SWELL_OK;
}

enum swell_err fw_pool_start(struct swell_ctl *c, const struct swell_ctl_config *cfg, const struct fw_mem *m,
			     struct fw_pool_at *p)
{
	struct fw_pool_at r;
	enum swell_err err;

	if (!c || !cfg)
		return SWELL_EINVAL;
	err = swell_ctl_check(cfg); /* the configuration's own reason before the memory's */
	if (err == SWELL_OK)
		err = fw_pool_place(cfg->nx, cfg->ny, m, &r);
	if (err != SWELL_OK)
		return err;
	err = r.apart ? swell_ctl_init_apart(c, cfg, m->sram, m->sram_words, m->fast, m->fast_words)
		      : swell_ctl_init(c, cfg, m->sram, m->sram_words);
	if (err == SWELL_OK)
		*p = r;
	return err;
}

/* The value of a start-up parameter (fw_pool_is_startup) in g. */
static int32_t startup_get(const struct swell_ctl_config *g, uint16_t id)
{
	switch (id) {
	case SWELL_SCENE_NX:
		return g->nx;
	case SWELL_SCENE_NY:
		return g->ny;
	case SWELL_SCENE_DX_UM:
		return (int32_t)g->dx_um;
	default:
		return (int32_t)g->depth_um;
	}
}

/* cfg with the start-up parameter id set to v; SWELL_ERANGE when it does not fit its field. */
static enum swell_err startup_set(struct swell_ctl_config *g, uint16_t id, int32_t v)
{
	if (v <= 0)
		return SWELL_ERANGE;
	if (id == SWELL_SCENE_NX || id == SWELL_SCENE_NY) {
		if (v > UINT16_MAX)
			return SWELL_ESIZE;
		*(id == SWELL_SCENE_NX ? &g->nx : &g->ny) = (uint16_t)v;
		return SWELL_OK;
	}
	*(id == SWELL_SCENE_DX_UM ? &g->dx_um : &g->depth_um) = (uint32_t)v;
	if (!g->solver_hz || 1000000u % g->solver_hz) /* eq. 2 needs a whole number of us a step */
		return SWELL_ERANGE;
	return swell_wave_e_from_physical(g->body.g_mm_s2, 1000000u / g->solver_hz, g->depth_um, g->dx_um, &g->wave.e);
}

int fw_pool_is_startup(const struct swell_msg *m)
{
	uint16_t id;

	if (m->type != SWELL_MSG_PARAM_SET && m->type != SWELL_MSG_PARAM_GET)
		return 0;
	id = m->type == SWELL_MSG_PARAM_SET ? m->u.param_set.id : m->u.param_get.id;
	return id >= SWELL_SCENE_NX && id <= SWELL_SCENE_DEPTH_UM;
}

int fw_pool_param(struct swell_ctl *c, const struct fw_mem *m, const struct swell_msg *in, struct swell_msg *answer,
		  struct fw_pool_at *p)
{
	struct swell_ctl_config g = c->cfg;
	const int set = in->type == SWELL_MSG_PARAM_SET;
	const uint16_t id = set ? in->u.param_set.id : in->u.param_get.id;
	const uint8_t seq = set ? in->u.param_set.seq : in->u.param_get.seq;
	enum swell_err err = SWELL_OK;
	int32_t v;

	if (!fw_pool_is_startup(in))
		return 0;
	v = startup_get(&g, id);
	if (set) {
		if (c->state == SWELL_CTL_RUNNING)
			err = SWELL_ESTATE; /* the force law runs on this memory */
		else
			err = startup_set(&g, id, in->u.param_set.value);
		if (err == SWELL_OK)
			err = fw_pool_start(c, &g, m, p); /* c untouched on error */
		if (err == SWELL_OK)
			v = startup_get(&g, id);
	}
	*answer = (struct swell_msg){ .type = err == SWELL_OK ? SWELL_MSG_PARAM_ACK : SWELL_MSG_PARAM_NACK,
				      .node = c->cfg.node };
	if (err == SWELL_OK) {
		answer->u.param_ack.id = id;
		answer->u.param_ack.value = v;
		answer->u.param_ack.seq = seq;
	} else {
		answer->u.param_nack.id = id;
		answer->u.param_nack.err = (uint8_t)err;
		answer->u.param_nack.seq = seq;
	}
	return 1;
}
