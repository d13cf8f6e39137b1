/* The controller core's parameters: PARAM_SET and PARAM_GET against the parameter table
 * (swell/param_table.h), a change applied whole or not at all. */
#include "ctl_priv.h"
#include "swell/param.h"

static void answer(struct swell_ctl *c, uint16_t id, uint8_t seq, enum swell_err err, int32_t value)
{
	struct swell_msg m;

	if (err == SWELL_OK) {
		m = ctl_msg(c, SWELL_MSG_PARAM_ACK);
		m.u.param_ack.id = id;
		m.u.param_ack.value = value;
		m.u.param_ack.seq = seq;
	} else {
		m = ctl_msg(c, SWELL_MSG_PARAM_NACK);
		m.u.param_nack.id = id;
		m.u.param_nack.err = (uint8_t)err;
		m.u.param_nack.seq = seq;
		c->n.params_refused++;
	}
	ctl_push(c, SWELL_LINK_HOST, &m);
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
		sp = ctl_safety_params(&g);
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

void ctl_param_msg(struct swell_ctl *c, const struct swell_msg *m)
{
	const int set = m->type == SWELL_MSG_PARAM_SET;
	const uint16_t id = set ? m->u.param_set.id : m->u.param_get.id;
	int32_t v = set ? m->u.param_set.value : 0; /* a command (write only) is echoed as given */
	enum swell_err err = set ? param_set(c, id, v) : SWELL_OK;

	if (err == SWELL_OK && (!set || id != SWELL_PARAM_COMMAND))
		err = param_get(c, id, &v); /* the value now in force */
	answer(c, id, set ? m->u.param_set.seq : m->u.param_get.seq, err, v);
}
