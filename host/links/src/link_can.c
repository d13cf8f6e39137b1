/* SocketCAN link: raw socket, optional filters, error frames taken into the bus state, bitrate via
 * libsocketcan. */
#define _GNU_SOURCE
#include "link_priv.h"

#include <errno.h>
#include <libsocketcan.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

struct can_link {
	struct swell_link base;
	struct swell_can_health health;
};

int swell_can_write(int fd, const struct swell_frame *f, int fd_mode)
{
	struct canfd_frame fr;
	size_t size;
	ssize_t n;

	memset(&fr, 0, sizeof(fr));
	fr.can_id = f->id & CAN_SFF_MASK;
	if (f->id > CAN_SFF_MASK)
		return -EINVAL; /* swell uses 11-bit identifiers only */
	fr.len = (uint8_t)f->len;
	memcpy(fr.data, f->data, f->len);
	if ((f->flags & SWELL_FRAME_FD) || f->len > CAN_MAX_DLEN) {
		if (!fd_mode)
			return -EMSGSIZE;
		fr.flags = CANFD_BRS;
		size = CANFD_MTU;
	} else {
		size = CAN_MTU;
	}
	do
		n = write(fd, &fr, size);
	while (n < 0 && errno == EINTR);
	if (n < 0)
		return -errno;
	return (size_t)n == size ? 0 : -EIO;
}

static int can_send(struct swell_link *l, const struct swell_frame *f)
{
	uint64_t deadline = 0;
	int rc;

	/* transmit queue full: wait for room rather than drop a frame, 100 ms at most. Not with poll:
	 * the socket stays writable (its own buffer is not what is full), POLLOUT comes at once, and
	 * with no node to ACK or a bus-off the queue never drains. */
	while ((rc = swell_can_write(l->fd, f, l->carrier == SWELL_CARRIER_CANFD)) == -ENOBUFS) {
		struct timespec ms = { 0, 1000000 };

		if (!deadline)
			deadline = swell_link_deadline(100);
		else if (swell_link_ms_left(deadline, 100) == 0)
			break;
		nanosleep(&ms, NULL);
	}
	swell_can_io_result(&((struct can_link *)l)->health, rc);
	return rc;
}

static int can_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct can_link *c = (struct can_link *)l;
	uint64_t deadline = swell_link_deadline(timeout_ms);

	for (;;) {
		struct canfd_frame fr;
		int n = swell_link_wait_in(l->fd, deadline, timeout_ms);

		if (n < 0)
			return n;
		n = swell_can_read(l->fd, &c->health, &fr);
		if (n < 0)
			return -errno;
		if (n == 0 && (fr.can_id & CAN_ERR_FLAG)) { /* taken into the bus state */
			l->cnt.bus_errors++;
			continue;
		}
		if (n == 0 || (fr.can_id & CAN_RTR_FLAG)) { /* heard while bus-off, or a remote frame */
			l->cnt.rx_dropped++;
			continue;
		}
		memset(f, 0, sizeof(*f));
		f->t_ns = swell_link_now_ns();
		f->id = fr.can_id & (fr.can_id & CAN_EFF_FLAG ? CAN_EFF_MASK : CAN_SFF_MASK);
		f->flags = (uint8_t)((fr.can_id & CAN_EFF_FLAG ? SWELL_FRAME_EFF : 0u) |
				     (n == CANFD_MTU ? SWELL_FRAME_FD : 0u));
		f->len = fr.len > CANFD_MAX_DLEN ? CANFD_MAX_DLEN : fr.len;
		memcpy(f->data, fr.data, f->len);
		return 0;
	}
}

const char *swell_can_state_name(enum swell_can_state s)
{
	static const char *const names[] = { "error-active", "error-warning", "error-passive", "bus-off" };

	return (unsigned)s <= SWELL_CAN_BUS_OFF ? names[s] : "?";
}

enum swell_can_event swell_can_error_frame(struct swell_can_health *h, uint32_t can_id, const uint8_t d[8])
{
	enum swell_can_state before, now;

	if (!h || !d || !(can_id & CAN_ERR_FLAG))
		return SWELL_CAN_EV_NONE;
	before = now = (enum swell_can_state)h->state;
	h->error_frames++;
	if (can_id & (CAN_ERR_CNT | CAN_ERR_CRTL)) { /* drivers put the counters in data[6], data[7] */
		h->tx_err = d[6];
		h->rx_err = d[7];
	}
	h->tx_timeouts += (can_id & CAN_ERR_TX_TIMEOUT) != 0;
	h->lost_arb += (can_id & CAN_ERR_LOSTARB) != 0;
	h->no_ack += (can_id & CAN_ERR_ACK) != 0;
	h->prot += (can_id & CAN_ERR_PROT) != 0;
	h->transceiver += (can_id & CAN_ERR_TRX) != 0;
	if (can_id & CAN_ERR_CRTL) {
		h->overflows += (d[1] & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW)) != 0;
		if (before != SWELL_CAN_BUS_OFF) { /* only a restart leaves bus-off, not a counter report */
			if (d[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))
				now = SWELL_CAN_PASSIVE;
			else if (d[1] & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING))
				now = SWELL_CAN_WARNING;
		}
		if (d[1] & CAN_ERR_CRTL_ACTIVE)
			now = SWELL_CAN_ACTIVE;
	}
	if (can_id & CAN_ERR_RESTARTED) {
		now = SWELL_CAN_ACTIVE;
		if (!(can_id & CAN_ERR_CNT)) /* a restarted controller starts with clear counters */
			h->tx_err = h->rx_err = 0;
	}
	if (can_id & CAN_ERR_BUSOFF) /* wins over a restart in the same frame: fail safe */
		now = SWELL_CAN_BUS_OFF;
	if (now == before)
		return SWELL_CAN_EV_NONE;
	h->state = (uint8_t)now;
	uint32_t *const into[] = { &h->actives, &h->warnings, &h->passives, &h->bus_offs }; /* by state */
	(*into[now])++;
	if (now == SWELL_CAN_BUS_OFF)
		return SWELL_CAN_EV_BUS_OFF;
	if (before == SWELL_CAN_BUS_OFF) {
		h->restarts++;
		return SWELL_CAN_EV_RESTARTED;
	}
	return SWELL_CAN_EV_STATE;
}

void swell_can_io_result(struct swell_can_health *h, int rc)
{
	if (rc == 0) {
		h->down_seen = 0;
		return;
	}
	if (rc != -ENETDOWN)
		return;
	if (!h->down_seen)
		h->downs++;
	h->down_seen = 1;
	h->tx_err = h->rx_err = 0;
	if (h->state == SWELL_CAN_BUS_OFF) {
		h->state = SWELL_CAN_ACTIVE;
		h->restarts++;
	}
}

int swell_can_read(int fd, struct swell_can_health *h, struct canfd_frame *f)
{
	const ssize_t r = read(fd, f, sizeof(*f));

	if (r < 0) {
		const int e = errno;

		swell_can_io_result(h, -e);
		errno = e;
		return -1;
	}
	swell_can_io_result(h, 0);
	if (r != CAN_MTU && r != CANFD_MTU) {
		errno = EIO;
		return -1;
	}
	if (f->can_id & CAN_ERR_FLAG) {
		swell_can_error_frame(h, f->can_id, f->data);
		return 0;
	}
	if (h->state == SWELL_CAN_BUS_OFF) {
		h->dropped_off++;
		return 0;
	}
	return (int)r;
}

static const struct swell_link_ops can_ops = { can_send, can_recv, swell_link_close_fd, NULL };

int swell_can_socket(const char *ifname, const struct swell_can_opts *opts, int nonblock)
{
	struct sockaddr_can addr;
	struct ifreq ifr;
	int fd, rc, on = 1;

	if (!ifname || strlen(ifname) >= IFNAMSIZ)
		return -EINVAL;
	fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC | (nonblock ? SOCK_NONBLOCK : 0), CAN_RAW);
	if (fd < 0)
		return -errno;
	memset(&ifr, 0, sizeof(ifr));
	memcpy(ifr.ifr_name, ifname, strlen(ifname));
	if (ioctl(fd, SIOCGIFINDEX, &ifr) < 0)
		goto fail_errno;
	if (opts->fd) {
		/* refuse up front rather than on the first long frame: an FD interface has MTU 72 */
		struct ifreq mtu = ifr;

		if (ioctl(fd, SIOCGIFMTU, &mtu) < 0)
			goto fail_errno;
		if (mtu.ifr_mtu != (int)CANFD_MTU) {
			errno = EOPNOTSUPP;
			goto fail_errno;
		}
	}
	if (opts->fd && setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof(on)) < 0)
		goto fail_errno;
	if (opts->filters) {
		struct can_filter flt[64];
		size_t i;

		if (opts->nfilters > 64) {
			errno = EINVAL;
			goto fail_errno;
		}
		for (i = 0; i < opts->nfilters; i++) {
			flt[i].can_id = opts->filters[i].id & CAN_SFF_MASK;
			flt[i].can_mask = (opts->filters[i].mask & CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG;
		}
		if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, flt, (socklen_t)(opts->nfilters * sizeof(flt[0]))) < 0)
			goto fail_errno;
	}
	if (opts->error_frames) {
		can_err_mask_t em = opts->error_mask ? opts->error_mask : CAN_ERR_MASK;

		if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &em, sizeof(em)) < 0)
			goto fail_errno;
	}
	memset(&addr, 0, sizeof(addr));
	addr.can_family = AF_CAN;
	addr.can_ifindex = ifr.ifr_ifindex;
	if (bind(fd, (struct sockaddr *)&addr, sizeof(addr)) < 0)
		goto fail_errno;
	return fd;
fail_errno:
	rc = -errno; /* before close, which may change it */
	close(fd);
	return rc;
}

const struct swell_can_health *swell_link_can_health(const struct swell_link *l)
{
	return (l && l->ops == &can_ops) ? &((const struct can_link *)l)->health : NULL;
}

int swell_link_open_can(struct swell_link **out, const char *ifname, const struct swell_can_opts *opts)
{
	static const struct swell_can_opts defaults;
	struct can_link *c;
	int rc;

	if (!out || !ifname || strlen(ifname) >= IFNAMSIZ)
		return -EINVAL;
	if (!opts)
		opts = &defaults;
	errno = 0; /* libsocketcan returns -1 with errno from netlink (EPERM without CAP_NET_ADMIN, EOPNOTSUPP on vcan) */
	if (opts->bitrate &&
	    (can_do_stop(ifname) < 0 || can_set_bitrate(ifname, opts->bitrate) < 0 || can_do_start(ifname) < 0))
		return errno ? -errno : -EIO;
	c = calloc(1, sizeof(*c));
	if (!c)
		return -ENOMEM;
	c->base.ops = &can_ops;
	c->base.carrier = opts->fd ? SWELL_CARRIER_CANFD : SWELL_CARRIER_CAN;
	c->base.fd = swell_can_socket(ifname, opts, 0);
	if (c->base.fd < 0) {
		rc = c->base.fd;
		free(c);
		return rc;
	}
	snprintf(c->base.name, sizeof(c->base.name), "%s %s", opts->fd ? "canfd" : "can", ifname);
	*out = &c->base;
	return 0;
}
