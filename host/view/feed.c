/* Decoder side of swell-view, see feed.h. */
#include "feed.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>

#include "swell/param.h"
#include "swell/pool.h"

void feed_init(struct view_feed *f, struct view_model *vm, uint8_t node)
{
	/* the controller's default body, 50 x 50 x 50 mm, until a CTL_INFO says otherwise */
	*f = (struct view_feed){ .vm = vm,
				 .node = node,
				 .obj_a_um = SWELL_POOL_BOX_UM,
				 .obj_b_um = SWELL_POOL_BOX_UM,
				 .obj_h_um = SWELL_POOL_BOX_UM };
}

/* The controller restarted, or the scene changed: the pose sequence and the charts start again. */
static void sequences_restart(struct view_feed *f)
{
	f->have_pose_seq = false;
	if (f->charts)
		charts_restart(f->charts);
}

static void on_scene(struct view_feed *f, const struct swell_msg_scene *s, uint64_t now_us)
{
	struct view_scene vs = {
		.nx = s->nx,
		.ny = s->ny,
		.dx_um = s->dx_um,
		.depth_um = (uint32_t)s->depth_10um * 10u,
		.tile_w = SWELL_PROTO_TILE,
		.tile_h = SWELL_PROTO_TILE,
		.scene_id = s->scene_id,
	};
	bool had = f->vm->have_scene;
	uint32_t restarts = f->vm->st.restarts;
	if (vm_scene(f->vm, &vs, now_us) != SWELL_OK) {
		vm_bad(f->vm);
		return;
	}
	if (!had || f->vm->st.restarts != restarts)
		sequences_restart(f);
}

static void on_quad(struct view_feed *f, const struct swell_msg_height_quad *q, uint32_t pos)
{
	struct view_model *m = f->vm;
	if (!m->have_scene) {
		m->st.ignored++;
		return;
	}
	if (q->tile_x >= m->tiles_x || q->tile_y >= m->tiles_y) {
		vm_bad(m); /* decodable, but not in this scene */
		return;
	}
	uint16_t i0, j0, w, h;
	vm_tile_rect(m, q->tile_x, q->tile_y, &i0, &j0, &w, &h);
	uint16_t col = (uint16_t)(q->half * 4u);
	if (q->row >= h || col >= w)
		return; /* padding beyond the grid's edge: nothing to show */
	uint16_t n = (uint16_t)(w - col < 4 ? w - col : 4);
	int32_t v[4];
	swell_height_quad_heights(q, v);
	vm_cells(m, q->tile_x, q->tile_y, col, q->row, n, pos, v);
}

static void on_heartbeat(struct view_feed *f, const struct swell_msg_heartbeat *hb, uint64_t now_us)
{
	/* Back in BOOT after any other state: the controller restarted. */
	if (f->have_state && hb->state == SWELL_CTL_BOOT && f->state != SWELL_CTL_BOOT) {
		vm_restart(f->vm, now_us);
		sequences_restart(f);
	}
	f->have_state = true;
	f->state = hb->state;
	char name[16];
	snprintf(name, sizeof(name), "%s", swell_state_name(hb->state));
	for (char *p = name; *p; p++)
		*p = (char)toupper((unsigned char)*p); /* the HUD shows state names in capitals */
	vm_heartbeat(f->vm, name, hb->err, hb->bad_frames, hb->overruns);
	if (f->have_hb) {
		uint8_t d = (uint8_t)(hb->seq - f->hb_seq);
		if (d < 128)
			f->hb_count += d;
		else
			f->have_hb = false; /* went back: a new sender; restart the clock */
	}
	if (!f->have_hb) {
		f->have_hb = true;
		f->hb_count = 0;
		f->vm->have_offset = f->vm->have_prev_best = false;
	}
	f->hb_seq = hb->seq;
	vm_clock(f->vm, f->hb_count * FEED_HEARTBEAT_US, f->rec_clock ? f->rec_us : now_us);
	if (f->charts && f->vm->st.latency_valid)
		charts_latency(f->charts, now_us, f->vm->st.latency_ms);
}

static void on_info(struct view_feed *f, const struct swell_msg_ctl_info *c)
{
	const uint8_t v[3] = { c->fw_major, c->fw_minor, c->fw_patch };

	f->obj_a_um = (uint32_t)c->obj_a_100um * 100u;
	f->obj_b_um = (uint32_t)c->obj_b_100um * 100u;
	f->obj_h_um = (uint32_t)c->obj_h_100um * 100u;
	f->obj_from_wire = true;
	vm_ctl_info(f->vm, v, f->obj_a_um, f->obj_b_um, f->obj_h_um);
}

static void on_msg(struct view_feed *f, const struct swell_msg *m, uint64_t now_us, bool can, uint32_t pos)
{
	struct view_model *vm = f->vm;

	switch (m->type) {
	case SWELL_MSG_SCENE:
		on_scene(f, &m->u.scene, now_us);
		break;
	case SWELL_MSG_HEIGHT_QUAD:
		on_quad(f, &m->u.height_quad, pos);
		break;
	case SWELL_MSG_HEARTBEAT:
		on_heartbeat(f, &m->u.heartbeat, now_us);
		break;
	case SWELL_MSG_CTL_INFO:
		on_info(f, &m->u.ctl_info);
		break;
	case SWELL_MSG_OBJECT_POSE: {
		const struct swell_msg_object_pose *p = &m->u.object_pose;
		if (f->have_pose_seq) {
			uint8_t d = (uint8_t)(p->seq - f->pose_seq);
			if ((d == 0 || d >= 128) && ++f->pose_stale < 8)
				break; /* a repeat or an older pose (reordered): keep the newer one */
			/* CAN has no packet sequence: count loss here, but not across a count that started
			 * again (taken after 8 stale poses: d is 0 or "behind" then) */
			if (can && d > 0 && d < 128)
				vm_gap(vm, d - 1u);
		}
		f->have_pose_seq = true;
		f->pose_seq = p->seq;
		f->pose_stale = 0; /* (after 8 "older" poses in a row the sender has restarted its count) */
		struct view_object o = vm->obj;
		o.valid = true;
		o.x_um = p->x_10um * 10;
		o.y_um = p->y_10um * 10;
		o.z_um = p->z_10um * 10;
		o.a_um = f->obj_a_um;
		o.b_um = f->obj_b_um;
		o.h_um = f->obj_h_um;
		f->submersion_halfpct = p->submersion_halfpct;
		if (vm_object(vm, &o) == SWELL_OK && f->charts)
			charts_pose(f->charts, now_us, p->seq, (float)o.z_um * 1e-3f,
				    charts_water_under(vm, o.x_um, o.y_um, o.a_um, o.b_um),
				    (float)p->submersion_halfpct * 0.5f);
		break;
	}
	case SWELL_MSG_OBJECT_FORCE: {
		const struct swell_msg_object_force *q = &m->u.object_force;
		if (!vm->obj.valid || q->seq != f->pose_seq)
			break; /* a force belongs to the pose of the same sequence number */
		struct view_object o = vm->obj;
		o.fx_cN = q->fx_cN;
		o.fy_cN = q->fy_cN;
		o.fz_cN = q->fz_cN;
		f->force_limits = q->limits;
		if (vm_object(vm, &o) == SWELL_OK && f->charts)
			charts_force(f->charts, now_us, q->seq, (float)q->fx_cN * 0.01f, (float)q->fy_cN * 0.01f,
				     (float)q->fz_cN * 0.01f, q->limits);
		break;
	}
	case SWELL_MSG_ENERGY:
		if (f->charts)
			charts_energy(f->charts, now_us, (float)m->u.energy.created_uJ * 1e-3f,
				      (float)m->u.energy.balance_10uJ * 1e-2f, m->u.energy.acting);
		break;
	default:
		break; /* device and parameter traffic: not the viewer's business */
	}
}

void feed_packet(struct view_feed *f, const uint8_t *pkt, size_t len, uint64_t now_us)
{
	struct swell_msg msgs[SWELL_PKT_MSGS_MAX];
	size_t n = 0;
	uint8_t seq = 0;

	if (swell_pkt_decode(pkt, len, msgs, SWELL_PKT_MSGS_MAX, &n, &seq, &f->st) != SWELL_OK) {
		vm_bad(f->vm);
		return;
	}
	if (f->node != FEED_NODE_ANY && n > 0 && msgs[0].node != f->node) {
		f->other_node++;
		return;
	}
	vm_frame(f->vm, seq, 8, now_us);
	/* Stream position: the packet sequence unwrapped. A packet a little behind the newest is a
	 * reordered one (its heights lose to newer ones already held); far behind, the sender started
	 * counting again. */
	int d = (uint8_t)(seq - f->last_seq);
	if (d >= 128)
		d -= 256; /* the distance modulo 256 taken in [-128, 127] */
	uint32_t pos;
	if (!f->have_seq || d > 0 || d < -32) {
		f->pos += f->have_seq ? (uint8_t)(seq - f->last_seq) : 1u;
		if (f->pos == 0)
			f->pos = 1;
		f->last_seq = seq;
		f->have_seq = true;
		pos = f->pos;
	} else {
		pos = f->pos + (uint32_t)d; /* d <= 0 */
		if (pos == 0)
			pos = 1;
	}
	for (size_t k = 0; k < n; k++)
		on_msg(f, &msgs[k], now_us, false, pos);
}

void feed_can(struct view_feed *f, uint32_t id, const uint8_t *data, size_t len, bool fd, uint64_t now_us)
{
	struct swell_msg msgs[SWELL_CANFD_MSGS_MAX];
	size_t n = 0;
	enum swell_err err;

	if (!fd) {
		err = swell_can_decode(id, data, len, &msgs[0], &f->st);
		n = 1;
	} else {
		err = swell_canfd_decode(id, data, len, msgs, SWELL_CANFD_MSGS_MAX, &n, &f->st);
	}
	if (err != SWELL_OK) {
		vm_bad(f->vm);
		return;
	}
	if (f->node != FEED_NODE_ANY && n > 0 && msgs[0].node != f->node) {
		f->other_node++;
		return;
	}
	vm_rx(f->vm, now_us);
	if (++f->pos == 0)
		f->pos = 1; /* CAN: arrival order is the stream order */
	for (size_t k = 0; k < n; k++)
		on_msg(f, &msgs[k], now_us, true, f->pos);
}
