/* Host links: dispatch, counters and message framing per carrier. */
#define _GNU_SOURCE
#include "link_priv.h"

#include <errno.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "swell/transport.h"

uint64_t swell_link_now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

uint64_t swell_link_deadline(int timeout_ms)
{
	return timeout_ms < 0 ? UINT64_MAX : swell_link_now_ns() + (uint64_t)timeout_ms * 1000000u;
}

int swell_link_ms_left(uint64_t deadline_ns, int timeout_ms)
{
	uint64_t now;

	if (timeout_ms < 0)
		return -1;
	now = swell_link_now_ns();
	if (now >= deadline_ns)
		return 0;
	return (int)((deadline_ns - now + 999999u) / 1000000u);
}

uint8_t *swell_put_le(uint8_t *p, uint64_t v, int n)
{
	for (int i = 0; i < n; i++)
		p[i] = (uint8_t)(v >> (8 * i));
	return p + n;
}

int swell_link_wait_in(int fd, uint64_t deadline_ns, int timeout_ms)
{
	for (;;) {
		struct pollfd p = { .fd = fd, .events = POLLIN };
		const int rc = poll(&p, 1, swell_link_ms_left(deadline_ns, timeout_ms));

		if (rc > 0)
			return 0;
		if (rc == 0)
			return -ETIMEDOUT;
		if (errno != EINTR)
			return -errno;
	}
}

int swell_link_send(struct swell_link *l, const struct swell_frame *f)
{
	int rc;

	if (!l || !f || f->len > SWELL_LINK_MTU)
		return -EINVAL;
	rc = l->ops->send(l, f);
	if (rc == 0) {
		l->cnt.tx_frames++;
		l->cnt.tx_bytes += f->len;
	} else {
		l->cnt.tx_errors++;
	}
	return rc;
}

int swell_link_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	int rc;

	if (!l || !f)
		return -EINVAL;
	rc = l->ops->recv(l, f, timeout_ms);
	if (rc == 0) {
		l->cnt.rx_frames++;
		l->cnt.rx_bytes += f->len;
	} else if (rc == -ETIMEDOUT) {
		l->cnt.rx_timeouts++;
	} else if (rc != -ENODATA) {
		l->cnt.rx_errors++;
	}
	return rc;
}

void swell_link_close(struct swell_link *l)
{
	if (l)
		l->ops->close(l);
}

void swell_link_close_fd(struct swell_link *l)
{
	close(l->fd);
	free(l);
}

const struct swell_link_counters *swell_link_get_counters(const struct swell_link *l)
{
	return &l->cnt;
}

int swell_link_poll_fd(const struct swell_link *l)
{
	return l->ops->poll_fd ? l->ops->poll_fd(l) : -1;
}

enum swell_carrier swell_link_carrier(const struct swell_link *l)
{
	return l->carrier;
}

const char *swell_link_name(const struct swell_link *l)
{
	return l->name;
}

enum swell_err swell_link_encode(enum swell_carrier c, uint8_t node, uint8_t pkt_seq, const struct swell_msg *m,
				 size_t n, struct swell_frame *f, size_t *used)
{
	struct swell_frame tmp;
	enum swell_err err;
	uint8_t can_len = 0;
	size_t len = 0;

	if (!m || !f || !used || n == 0)
		return SWELL_EINVAL;
	memset(&tmp, 0, sizeof(tmp));
	switch (c) {
	case SWELL_CARRIER_CAN:
		err = swell_can_encode(&m[0], &tmp.id, tmp.data, &can_len);
		*used = 1;
		break;
	case SWELL_CARRIER_CANFD:
		err = swell_canfd_encode(m, n, &tmp.id, tmp.data, &can_len, used);
		tmp.flags = SWELL_FRAME_FD;
		break;
	case SWELL_CARRIER_PKT:
		err = swell_pkt_encode(node, pkt_seq, m, n, tmp.data, sizeof(tmp.data), &len, used);
		break;
	default:
		return SWELL_EINVAL;
	}
	tmp.len = (uint16_t)(c == SWELL_CARRIER_PKT ? len : can_len);
	if (err == SWELL_OK)
		*f = tmp;
	return err;
}

enum swell_err swell_link_decode(enum swell_carrier c, const struct swell_frame *f, struct swell_msg *out, size_t cap,
				 size_t *n, uint8_t *pkt_seq, struct swell_proto_stats *st)
{
	uint32_t id;
	uint8_t seq;
	enum swell_err err;

	if (!f || !out || !n || cap == 0)
		return SWELL_EINVAL;
	id = (f->flags & SWELL_FRAME_EFF) ? 0xFFFFFFFFu : f->id;
	switch (c) {
	case SWELL_CARRIER_CAN:
	case SWELL_CARRIER_CANFD: /* an FD interface also carries classic frames */
		if (f->flags & SWELL_FRAME_FD)
			return swell_canfd_decode(id, f->data, f->len, out, cap, n, st);
		err = swell_can_decode(id, f->data, f->len, out, st);
		if (err == SWELL_OK)
			*n = 1;
		return err;
	case SWELL_CARRIER_PKT: /* *pkt_seq written only on success */
		return swell_pkt_decode(f->data, f->len, out, cap, n, pkt_seq ? pkt_seq : &seq, st);
	}
	return SWELL_EINVAL;
}

int swell_link_open_spec(struct swell_link **out, const struct swell_link_spec *s, const struct swell_link_open_opts *o)
{
	const char *host = o->udp_host ? o->udp_host : SWELL_UDP_HOST;

	switch (s->kind) {
	case SWELL_LINK_UDP:
		if (o->udp_answer)
			return swell_link_open_udp(out, host, s->port, NULL, 0);
		for (unsigned k = 0; k < o->udp_bind_tries; k++) {
			int rc = swell_link_open_udp(out, host, (uint16_t)(o->udp_bind_port + k), host, s->port);

			if (rc != -EADDRINUSE)
				return rc;
		}
		return swell_link_open_udp(out, host, o->udp_bind_tries ? 0 : o->udp_bind_port, host, s->port);
	case SWELL_LINK_CAN:
	case SWELL_LINK_CANFD: {
		struct swell_can_opts co = { 0 }; /* every id unless filtered: nodes are told apart by decoding */

		co.fd = s->kind == SWELL_LINK_CANFD;
		co.error_frames = o->can_errors;
		if (!co.fd) {
			co.filters = o->can_filters;
			co.nfilters = o->can_nfilters;
		}
		return swell_link_open_can(out, s->name, &co);
	}
	case SWELL_LINK_USB: {
		struct swell_usb_opts uo;

		swell_usb_opts_default(&uo);
		uo.vid = s->vid;
		uo.pid = s->pid;
		uo.iface = s->iface;
		return swell_link_open_usb(out, &uo);
	}
	case SWELL_LINK_FFS:
		return o->ffs_iface ? swell_link_open_ffs(out, s->name, o->ffs_iface) : -EINVAL;
	case SWELL_LINK_REPLAY:
		return swell_link_open_replay(out, s->name, s->realtime);
	default:
		return -EINVAL;
	}
}
