/* Host links: dispatch, counters and message framing per carrier. */
#define _GNU_SOURCE
#include "link_priv.h"

#include <errno.h>
#include <string.h>
#include <time.h>

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

const struct swell_link_counters *swell_link_get_counters(const struct swell_link *l)
{
	return &l->cnt;
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

	if (!m || !f || !used || n == 0)
		return SWELL_EINVAL;
	memset(&tmp, 0, sizeof(tmp));
	switch (c) {
	case SWELL_CARRIER_CAN: {
		uint8_t len;

		err = swell_can_encode(&m[0], &tmp.id, tmp.data, &len);
		tmp.len = len;
		*used = 1;
		break;
	}
	case SWELL_CARRIER_CANFD: {
		uint8_t len;

		err = swell_canfd_encode(m, n, &tmp.id, tmp.data, &len, used);
		tmp.len = len;
		tmp.flags = SWELL_FRAME_FD;
		break;
	}
	case SWELL_CARRIER_PKT: {
		size_t len;

		err = swell_pkt_encode(node, pkt_seq, m, n, tmp.data, sizeof(tmp.data), &len, used);
		tmp.len = (uint16_t)len;
		break;
	}
	default:
		return SWELL_EINVAL;
	}
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
	case SWELL_CARRIER_PKT:
		err = swell_pkt_decode(f->data, f->len, out, cap, n, &seq, st);
		if (err == SWELL_OK && pkt_seq)
			*pkt_seq = seq;
		return err;
	}
	return SWELL_EINVAL;
}
