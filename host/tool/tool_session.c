/* swell-tool: the conversation with a controller; see tool_session.h. */
#define _GNU_SOURCE
#include "tool_session.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/link.h"
#include "swell/param.h"

#define RESEND_MS 250

static uint64_t ms_ns(int ms)
{
	return (uint64_t)(ms > 0 ? ms : 0) * 1000000u;
}

int tool_object_wet(const struct tool_session *s)
{
	return s->t.have_pose && s->t.pose.submersion_halfpct > 0;
}

double tool_elapsed_s(const struct tool_session *s)
{
	return (double)(swell_link_now_ns() - s->t0_ns) / 1e9;
}

static void take_quad(struct tool_telemetry *t, const struct swell_msg_height_quad *q)
{
	const unsigned y = q->tile_y * SWELL_PROTO_TILE + q->row, x0 = q->tile_x * SWELL_PROTO_TILE + q->half * 4u;
	const int16_t h[4] = { q->h0, q->h1, q->h2, q->h3 };
	unsigned k;

	for (k = 0; k < 4; k++) {
		const unsigned a = y * TOOL_GRID_MAX + x0 + k;

		t->grid[a] = h[k];
		t->seen[a] = 1;
	}
}

static void take(struct tool_session *s, const struct swell_msg *m, uint64_t now)
{
	struct tool_telemetry *t = &s->t;

	switch (m->type) {
	case SWELL_MSG_HEARTBEAT:
		t->hb = m->u.heartbeat;
		t->have_hb = 1;
		t->hb_ns = now;
		break;
	case SWELL_MSG_SCENE:
		if (t->have_scene && t->scene.scene_id != m->u.scene.scene_id)
			memset(t->seen, 0, sizeof(t->seen)); /* a new pool: the old heights mean nothing */
		t->scene = m->u.scene;
		t->have_scene = 1;
		break;
	case SWELL_MSG_CTL_INFO:
		t->info = m->u.ctl_info;
		t->have_info = 1;
		break;
	case SWELL_MSG_OBJECT_POSE:
		t->pose = m->u.object_pose;
		t->have_pose = 1;
		t->pose_ns = now;
		break;
	case SWELL_MSG_OBJECT_FORCE:
		t->force = m->u.object_force;
		t->have_force = 1;
		t->force_ns = now;
		break;
	case SWELL_MSG_ENERGY:
		t->energy = m->u.energy;
		t->have_energy = 1;
		break;
	case SWELL_MSG_HEIGHT_QUAD:
		take_quad(t, &m->u.height_quad);
		break;
	default:
		break;
	}
}

/* One frame: decode, take in what is our node's, note other nodes. Returns messages taken. */
static int take_frame(struct tool_session *s, const struct swell_frame *f)
{
	struct swell_msg m[SWELL_CANFD_MSGS_MAX];
	size_t n = 0, k;
	int ours = 0;

	if (swell_link_decode(swell_link_carrier(s->l), f, m, SWELL_CANFD_MSGS_MAX, &n, NULL, &s->st) != SWELL_OK)
		return 0;
	for (k = 0; k < n; k++) {
		const int from_ctl = m[k].type != SWELL_MSG_PARAM_SET && m[k].type != SWELL_MSG_PARAM_GET &&
			m[k].type != SWELL_MSG_ENTER_BOOTLOADER && m[k].type != SWELL_MSG_FORCE_CMD &&
			m[k].type != SWELL_MSG_DEVICE_POS && m[k].type != SWELL_MSG_DEVICE_VEL &&
			m[k].type != SWELL_MSG_DEVICE_FORCE;

		if (!from_ctl)
			continue; /* another host's requests, or device traffic on a shared bus */
		if (s->node < 0 && m[k].type == SWELL_MSG_HEARTBEAT &&
		    (s->spec.node < 0 || s->spec.node == m[k].node)) {
			if (s->spec.node < 0 && s->other >= 0 && s->other != m[k].node)
				continue; /* two controllers and none chosen: tool_open refuses */
			s->node = m[k].node;
		}
		if (s->node >= 0 && m[k].node == s->node) {
			take(s, &m[k], f->t_ns ? f->t_ns : swell_link_now_ns());
			if (s->on_msg)
				s->on_msg(s, &m[k], s->user);
			ours++;
		} else if (s->spec.node < 0 || m[k].node != s->spec.node) {
			s->other = m[k].node; /* not ours, not the node asked for */
		}
	}
	if (ours) {
		s->t.frames++;
		s->t.bytes += f->len;
		s->t.msgs += (uint64_t)ours;
		if (swell_link_carrier(s->l) == SWELL_CARRIER_CAN)
			s->t.can_bits += swell_can_bits(f->len);
	}
	return ours;
}

int tool_pump(struct tool_session *s, int ms)
{
	const uint64_t until = swell_link_now_ns() + ms_ns(ms);
	int taken = 0;

	for (;;) {
		struct swell_frame f;
		uint64_t now = swell_link_now_ns();
		int left = now >= until ? 0 : (int)((until - now + 999999u) / 1000000u);
		/* UDP: a HEARTBEAT to the controller when one is due, so that it keeps this client: the node
		 * found, else every node (a controller of another node than the one asked for is heard, and
		 * named); due: the ms until the next, -1 on other carriers */
		const int due = swell_client_keepalive(s->l, s->node, &s->keep_ns);
		int rc = swell_link_recv(s->l, &f, due >= 0 && due < left ? due : left);

		if (rc == 0) {
			taken += take_frame(s, &f);
			continue;
		}
		if (left == 0 || rc != -ETIMEDOUT) {
			if (rc != -ETIMEDOUT && left > 0) { /* a USB device gone: wait out the time, do not spin */
				nanosleep(&(struct timespec){ 0, 10000000 }, NULL);
				continue;
			}
			return taken;
		}
	}
}

enum tool_rc tool_open(struct tool_session *s, const struct swell_client_spec *spec, int timeout_ms, char *err,
		       size_t errlen)
{
	uint64_t until, found_ns = 0;
	int rc;

	memset(s, 0, sizeof(*s));
	s->spec = *spec;
	s->node = -1;
	s->other = -1;
	s->silent_ms = timeout_ms > TOOL_SILENT_MS ? timeout_ms : TOOL_SILENT_MS;
	s->t0_ns = swell_link_now_ns();
	swell_link_spec_describe(&spec->link, s->name, sizeof(s->name));
	rc = swell_client_open(spec, timeout_ms, &s->l);
	if (rc < 0) {
		snprintf(err, errlen, "cannot open %s: %s", s->name, strerror(-rc));
		return TOOL_FAIL;
	}
	/* With no node given, listen 150 ms past the first heartbeat: long enough to hear a second
	 * controller on a shared bus (they beat at 10 Hz, both beats in 150 ms), short for a prompt answer. */
	until = swell_link_now_ns() + ms_ns(timeout_ms);
	while (swell_link_now_ns() < until) {
		tool_pump(s, 20);
		if (s->node >= 0 && s->spec.node < 0 && s->other >= 0 && s->other != s->node) {
			snprintf(err, errlen, "several controllers on %s (nodes %d and %d): choose one with --node",
				 s->name, s->node, s->other);
			return TOOL_WRONG_NODE;
		}
		if (s->node >= 0 && !found_ns)
			found_ns = swell_link_now_ns();
		if (s->node >= 0 && (s->spec.node >= 0 || swell_link_now_ns() - found_ns > ms_ns(150)))
			return TOOL_OK;
	}
	if (s->node >= 0)
		return TOOL_OK;
	if (s->other >= 0 && s->spec.node >= 0) {
		snprintf(err, errlen, "no controller node %d on %s within %d ms (node %d is there)", s->spec.node,
			 s->name, timeout_ms, s->other);
		return TOOL_WRONG_NODE;
	}
	snprintf(err, errlen,
		 "no controller heard on %s within %d ms (is swell-ctl running with its host link there%s?)", s->name,
		 timeout_ms, swell_link_udp_port(s->l) ? ", and one of its 4 client slots free" : "");
	return TOOL_NO_CTL;
}

void tool_close(struct tool_session *s)
{
	if (s->l)
		swell_link_close(s->l);
	s->l = NULL;
}

enum tool_rc tool_wait_full(struct tool_session *s, int timeout_ms)
{
	const uint64_t until = swell_link_now_ns() + ms_ns(timeout_ms);

	while (!(s->t.have_hb && s->t.have_scene && s->t.have_info)) {
		if (swell_link_now_ns() >= until)
			return TOOL_TIMEOUT;
		tool_pump(s, 20);
	}
	return TOOL_OK;
}

int tool_silent(const struct tool_session *s)
{
	return !s->t.have_hb || swell_link_now_ns() - s->t.hb_ns > ms_ns(s->silent_ms);
}

static int send_msg(struct tool_session *s, const struct swell_msg *m)
{
	struct swell_frame f;
	size_t used = 0;

	if (swell_link_encode(swell_link_carrier(s->l), m->node, s->pkt_seq++, m, 1, &f, &used) != SWELL_OK)
		return -EINVAL;
	return swell_link_send(s->l, &f);
}

/* Wait up to ms for the answer to (id, seq): 1 ACK, 0 NACK, -1 none yet. */
static int wait_answer(struct tool_session *s, uint16_t id, uint8_t seq, int ms, int32_t *value, enum swell_err *why)
{
	const uint64_t until = swell_link_now_ns() + ms_ns(ms);

	while (swell_link_now_ns() < until) {
		struct swell_frame f;
		struct swell_msg m[SWELL_CANFD_MSGS_MAX];
		size_t n = 0, k;

		swell_client_keepalive(s->l, s->node, &s->keep_ns);
		if (swell_link_recv(s->l, &f, 10) != 0)
			continue;
		take_frame(s, &f);
		if (swell_link_decode(swell_link_carrier(s->l), &f, m, SWELL_CANFD_MSGS_MAX, &n, NULL, NULL) !=
		    SWELL_OK)
			continue;
		for (k = 0; k < n; k++) {
			if ((int)m[k].node != s->node)
				continue;
			const int answer = swell_param_answer(&m[k], id, seq, value, why);

			if (answer >= 0)
				return answer;
		}
	}
	return -1;
}

enum tool_rc tool_request(struct tool_session *s, int set, uint16_t id, int32_t value, int timeout_ms, int32_t *answer,
			  enum swell_err *why, char *err, size_t errlen)
{
	const uint64_t until = swell_link_now_ns() + ms_ns(timeout_ms);
	const uint8_t seq = ++s->seq;
	const struct swell_msg m = swell_param_request((uint8_t)s->node, set, id, value, seq);

	/* The same request again for a lost frame: a set is idempotent and the answer names its seq. */
	while (swell_link_now_ns() < until) {
		uint64_t left = (until - swell_link_now_ns()) / 1000000u;
		int r, rc = send_msg(s, &m);

		if (rc < 0 && rc != -ENODEV) {
			snprintf(err, errlen, "send on %s: %s", s->name, strerror(-rc));
			return TOOL_FAIL;
		}
		r = wait_answer(s, id, seq, left < RESEND_MS ? (int)left : RESEND_MS, answer, why);
		if (r == 1)
			return TOOL_OK;
		if (r == 0)
			return TOOL_REFUSED;
	}
	if (tool_silent(s))
		snprintf(err, errlen,
			 "the controller (node %d on %s) went silent: no heartbeat for %.1f s and no answer", s->node,
			 s->name, (double)(swell_link_now_ns() - s->t.hb_ns) / 1e9);
	else
		snprintf(err, errlen, "no answer from node %d on %s within %d ms (its heartbeat goes on)", s->node,
			 s->name, timeout_ms);
	return TOOL_TIMEOUT;
}

enum tool_rc tool_get(struct tool_session *s, const struct swell_param_desc *d, int timeout_ms, int32_t *v,
		      const char *what)
{
	enum swell_err why = SWELL_OK;
	char err[200];
	enum tool_rc rc = tool_request(s, 0, d->id, 0, timeout_ms, v, &why, err, sizeof(err));

	if (rc == TOOL_REFUSED)
		fprintf(stderr, "swell-tool: %s%sget %s refused: %s\n", what ? what : "", what ? ": " : "", d->name,
			swell_err_str(why));
	else if (rc != TOOL_OK)
		fprintf(stderr, "swell-tool: %s%sget %s: %s\n", what ? what : "", what ? ": " : "", d->name, err);
	return rc;
}

/* The cells under the object's footprint, [i0, i1] x [j0, j1]; 0 when pose, scene or size is unknown. */
static int footprint(const struct tool_telemetry *t, long *i0, long *i1, long *j0, long *j1)
{
	double dx_mm, x, y, a, b;

	if (!t->have_scene || !t->have_pose || !t->have_info)
		return 0;
	dx_mm = t->scene.dx_um / 1000.0;
	x = t->pose.x_10um / 100.0;
	y = t->pose.y_10um / 100.0;
	a = t->info.obj_a_100um / 10.0;
	b = t->info.obj_b_100um / 10.0;
	*i0 = (long)floor((x - a / 2) / dx_mm);
	*i1 = (long)floor((x + a / 2) / dx_mm);
	*j0 = (long)floor((y - b / 2) / dx_mm);
	*j1 = (long)floor((y + b / 2) / dx_mm);
	return 1;
}

double tool_water_under_mm(const struct tool_session *s)
{
	const struct tool_telemetry *t = &s->t;
	long i0, i1, j0, j1, i, j, n = 0;
	double sum = 0;

	if (!footprint(t, &i0, &i1, &j0, &j1))
		return 0;
	for (j = j0 < 0 ? 0 : j0; j <= j1 && j < t->scene.ny; j++)
		for (i = i0 < 0 ? 0 : i0; i <= i1 && i < t->scene.nx; i++)
			if (t->seen[j * TOOL_GRID_MAX + i]) {
				sum += swell_sample_to_height(t->grid[j * TOOL_GRID_MAX + i]);
				n++;
			}
	return n ? sum / (double)n / 65536.0 : 0; /* solver units, 2^-16 mm */
}

double tool_wave_max_mm(const struct tool_session *s)
{
	const struct tool_telemetry *t = &s->t;
	long i0 = -1, i1 = -2, j0 = -1, j1 = -2, i, j;
	int worst = 0;

	if (!t->have_scene)
		return 0;
	footprint(t, &i0, &i1, &j0, &j1); /* the water the object pushes away is not a wave */
	for (j = 0; j < t->scene.ny; j++)
		for (i = 0; i < t->scene.nx; i++) {
			const long a = j * TOOL_GRID_MAX + i;
			const int h = abs(t->grid[a]);

			if (t->seen[a] && h > worst && !(i >= i0 && i <= i1 && j >= j0 && j <= j1))
				worst = h;
		}
	return swell_sample_to_height((int16_t)worst) / 65536.0; /* solver units, 2^-16 mm */
}
