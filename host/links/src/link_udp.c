/* UDP link: one swell packet per datagram (software in the loop, loopback by default). */
#define _GNU_SOURCE
#include "link_priv.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

struct udp_link {
	struct swell_link base;
	int fd;
	int have_peer;
	int follow; /* no fixed peer: answer the last sender */
	struct sockaddr_in peer;
	uint16_t port;
};

static int udp_send(struct swell_link *l, const struct swell_frame *f)
{
	struct udp_link *u = (struct udp_link *)l;
	ssize_t n;

	if (!u->have_peer)
		return -ENOTCONN;
	n = sendto(u->fd, f->data, f->len, 0, (const struct sockaddr *)&u->peer, sizeof(u->peer));
	if (n < 0)
		return -errno;
	return n == f->len ? 0 : -EIO;
}

static int udp_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct udp_link *u = (struct udp_link *)l;
	uint64_t deadline = swell_link_deadline(timeout_ms);

	for (;;) {
		struct pollfd p = { .fd = u->fd, .events = POLLIN };
		struct sockaddr_in from = { 0 };
		socklen_t fl = sizeof(from);
		uint8_t buf[SWELL_LINK_MTU + 1];
		ssize_t n;
		int rc = poll(&p, 1, swell_link_ms_left(deadline, timeout_ms));

		if (rc < 0 && errno == EINTR)
			continue;
		if (rc < 0)
			return -errno;
		if (rc == 0)
			return -ETIMEDOUT;
		n = recvfrom(u->fd, buf, sizeof(buf), MSG_TRUNC, (struct sockaddr *)&from, &fl);
		if (n < 0)
			return -errno;
		if (n > (ssize_t)SWELL_LINK_MTU) {
			l->cnt.rx_dropped++; /* larger than any swell packet: not ours */
			continue;
		}
		if (u->follow) {
			u->peer = from;
			u->have_peer = 1;
		} else if (from.sin_port != u->peer.sin_port || from.sin_addr.s_addr != u->peer.sin_addr.s_addr) {
			l->cnt.rx_dropped++; /* a fixed peer: nobody else is heard (a stale sender to this port) */
			continue;
		}
		memset(f, 0, sizeof(*f));
		f->t_ns = swell_link_now_ns();
		f->len = (uint16_t)n;
		memcpy(f->data, buf, (size_t)n);
		return 0;
	}
}

static void udp_close(struct swell_link *l)
{
	struct udp_link *u = (struct udp_link *)l;

	close(u->fd);
	free(u);
}

static const struct swell_link_ops udp_ops = { udp_send, udp_recv, udp_close };

static int parse_addr(const char *host, uint16_t port, struct sockaddr_in *a)
{
	memset(a, 0, sizeof(*a));
	a->sin_family = AF_INET;
	a->sin_port = htons(port);
	return inet_pton(AF_INET, host, &a->sin_addr) == 1 ? 0 : -EINVAL;
}

int swell_link_open_udp(struct swell_link **out, const char *bind_host, uint16_t bind_port, const char *peer_host,
			uint16_t peer_port)
{
	struct udp_link *u;
	struct sockaddr_in a;
	socklen_t al = sizeof(a);
	int rc;

	if (!out || !bind_host)
		return -EINVAL;
	u = calloc(1, sizeof(*u));
	if (!u)
		return -ENOMEM;
	u->base.ops = &udp_ops;
	u->base.carrier = SWELL_CARRIER_PKT;
	rc = parse_addr(bind_host, bind_port, &a);
	if (rc == 0 && peer_host) {
		rc = parse_addr(peer_host, peer_port, &u->peer);
		u->have_peer = 1;
	}
	u->follow = !peer_host;
	if (rc)
		goto fail;
	u->fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
	if (u->fd < 0) {
		rc = -errno;
		goto fail;
	}
	if (bind(u->fd, (struct sockaddr *)&a, sizeof(a)) < 0 || getsockname(u->fd, (struct sockaddr *)&a, &al) < 0) {
		rc = -errno;
		close(u->fd);
		goto fail;
	}
	u->port = ntohs(a.sin_port);
	if (peer_host)
		snprintf(u->base.name, sizeof(u->base.name), "udp %s:%u -> %s:%u", bind_host, u->port, peer_host,
			 peer_port);
	else
		snprintf(u->base.name, sizeof(u->base.name), "udp %s:%u -> last sender", bind_host, u->port);
	*out = &u->base;
	return 0;
fail:
	free(u);
	return rc;
}

uint16_t swell_link_udp_port(const struct swell_link *l)
{
	return (l && l->ops == &udp_ops) ? ((const struct udp_link *)l)->port : 0;
}
