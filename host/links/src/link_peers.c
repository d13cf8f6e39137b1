/* The peer rules of a served UDP socket: see swell/link_peers.h. */
#include "swell/link_peers.h"

#include <string.h>

#include "swell/link.h"
#include "swell/transport.h"

void swell_peers_init(struct swell_peers *p, int device_side, const struct sockaddr_in *fixed)
{
	memset(p, 0, sizeof(*p));
	p->device_side = device_side;
	if (fixed) {
		p->peer = *fixed;
		p->have_peer = p->peer_fixed = 1;
	}
}

int swell_peers_hear(struct swell_peers *p, const struct sockaddr_in *from)
{
	if (p->device_side && p->have_peer && !p->peer_open && !swell_udp_same(from, &p->peer)) {
		p->others++;
		return 0;
	}
	return 1;
}

static int has_type(const struct swell_msg *m, size_t n, uint8_t type)
{
	for (size_t k = 0; k < n; k++)
		if (m[k].type == type)
			return 1;
	return 0;
}

/* The device held, the device let go coming back, or a new sender of DEVICE_POS taking its place. */
static size_t take_device(struct swell_peers *p, const struct sockaddr_in *from, size_t n, int pos)
{
	if (p->have_peer && !p->peer_open)
		return n;
	if (p->have_peer && swell_udp_same(from, &p->peer)) {
		p->peer_open = !pos; /* the device let go is back: held again by its next sample */
		return n;
	}
	if (!pos) {
		p->others++;
		return 0;
	}
	p->peer = *from;
	p->have_peer = 1;
	p->peer_open = 0;
	p->peers_taken++;
	return n;
}

/* The client slot of from, taking a free one for a new sender; NULL when the table is full. */
static struct swell_peer_client *client_of(struct swell_peers *p, const struct sockaddr_in *from)
{
	struct swell_peer_client *free_slot = NULL;

	for (size_t k = 0; k < SWELL_PEERS_CLIENTS; k++) {
		struct swell_peer_client *c = &p->clients[k];

		if (c->heard_ns && swell_udp_same(&c->addr, from))
			return c;
		if (!c->heard_ns && !free_slot)
			free_slot = c;
	}
	if (free_slot) {
		free_slot->addr = *from;
		p->clients_admitted++;
	}
	return free_slot;
}

size_t swell_peers_take(struct swell_peers *p, const struct sockaddr_in *from, struct swell_msg *m, size_t n,
			int64_t now_ns)
{
	struct swell_peer_client *c;
	size_t kept = 0;

	if (p->device_side)
		return take_device(p, from, n, has_type(m, n, SWELL_MSG_DEVICE_POS));
	if (p->have_peer && swell_udp_same(from, &p->peer))
		return n; /* the configured viewer */
	swell_peers_expire(p, now_ns);
	c = client_of(p, from);
	if (!c) {
		p->clients_refused++;
		return 0;
	}
	c->heard_ns = now_ns;
	for (size_t k = 0; k < n; k++) /* the keep-alive: nothing for the reader */
		if (m[k].type != SWELL_MSG_HEARTBEAT)
			m[kept++] = m[k];
	return kept;
}

void swell_peers_expire(struct swell_peers *p, int64_t now_ns)
{
	const int64_t silent_ns = (int64_t)SWELL_UDP_CLIENT_SILENT_MS * 1000000;

	for (size_t k = 0; k < SWELL_PEERS_CLIENTS; k++)
		if (p->clients[k].heard_ns && now_ns - p->clients[k].heard_ns > silent_ns) {
			p->clients[k].heard_ns = 0;
			p->clients_silent++;
		}
}

int swell_peers_release(struct swell_peers *p)
{
	if (!p->device_side || p->peer_fixed || !p->have_peer || p->peer_open)
		return 0;
	p->peer_open = 1;
	return 1;
}

unsigned swell_peers_clients(const struct swell_peers *p)
{
	unsigned n = 0;

	for (size_t k = 0; k < SWELL_PEERS_CLIENTS; k++)
		n += p->clients[k].heard_ns != 0;
	return n;
}

size_t swell_peers_dests(const struct swell_peers *p, struct sockaddr_in *to)
{
	size_t n = 0;

	if (p->have_peer)
		to[n++] = p->peer;
	for (size_t k = 0; k < SWELL_PEERS_CLIENTS; k++)
		if (p->clients[k].heard_ns)
			to[n++] = p->clients[k].addr;
	return n;
}
