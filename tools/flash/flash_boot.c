/* swell-flash: enter-bootloader and find over a host link; see flash_boot.h. */
#define _GNU_SOURCE
#include "flash_boot.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "swell/param_table.h"
#include "swell/proto.h"
#include "swell/link.h"

static const char *const state_names[] = { "BOOT", "IDLE", "ARMED", "RUNNING", "FAULT" };

static const char *state_name(unsigned s)
{
	return s < 5 ? state_names[s] : "?";
}

static enum flash_boot_result say(enum flash_boot_result r, char *msg, size_t len, const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(msg, len, fmt, ap);
	va_end(ap);
	return r;
}

static double secs(uint64_t ns)
{
	return (double)ns / 1e9;
}

/* One listening session on a link of any carrier. */
struct session {
	struct swell_link *l;
	enum swell_carrier carrier;
	int node; /* -1 any */
	uint8_t seq; /* packet sequence (packets only) */
	uint64_t gone_ns; /* first time the link said the device left (0: never) */
	unsigned others; /* valid messages of nodes other than the chosen one */
	uint64_t keep_ns; /* UDP: when the next keep-alive to the controller is due */
	int heard; /* the node of the last messages taken (-1: none yet): whom the keep-alives are for */
};

/* Wait until `end` (swell_link_now_ns) for the next frame that decodes to messages of the chosen
 * node; 0 with its *n messages in m[SWELL_PKT_MSGS_MAX], -1 at the time limit. */
static int next_frame(struct session *s, uint64_t end, struct swell_msg *m, size_t *n)
{
	for (;;) {
		struct swell_frame f;
		uint64_t now = swell_link_now_ns();
		size_t i, kept = 0;
		int rc, wait_ms, due;

		if (now >= end)
			return -1;
		wait_ms = (int)((end - now) / 1000000u) + 1;
		due = swell_client_keepalive(s->l, s->heard, &s->keep_ns); /* UDP: stay a client */
		rc = swell_link_recv(s->l, &f, due >= 0 && due < wait_ms ? due : wait_ms);
		if (rc == -ENODEV && !s->gone_ns)
			s->gone_ns = swell_link_now_ns();
		if (rc != 0 && rc != -ETIMEDOUT) { /* a broken link must not spin */
			struct timespec d = { 0, 10000000 };
			nanosleep(&d, NULL);
		}
		if (rc != 0)
			continue;
		if (swell_link_decode(s->carrier, &f, m, SWELL_PKT_MSGS_MAX, n, NULL, NULL) != SWELL_OK)
			continue;
		for (i = 0; i < *n; i++) {
			if (s->node >= 0 && m[i].node != s->node)
				s->others++;
			else
				m[kept++] = m[i];
		}
		*n = kept;
		if (kept) {
			s->heard = m[0].node;
			return 0;
		}
	}
}

/* Wait up to ms for the next heartbeat of node (-1: any); 0 got one, -1 none. Heartbeats of other
 * nodes set the bits of *seen (may be NULL). */
static int next_heartbeat(struct session *s, int ms, struct swell_msg *hb, uint32_t *seen)
{
	uint64_t end = swell_link_now_ns() + (uint64_t)ms * 1000000u;
	struct swell_msg m[SWELL_PKT_MSGS_MAX];
	size_t n, i;

	while (next_frame(s, end, m, &n) == 0)
		for (i = 0; i < n; i++) {
			if (m[i].type != SWELL_MSG_HEARTBEAT)
				continue;
			if (seen && m[i].node < 32)
				*seen |= 1u << m[i].node;
			*hb = m[i];
			return 0;
		}
	return -1;
}

/* Send m[0..n) in as few frames as the carrier takes (a packet: all of them; classic CAN: one each).
 * 0, 1 (not encodable) or a negative errno. */
static int send_msgs(struct session *s, const struct swell_msg *m, size_t n)
{
	size_t k = 0;

	while (k < n) {
		struct swell_frame f;
		size_t used = 0;
		int rc;

		if (swell_link_encode(s->carrier, m[k].node, s->seq++, m + k, n - k, &f, &used) != SWELL_OK ||
		    used == 0)
			return 1;
		rc = swell_link_send(s->l, &f);
		if (rc)
			return rc;
		k += used;
	}
	return 0;
}

static int open_session(struct session *s, const struct swell_client_spec *spec, int wait_ms, char *where, size_t wlen)
{
	int rc;

	memset(s, 0, sizeof(*s));
	s->node = spec->node;
	s->heard = -1;
	swell_link_spec_describe(&spec->link, where, wlen);
	rc = swell_client_open(spec, wait_ms, &s->l);
	if (rc == 0)
		s->carrier = swell_link_carrier(s->l);
	return rc;
}

static void names_of(uint32_t seen, char *buf, size_t len)
{
	size_t used = 0;
	unsigned k;

	buf[0] = '\0';
	for (k = 0; k < 32 && used < len; k++)
		if (seen & (1u << k))
			used += (size_t)snprintf(buf + used, len - used, "%s%u", used ? ", " : "", k);
}

/* The controller to talk to: its first heartbeat, then its second (a full heartbeat period: any
 * other controller on the bus is heard meanwhile, and a packet queued before we listened is not
 * taken for its state). */
static enum flash_boot_result find_target(struct session *s, const char *where, struct swell_msg *hb, char *msg,
					  size_t msg_len)
{
	uint32_t seen = 0;
	uint64_t end;
	char nodes[96];

	if (next_heartbeat(s, 1500, hb, &seen)) {
		if (s->node >= 0)
			return say(BOOT_NOT_FOUND, msg, msg_len,
				   "no heartbeat of controller node %d on %s within 1.5 s%s", s->node, where,
				   s->others ? " (other nodes heard)" : "");
		return say(BOOT_NOT_FOUND, msg, msg_len, "no controller heartbeat on %s within 1.5 s", where);
	}
	end = swell_link_now_ns() + 1500000000u;
	for (;;) {
		struct swell_msg h;
		uint64_t now = swell_link_now_ns();

		if (now >= end || next_heartbeat(s, (int)((end - now) / 1000000u) + 1, &h, &seen))
			return say(BOOT_NOT_FOUND, msg, msg_len,
				   "controller node %u on %s heard once, then silent for 1.5 s", (unsigned)hb->node,
				   where);
		if (h.node == hb->node) {
			*hb = h;
			break;
		}
	}
	s->node = hb->node; /* from now on only this controller's messages */
	if (seen & ~(1u << hb->node)) {
		names_of(seen, nodes, sizeof(nodes));
		return say(BOOT_REFUSED_NODES, msg, msg_len,
			   "several controllers on %s (nodes %s): choose one with --node; nothing sent", where, nodes);
	}
	return BOOT_ENTERED;
}

enum flash_boot_result flash_enter_bootloader(const struct swell_client_spec *spec, int force, int watch_ms,
					      struct flash_boot_times *times, char *msg, size_t msg_len)
{
	struct session s;
	struct swell_msg hb = { 0 }, m, stop[2]; /* hb: zeroed for the analyzer, find_target fills it */
	enum flash_boot_result r;
	char where[96];
	unsigned beats = 0;
	uint64_t t_sent, t_last = 0;
	int rc;

	if (times)
		times->last_beat_s = times->dev_gone_s = -1;
	rc = open_session(&s, spec, 1500, where, sizeof(where));
	if (rc)
		return say(BOOT_ERROR, msg, msg_len, "cannot open %s: %s", where, strerror(-rc));
	r = find_target(&s, where, &hb, msg, msg_len);
	if (r != BOOT_ENTERED)
		goto out;
	printf("swell-flash: controller node %u on %s: state %s, protocol version %u\n", (unsigned)hb.node, where,
	       state_name(hb.u.heartbeat.state), (unsigned)hb.u.heartbeat.version);
	if (hb.u.heartbeat.state == SWELL_CTL_RUNNING) {
		if (!force) {
			r = say(BOOT_REFUSED_RUNNING, msg, msg_len,
				"controller is RUNNING (the object may be held in the water): stop it, or --force to "
				"stop it first; nothing sent");
			goto out;
		}
		/* AUTORUN=0 too: in older controllers autorun overrode STOP */
		printf("swell-flash: --force: sending AUTORUN=0 and COMMAND=STOP (force zeroed by the controller)\n");
		/* one packet on USB and UDP: swell-ctl's FunctionFS side may take a second OUT packet late
		 * while nobody reads its IN endpoint (this process, blocked sending) */
		stop[0] = swell_param_request(hb.node, 1, SWELL_PARAM_AUTORUN, 0, 1);
		stop[1] = swell_param_request(hb.node, 1, SWELL_PARAM_COMMAND, SWELL_CMD_STOP, 2);
		rc = send_msgs(&s, stop, 2);
		if (rc) {
			r = say(BOOT_ERROR, msg, msg_len, "cannot send PARAM_SET AUTORUN=0, COMMAND=STOP on %s: %s",
				where, rc > 0 ? "not encodable" : strerror(-rc));
			goto out;
		}
		for (;;) {
			if (next_heartbeat(&s, 1500, &hb, NULL)) {
				r = say(BOOT_ERROR, msg, msg_len, "controller silent after COMMAND=STOP");
				goto out;
			}
			if (hb.u.heartbeat.state != SWELL_CTL_RUNNING)
				break;
			if (++beats > 15) {
				r = say(BOOT_ERROR, msg, msg_len, "controller still RUNNING after COMMAND=STOP");
				goto out;
			}
		}
		printf("swell-flash: controller now %s\n", state_name(hb.u.heartbeat.state));
	}
	memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_ENTER_BOOTLOADER;
	m.node = hb.node;
	m.u.enter_bootloader.key = SWELL_PROTO_BOOT_KEY;
	s.gone_ns = 0;
	rc = send_msgs(&s, &m, 1);
	if (rc) {
		r = say(BOOT_ERROR, msg, msg_len, "cannot send ENTER_BOOTLOADER on %s: %s", where,
			rc > 0 ? "not encodable" : strerror(-rc));
		goto out;
	}
	t_sent = swell_link_now_ns();
	printf("swell-flash: ENTER_BOOTLOADER sent (key 0x%08x) on %s; watching the heartbeat for %d ms\n",
	       SWELL_PROTO_BOOT_KEY, where, watch_ms);
	/* A heartbeat already on its way may still come (the controller's last one is sent on purpose);
	 * count those later than 200 ms. */
	beats = 0;
	while (swell_link_now_ns() - t_sent < (uint64_t)watch_ms * 1000000u) {
		if (next_heartbeat(&s, 100, &hb, NULL) == 0) {
			t_last = swell_link_now_ns();
			beats += t_last - t_sent > 200000000u;
		}
	}
	if (times) {
		times->last_beat_s = t_last ? secs(t_last - t_sent) : -1;
		times->dev_gone_s = s.gone_ns > t_sent ? secs(s.gone_ns - t_sent) : -1;
	}
	if (beats)
		r = say(BOOT_STILL_RUNNING, msg, msg_len,
			"controller still sends heartbeats (%u in %d ms after the request, state %s): no bootloader "
			"entered (a controller that ignores the request, or firmware without it)",
			beats, watch_ms, state_name(hb.u.heartbeat.state));
	else
		r = say(BOOT_ENTERED, msg, msg_len,
			"controller silent after ENTER_BOOTLOADER: it reboots into its bootloader");
out:
	swell_link_close(s.l);
	return r;
}

int flash_find_controller(const struct swell_client_spec *spec, int timeout_ms, struct flash_found *out, char *msg,
			  size_t msg_len)
{
	struct session s;
	uint64_t t0 = swell_link_now_ns(), end = t0 + (uint64_t)timeout_ms * 1000000u;
	struct swell_msg m[SWELL_PKT_MSGS_MAX];
	unsigned beats = 0, others = 0;
	char where[96];
	size_t n, i;
	int rc;

	rc = open_session(&s, spec, timeout_ms, where, sizeof(where));
	if (rc) {
		say(BOOT_ERROR, msg, msg_len, "cannot open %s: %s", where,
		    rc == -ENODEV && spec->link.kind == SWELL_LINK_USB ? "no such device within the time limit"
								       : strerror(-rc));
		return rc == -ENODEV && spec->link.kind == SWELL_LINK_USB ? -1 : -2;
	}
	while (next_frame(&s, end, m, &n) == 0) {
		for (i = 0; i < n; i++) {
			const struct swell_msg_ctl_info *c = &m[i].u.ctl_info;

			if (m[i].type == SWELL_MSG_HEARTBEAT) {
				beats++;
				continue;
			}
			if (m[i].type != SWELL_MSG_CTL_INFO) {
				others++;
				continue;
			}
			out->node = m[i].node;
			out->version[0] = c->fw_major;
			out->version[1] = c->fw_minor;
			out->version[2] = c->fw_patch;
			out->obj_100um[0] = c->obj_a_100um;
			out->obj_100um[1] = c->obj_b_100um;
			out->obj_100um[2] = c->obj_h_100um;
			out->mono_s = secs(swell_link_now_ns());
			out->after_s = secs(swell_link_now_ns() - t0);
			swell_link_close(s.l);
			return 0;
		}
	}
	swell_link_close(s.l);
	if (beats)
		say(BOOT_NOT_FOUND, msg, msg_len,
		    "%u heartbeats but no CTL_INFO on %s within %.1f s: firmware older than CTL_INFO (it cannot say "
		    "its version)",
		    beats, where, timeout_ms / 1e3);
	else
		say(BOOT_NOT_FOUND, msg, msg_len, "controller%s not heard on %s within %.1f s%s",
		    spec->node >= 0 ? " (the node asked for)" : "", where, timeout_ms / 1e3,
		    s.others         ? " (other nodes heard)"
			    : others ? " (other traffic only)"
				     : "");
	return -1;
}
