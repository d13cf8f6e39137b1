/* UDP link: one swell packet per datagram (software in the loop, loopback by default). */
#define _GNU_SOURCE
#include "link_priv.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

struct udp_link {
	struct swell_link base;
	int have_peer;
	int follow; /* no fixed peer: answer the last sender */
	struct sockaddr_in peer;
	uint16_t port;
};

int swell_udp_socket(const struct sockaddr_in *at, int nonblock, int any_if_taken, int *taken,
		     struct sockaddr_in *bound)
{
	const int rcvbuf = 2 << 20; /* bytes of queue, about 2700 small datagrams */
	struct sockaddr_in a = *at;
	socklen_t alen = sizeof(*bound);
	int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | (nonblock ? SOCK_NONBLOCK : 0), 0), rc;

	if (fd < 0)
		return -errno;
	/* A burst from a third sender (2000 garbage datagrams in the bench) must not make the kernel drop
	 * the device's samples while this process waits for the CPU: a deep receive queue (FORCE when
	 * permitted, else capped by net.core.rmem_max; the default queue holds about 280 datagrams). */
	if (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &rcvbuf, sizeof(rcvbuf)) < 0)
		(void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
	rc = bind(fd, (const struct sockaddr *)&a, sizeof(a));
	if (rc < 0 && errno == EADDRINUSE && any_if_taken) {
		a.sin_port = 0;
		*taken = 1;
		rc = bind(fd, (const struct sockaddr *)&a, sizeof(a));
	}
	if (rc < 0 || getsockname(fd, (struct sockaddr *)bound, &alen) < 0) {
		rc = -errno; /* before close, which may change it */
		close(fd);
		return rc;
	}
	return fd;
}

long swell_udp_recv(int fd, void *buf, size_t cap, struct sockaddr_in *from, int timeout_ms)
{
	socklen_t fl = sizeof(*from);
	ssize_t n = timeout_ms == 0 ? 0 : swell_link_wait_in(fd, swell_link_deadline(timeout_ms), timeout_ms);

	if (n < 0)
		return (long)n;
	memset(from, 0, sizeof(*from));
	n = recvfrom(fd, buf, cap, MSG_TRUNC | MSG_DONTWAIT, (struct sockaddr *)from, &fl);
	if (n < 0)
		return errno == EAGAIN || errno == EWOULDBLOCK ? -ETIMEDOUT : -errno;
	return (long)n;
}

int swell_udp_send(int fd, const struct sockaddr_in *to, const void *p, size_t len)
{
	ssize_t n = sendto(fd, p, len, 0, (const struct sockaddr *)to, sizeof(*to));

	if (n < 0)
		return -errno;
	return n == (ssize_t)len ? 0 : -EIO;
}

int swell_udp_same(const struct sockaddr_in *a, const struct sockaddr_in *b)
{
	return a->sin_port == b->sin_port && a->sin_addr.s_addr == b->sin_addr.s_addr;
}

static int udp_send(struct swell_link *l, const struct swell_frame *f)
{
	struct udp_link *u = (struct udp_link *)l;

	return u->have_peer ? swell_udp_send(u->base.fd, &u->peer, f->data, f->len) : -ENOTCONN;
}

static int udp_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct udp_link *u = (struct udp_link *)l;
	uint64_t deadline = swell_link_deadline(timeout_ms);

	for (;;) {
		struct sockaddr_in from = { 0 }; /* filled by recvfrom; zeroed for the analyzer */
		uint8_t buf[SWELL_LINK_MTU + 1];
		long n = swell_udp_recv(u->base.fd, buf, sizeof(buf), &from, swell_link_ms_left(deadline, timeout_ms));

		if (n < 0)
			return (int)n;
		if (n > (long)SWELL_LINK_MTU) {
			l->cnt.rx_dropped++; /* larger than any swell packet: not ours */
			continue;
		}
		if (u->follow) {
			u->peer = from;
			u->have_peer = 1;
		} else if (!swell_udp_same(&from, &u->peer)) {
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

static const struct swell_link_ops udp_ops = { udp_send, udp_recv, swell_link_close_fd, NULL };

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
	int rc;

	if (!out || !bind_host)
		return -EINVAL;
	u = calloc(1, sizeof(*u));
	if (!u)
		return -ENOMEM;
	u->base.ops = &udp_ops;
	u->base.carrier = SWELL_CARRIER_PKT;
	u->have_peer = peer_host != NULL;
	u->follow = !peer_host;
	rc = parse_addr(bind_host, bind_port, &a);
	if (rc == 0 && peer_host)
		rc = parse_addr(peer_host, peer_port, &u->peer);
	u->base.fd = rc ? rc : swell_udp_socket(&a, 0, 0, NULL, &a);
	if (u->base.fd < 0) {
		rc = u->base.fd;
		free(u);
		return rc;
	}
	u->port = ntohs(a.sin_port);
	if (peer_host)
		snprintf(u->base.name, sizeof(u->base.name), "udp %s:%u -> %s:%u", bind_host, u->port, peer_host,
			 peer_port);
	else
		snprintf(u->base.name, sizeof(u->base.name), "udp %s:%u -> last sender", bind_host, u->port);
	*out = &u->base;
	return 0;
}

uint16_t swell_link_udp_port(const struct swell_link *l)
{
	return (l && l->ops == &udp_ops) ? ((const struct udp_link *)l)->port : 0;
}
