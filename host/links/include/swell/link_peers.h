/* Who may talk on a UDP socket that serves more than one sender: swell-ctl's device link and host
 * link (docs/links.md has the rules). Pure: no I/O. The caller reads (swell_udp_recv), asks
 * swell_peers_hear before decoding and swell_peers_take after, and sends to swell_peers_dests. Times
 * are CLOCK_MONOTONIC ns. */
#ifndef SWELL_LINK_PEERS_H
#define SWELL_LINK_PEERS_H

#include <netinet/in.h>
#include <stddef.h>
#include <stdint.h>

#include "swell/proto.h"

#define SWELL_PEERS_CLIENTS 4u

struct swell_peer_client {
	struct sockaddr_in addr;
	int64_t heard_ns; /* its last valid packet; 0: the slot is free */
};

struct swell_peers {
	int device_side;
	/* Device link: the device, configured (peer_fixed) or learned, held until swell_peers_release opens
	 * it (peer_open: still sent to, and the next sender of DEVICE_POS takes it). Host link: the
	 * configured viewer address, sent to whether or not it speaks. */
	struct sockaddr_in peer;
	int have_peer, peer_fixed, peer_open;
	uint32_t others; /* device link: datagrams of any other sender, dropped (unread once held) */
	uint32_t peers_taken; /* device link: times a sender became the device */
	struct swell_peer_client clients[SWELL_PEERS_CLIENTS];
	uint32_t clients_admitted, clients_silent; /* host link: admitted, dropped after their silence */
	uint32_t clients_refused; /* host link: valid packets of senders refused for a full table */
};

/* fixed: the device (device side) or the viewer address (host side); NULL: none. */
void swell_peers_init(struct swell_peers *p, int device_side, const struct sockaddr_in *fixed);

/* Before decoding: 0 when the datagram of `from` is dropped unread (device side, another sender than
 * the device held; counted in others), else 1. */
int swell_peers_hear(struct swell_peers *p, const struct sockaddr_in *from);

/* After decoding: m[0..n) are the packet's messages of this node (n > 0). Returns how many of them go
 * on, kept at the front of m: 0 when the sender is not heard (device side: no device held and no
 * DEVICE_POS; host side: the client table is full); a client's HEARTBEAT (its keep-alive) is taken
 * here. */
size_t swell_peers_take(struct swell_peers *p, const struct sockaddr_in *from, struct swell_msg *m, size_t n,
			int64_t now_ns);

/* Host side: clients silent for longer than SWELL_UDP_CLIENT_SILENT_MS lose their slot. */
void swell_peers_expire(struct swell_peers *p, int64_t now_ns);

/* Device side, the device declared lost: a learned device is let go (1); a configured one is kept (0). */
int swell_peers_release(struct swell_peers *p);

/* Clients now admitted. */
unsigned swell_peers_clients(const struct swell_peers *p);

/* Where a send goes: the peer, when there is one, and every client; at most 1 + SWELL_PEERS_CLIENTS
 * addresses into to. Returns their number. */
size_t swell_peers_dests(const struct swell_peers *p, struct sockaddr_in *to);

#endif
