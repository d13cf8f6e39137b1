#define _GNU_SOURCE
#include "ctl_link.h"

#include <arpa/inet.h>
#include <errno.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* hm: an answer to a request sent more than this many ticks ago is stale: a silent device tick */
#define CTL_HM_MAX_AGE_TICKS 2

/* The socket layer leaves nothing open when it refuses (rc, a negative errno): the reason is said. */
static int refused(char *err, size_t len, const char *what, const char *spec, int rc)
{
	snprintf(err, len, "%s %s: %s", what, spec, strerror(-rc));
	return -1;
}

static int open_udp(struct ctl_link *l, const char *spec, const struct swell_link_spec *ls, int device_side, char *err,
		    size_t errlen)
{
	const int have_opt = device_side ? ls->have_peer : ls->have_listen;
	struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) }, viewer = a;

	viewer.sin_port = htons(ls->port);
	a.sin_port = htons((uint16_t)(device_side ? ls->port : SWELL_UDP_PORT_CLIENTS));
	if (!device_side && have_opt)
		a = ls->listen_at; /* the clients' port (and address, when spelled out) */
	/* the default clients' port is another controller's: this one takes any free port (said at
	 * start); a port spelled out is never swapped for another */
	const int fd = swell_udp_socket(&a, 1, !device_side && !have_opt, &l->clients_port_taken, &l->local);
	if (fd < 0)
		return refused(err, errlen, "bind", spec, fd);
	l->fd = fd;
	swell_peers_init(&l->peers, device_side, device_side ? (have_opt ? &ls->peer : NULL) : &viewer);
	snprintf(l->name, sizeof(l->name), "udp:%u", (unsigned)ls->port);
	return 0;
}

static int open_can(struct ctl_link *l, const char *spec, const char *iface, char *err, size_t errlen)
{
	/* every error class but CAN_ERR_BUSERROR, which may flood */
	const struct swell_can_opts o = { .error_frames = 1,
					  .error_mask = CAN_ERR_TX_TIMEOUT | CAN_ERR_LOSTARB | CAN_ERR_CRTL |
						  CAN_ERR_PROT | CAN_ERR_TRX | CAN_ERR_ACK | CAN_ERR_BUSOFF |
						  CAN_ERR_RESTARTED | CAN_ERR_CNT };

	const int fd = swell_can_socket(iface, &o, 1);
	if (fd < 0)
		return refused(err, errlen, "CAN", spec, fd);
	l->fd = fd;
	return 0;
}

static int open_usb(struct ctl_link *l, const char *spec, const struct swell_link_spec *ls, int device_side, char *err,
		    size_t errlen)
{
	/* each link its own FunctionFS function: interface 0 the device link, 1 the host link when both
	 * are on USB (the gadget numbers them in the order they are linked into the configuration) */
	const struct swell_usb_ffs_iface iface = {
		.class_code = SWELL_USB_CLASS,
		.ep_out = SWELL_USB_EP_OUT,
		.ep_in = SWELL_USB_EP_IN,
		.fs_packet = SWELL_USB_PACKET,
		.name = device_side ? "swell controller: device link" : "swell controller: host link",
	};
	const struct swell_link_open_opts o = { .ffs_iface = &iface };
	const int rc = swell_link_open_spec(&l->usb, ls, &o);

	if (rc < 0) {
		snprintf(err, errlen, "%s: FunctionFS open failed: %s", spec, strerror(-rc));
		return -1;
	}
	return 0;
}

int ctl_link_open(struct ctl_link *l, const char *spec, int device_side, uint8_t node, char *err, size_t errlen)
{
	const unsigned accept = SWELL_LINK_ACCEPT(SWELL_LINK_UDP) | SWELL_LINK_ACCEPT(SWELL_LINK_CAN) |
		SWELL_LINK_ACCEPT(SWELL_LINK_FFS) |
		(device_side ? SWELL_LINK_ACCEPT(SWELL_LINK_HM) | SWELL_LINK_ACCEPT_PEER : SWELL_LINK_ACCEPT_LISTEN);
	struct swell_link_spec ls;

	memset(l, 0, sizeof(*l));
	l->fd = -1;
	l->node = node;
	if (swell_link_spec_parse(spec, accept, device_side ? SWELL_UDP_PORT_DEVICE : SWELL_UDP_PORT_VIEWER, &ls, err,
				  errlen))
		return -2;
	snprintf(l->name, sizeof(l->name), "%s", spec); /* can:IFACE, usb:FFS_DIR, hm:HOST; UDP names its port */
	switch (ls.kind) {
	case SWELL_LINK_UDP:
		l->kind = CTL_LINK_UDP;
		return open_udp(l, spec, &ls, device_side, err, errlen);
	case SWELL_LINK_HM:
		l->kind = CTL_LINK_HM;
		if (hm_client_open(&l->hm, ls.name, CTL_HM_MAX_AGE_TICKS, err, errlen) < 0)
			return -1;
		hm_fx_init(&l->hmfx, &l->hm, HM_FX_FRESH_TICKS);
		return 0;
	case SWELL_LINK_CAN:
		l->kind = CTL_LINK_CAN;
		return open_can(l, spec, ls.name, err, errlen);
	case SWELL_LINK_FFS:
		l->kind = CTL_LINK_USB;
		return open_usb(l, spec, &ls, device_side, err, errlen);
	default:
		break;
	}
	return -2;
}

int ctl_link_fd(const struct ctl_link *l)
{
	if (l->kind == CTL_LINK_HM)
		return hm_client_fd(&l->hm);
	if (l->kind == CTL_LINK_USB)
		return swell_link_poll_fd(l->usb);
	return l->fd;
}

/* Keep the messages addressed to this node; another node's (a second controller or device on the
 * bus) are counted and dropped, never acted on. */
static size_t own_node(struct ctl_link *l, struct swell_msg *m, size_t n)
{
	size_t kept = 0;

	for (size_t k = 0; k < n; k++)
		if (m[k].node != l->node)
			l->foreign++;
		else
			m[kept++] = m[k];
	return kept;
}

static size_t recv_usb(struct ctl_link *l, struct swell_msg *out, size_t cap)
{
	struct swell_frame f;
	size_t n = 0;

	if (swell_link_recv(l->usb, &f, 0) != 0) /* never waits */
		return 0;
	l->frames_rx++;
	if (swell_link_decode(SWELL_CARRIER_PKT, &f, out, cap, &n, NULL, &l->st) != SWELL_OK)
		return 0;
	return own_node(l, out, n);
}

/* UDP: the peer rules (swell/link_peers.h) around the decoder. Another node's packet takes nothing,
 * holds nothing. */
static size_t recv_udp(struct ctl_link *l, struct swell_msg *out, size_t cap)
{
	uint8_t buf[SWELL_PKT_MAX + 1];
	struct sockaddr_in from = { 0 }; /* filled by recvfrom; zeroed for the analyzer */
	size_t n = 0;
	uint8_t seq;
	long r = swell_udp_recv(l->fd, buf, sizeof(buf), &from, 0);

	if (r < 0)
		return 0;
	if (r > (long)sizeof(buf))
		r = (long)sizeof(buf); /* too long for a packet: the decoder refuses it and counts it */
	l->frames_rx++;
	if (!swell_peers_hear(&l->peers, &from) ||
	    swell_pkt_decode(buf, (size_t)r, out, cap, &n, &seq, &l->st) != SWELL_OK)
		return 0;
	n = own_node(l, out, n);
	return n ? swell_peers_take(&l->peers, &from, out, n, (int64_t)swell_link_now_ns()) : 0;
}

size_t ctl_link_recv(struct ctl_link *l, struct swell_msg *out, size_t cap)
{
	if (l->kind == CTL_LINK_HM) {
		size_t n = hm_client_poll(&l->hm, out, cap, l->node);

		l->frames_rx += n > 0;
		if (l->hm.refusal_seq != l->hm_refusal_seen) { /* once a reason, not every retry */
			l->hm_refusal_seen = l->hm.refusal_seq;
			fprintf(stderr,
				"swell-ctl: %s: start-up stopped before any force: %s (trying again every %d ms)\n",
				l->hm.name, l->hm.refusal, HMC_RETRY_MS);
		}
		return n;
	}
	if (l->kind == CTL_LINK_USB)
		return recv_usb(l, out, cap);
	if (l->kind == CTL_LINK_CAN) {
		struct canfd_frame f;
		const int r = cap < 1 ? -1 : swell_can_read(l->fd, &l->can, &f);

		l->frames_rx += r >= 0;
		if (r <= 0)
			return 0;
		if (f.can_id & (CAN_RTR_FLAG | CAN_EFF_FLAG)) {
			l->st.rejected[SWELL_EUNKNOWN]++; /* foreign formats: counted, dropped */
			return 0;
		}
		if (swell_can_decode(f.can_id, f.data, f.len, out, &l->st) != SWELL_OK)
			return 0;
		return own_node(l, out, 1);
	}
	return recv_udp(l, out, cap);
}

/* UDP: to the peer (device link: the device; host link: the configured viewer) and every client. */
static void send_bytes(struct ctl_link *l, const uint8_t *p, size_t len)
{
	struct sockaddr_in to[1 + SWELL_PEERS_CLIENTS];
	const size_t n = swell_peers_dests(&l->peers, to);

	for (size_t k = 0; k < n; k++)
		if (swell_udp_send(l->fd, &to[k], p, len) != 0)
			l->tx_errors++;
		else
			l->frames_tx++;
}

static int has_answer(const struct swell_msg *m, size_t n)
{
	for (size_t k = 0; k < n; k++)
		if (m[k].type == SWELL_MSG_PARAM_ACK || m[k].type == SWELL_MSG_PARAM_NACK)
			return 1;
	return 0;
}

/* USB: the held answer goes first; 0 when nothing is held any more. */
static int send_held(struct ctl_link *l)
{
	const int rc = l->held.len ? swell_link_send(l->usb, &l->held) : 0;

	if (rc == -EBUSY)
		return -1;
	if (l->held.len && rc == 0)
		l->frames_tx++;
	else if (l->held.len)
		l->answers_dropped++; /* unplugged: the host asks again */
	l->held.len = 0;
	return 0;
}

/* Queued, never waits: a host that stops reading loses telemetry (counted), not ticks. An answer that
 * finds the IN slots busy is held (one) and goes first next time; packets stay in order. */
static void send_usb(struct ctl_link *l, const struct swell_frame *f, int answer)
{
	const int rc = send_held(l) == 0 ? swell_link_send(l->usb, f) : -EBUSY;

	if (rc == 0) {
		l->frames_tx++;
		return;
	}
	if (answer && rc == -EBUSY && !l->held.len) {
		l->held = *f;
		l->answers_held++;
		return;
	}
	l->tx_errors++;
	l->answers_dropped += answer != 0;
}

static void send_msgs(struct ctl_link *l, const struct swell_msg *m, size_t n)
{
	size_t k = 0;

	if (l->kind == CTL_LINK_HM) {
		for (k = 0; k < n; k++) /* effect sets first: the tick's request carries the newest */
			hm_fx_msg(&l->hmfx, &l->hm, &m[k]);
		for (k = 0; k < n; k++)
			if (m[k].type == SWELL_MSG_FORCE_CMD) {
				const struct swell_msg_force_cmd *f = &m[k].u.force_cmd;
				const int16_t cN[3] = { f->fx_cN, f->fy_cN, f->fz_cN };

				hm_fx_tick(&l->hmfx, &l->hm, f->enable, 1);
				hm_client_force(&l->hm, cN, f->enable);
				l->frames_tx++;
			}
		return;
	}
	while (k < n) {
		struct swell_frame f;
		size_t used = 0;

		if (l->kind ==
		    CTL_LINK_CAN) { /* one frame a message; a full TX queue drops (the next tick is fresher) */
			int bad = swell_link_encode(SWELL_CARRIER_CAN, 0, 0, &m[k++], 1, &f, &used) != SWELL_OK;

			if (!bad) { /* a write may take the interface's down report before any read does */
				const int rc = swell_can_write(l->fd, &f, 0);

				swell_can_io_result(&l->can, rc);
				bad = rc != 0;
			}
			l->tx_errors += bad;
			l->frames_tx += !bad;
			continue;
		}
		if (swell_link_encode(SWELL_CARRIER_PKT, l->node, l->seq++, m + k, n - k, &f, &used) != SWELL_OK ||
		    used == 0) {
			l->tx_errors++;
			return;
		}
		if (l->kind == CTL_LINK_USB)
			send_usb(l, &f, has_answer(m + k, used));
		else
			send_bytes(l, f.data, f.len);
		k += used;
	}
}

void ctl_link_send(struct ctl_link *l, const struct swell_msg *m, size_t n)
{
	const uint32_t before = l->frames_tx;

	if (n == 0)
		return;
	if (l->kind == CTL_LINK_UDP)
		swell_peers_expire(&l->peers, (int64_t)swell_link_now_ns());
	send_msgs(l, m, n);
	if (l->frames_tx != before)
		l->unsent_run = 0;
	else if ((l->kind != CTL_LINK_UDP || l->peers.have_peer || swell_peers_clients(&l->peers) > 0) &&
		 l->unsent_run < UINT32_MAX) /* a UDP link without peer or client has nowhere to send */
		l->unsent_run++;
}

int ctl_link_send_wait(struct ctl_link *l, const struct swell_msg *m, size_t n, int wait_ms)
{
	const struct timespec ms = { 0, 1000000 };
	int rc = 0;

	if (l->kind == CTL_LINK_HM) { /* the device confirms the zero bias force, or the wait ends */
		ctl_link_send(l, m, n);
		/* effect mode: the exit's command may still be enabled (the core is RUNNING): the device's
		 * effects are removed whatever it says, confirmed with the zero */
		hm_fx_tick(&l->hmfx, &l->hm, 0, 0);
		rc = hm_client_zero_wait(&l->hm, wait_ms);
		l->tx_errors += rc != 0;
		return rc;
	}
	for (size_t k = 0; k < n; k++) {
		const uint32_t errors = l->tx_errors;
		int waited = 0;

		for (;;) {
			ctl_link_send(l, &m[k], 1);
			if (l->tx_errors == errors)
				break;
			if (waited >= wait_ms) {
				rc = -1;
				break;
			}
			l->tx_errors = errors; /* refused for now: tried again */
			nanosleep(&ms, NULL);
			waited++;
		}
	}
	return rc;
}

void ctl_link_close(struct ctl_link *l)
{
	if (l->kind == CTL_LINK_HM)
		hm_client_close(&l->hm);
	else if (l->kind == CTL_LINK_USB && l->usb)
		swell_link_close(l->usb);
	else if (l->fd >= 0)
		close(l->fd);
	l->fd = -1;
	l->usb = NULL;
}
