/* swell-flash: enter-bootloader over the UDP host link; see flash_boot.h. */
#include "flash_boot.h"

#include <stdarg.h>
#include <stdio.h>

#include "swell/ctl.h"
#include "swell/link.h"

static const char *const state_names[] = {"BOOT", "IDLE", "ARMED", "RUNNING", "FAULT"};

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

/* Wait until `end` (swell_link_now_ns) for the next packet that decodes; 0 with its *n messages in
 * m[SWELL_PKT_MSGS_MAX], -1 at the time limit. */
static int next_packet(struct swell_link *l, uint64_t end, struct swell_msg *m, size_t *n)
{
	for (;;) {
		struct swell_frame f;
		uint64_t now = swell_link_now_ns();

		if (now >= end)
			return -1;
		if (swell_link_recv(l, &f, (int)((end - now) / 1000000u) + 1) != 0)
			continue;
		if (swell_link_decode(SWELL_CARRIER_PKT, &f, m, SWELL_PKT_MSGS_MAX, n, NULL, NULL) == SWELL_OK)
			return 0;
	}
}

/* Wait up to ms for the next heartbeat; 0 got one, -1 none. */
static int next_heartbeat(struct swell_link *l, int ms, struct swell_msg *hb)
{
	uint64_t end = swell_link_now_ns() + (uint64_t)ms * 1000000u;
	struct swell_msg m[SWELL_PKT_MSGS_MAX];
	size_t n, i;

	while (next_packet(l, end, m, &n) == 0)
		for (i = 0; i < n; i++)
			if (m[i].type == SWELL_MSG_HEARTBEAT) {
				*hb = m[i];
				return 0;
			}
	return -1;
}

static int send_one(struct swell_link *l, const struct swell_msg *m, uint8_t seq)
{
	struct swell_frame f;
	size_t used;

	if (swell_link_encode(SWELL_CARRIER_PKT, m->node, seq, m, 1, &f, &used) != SWELL_OK || used != 1)
		return -1;
	return swell_link_send(l, &f);
}

enum flash_boot_result flash_enter_bootloader(uint16_t port, int force, int watch_ms, char *msg,
					      size_t msg_len)
{
	struct swell_link *l;
	struct swell_msg hb, m = {0};
	enum flash_boot_result r;
	unsigned beats = 0;
	uint64_t t_sent;
	int rc;

	rc = swell_link_open_udp(&l, "127.0.0.1", port, NULL, 0);
	if (rc)
		return say(BOOT_ERROR, msg, msg_len, "cannot listen on udp 127.0.0.1:%u (a viewer there?): error %d",
			   (unsigned)port, rc);
	if (next_heartbeat(l, 1500, &hb)) {
		r = say(BOOT_NOT_FOUND, msg, msg_len, "no controller heartbeat on udp 127.0.0.1:%u within 1.5 s",
			(unsigned)port);
		goto out;
	}
	printf("swell-flash: controller node %u on udp:%u: state %s, protocol version %u\n",
	       (unsigned)hb.node, (unsigned)port, state_name(hb.u.heartbeat.state),
	       (unsigned)hb.u.heartbeat.version);
	if (hb.u.heartbeat.state == SWELL_CTL_RUNNING) {
		if (!force) {
			r = say(BOOT_REFUSED_RUNNING, msg, msg_len,
				"controller is RUNNING (the object may be held in the water): stop it, or --force to "
				"stop it first; nothing sent");
			goto out;
		}
		m.type = SWELL_MSG_PARAM_SET;
		m.node = hb.node;
		m.u.param_set.id = SWELL_PARAM_COMMAND;
		m.u.param_set.value = SWELL_CMD_STOP;
		m.u.param_set.seq = 1;
		printf("swell-flash: --force: sending COMMAND=STOP (force zeroed by the controller)\n");
		if (send_one(l, &m, 1)) {
			r = say(BOOT_ERROR, msg, msg_len, "cannot send PARAM_SET COMMAND=STOP");
			goto out;
		}
		for (;;) {
			if (next_heartbeat(l, 1500, &hb)) {
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
	m.type = SWELL_MSG_ENTER_BOOTLOADER;
	m.node = hb.node;
	m.u.enter_bootloader.key = SWELL_PROTO_BOOT_KEY;
	if (send_one(l, &m, 2)) {
		r = say(BOOT_ERROR, msg, msg_len, "cannot send ENTER_BOOTLOADER");
		goto out;
	}
	t_sent = swell_link_now_ns();
	printf("swell-flash: ENTER_BOOTLOADER sent (key 0x%08x); watching the heartbeat for %d ms\n",
	       SWELL_PROTO_BOOT_KEY, watch_ms);
	/* A heartbeat already on its way may still come; count those later than 200 ms. */
	beats = 0;
	while (swell_link_now_ns() - t_sent < (uint64_t)watch_ms * 1000000u) {
		if (next_heartbeat(l, 100, &hb) == 0 && swell_link_now_ns() - t_sent > 200000000u)
			beats++;
	}
	if (beats)
		r = say(BOOT_STILL_RUNNING, msg, msg_len,
			"controller still sends heartbeats (%u in %d ms after the request, state %s): no bootloader "
			"entered (a controller that ignores the request, or firmware without it)",
			beats, watch_ms, state_name(hb.u.heartbeat.state));
	else
		r = say(BOOT_ENTERED, msg, msg_len, "controller silent after ENTER_BOOTLOADER: it reboots into its bootloader");
out:
	swell_link_close(l);
	return r;
}

int flash_find_controller(uint16_t port, int timeout_ms, struct flash_found *out, char *msg, size_t msg_len)
{
	struct swell_link *l;
	uint64_t t0 = swell_link_now_ns(), end = t0 + (uint64_t)timeout_ms * 1000000u;
	struct swell_msg m[SWELL_PKT_MSGS_MAX];
	unsigned beats = 0, others = 0;
	size_t n, i;
	int rc;

	rc = swell_link_open_udp(&l, "127.0.0.1", port, NULL, 0);
	if (rc) {
		say(BOOT_ERROR, msg, msg_len, "cannot listen on udp 127.0.0.1:%u (a viewer there?): error %d",
		    (unsigned)port, rc);
		return -2;
	}
	while (next_packet(l, end, m, &n) == 0) {
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
			out->after_s = (double)(swell_link_now_ns() - t0) / 1e9;
			swell_link_close(l);
			return 0;
		}
	}
	swell_link_close(l);
	if (beats)
		say(BOOT_NOT_FOUND, msg, msg_len,
		    "%u heartbeats but no CTL_INFO on udp 127.0.0.1:%u within %.1f s: firmware older than "
		    "CTL_INFO (it cannot say its version)",
		    beats, (unsigned)port, timeout_ms / 1e3);
	else
		say(BOOT_NOT_FOUND, msg, msg_len, "controller not heard on udp 127.0.0.1:%u within %.1f s%s",
		    (unsigned)port, timeout_ms / 1e3, others ? " (other traffic only)" : "");
	return -1;
}
