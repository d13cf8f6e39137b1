/* The tools' link to a running controller, for swell-tool and swell-flash (udp[:PORT], can:IFACE,
 * usb[:VID:PID]; the node and a USB interface other than 0 are options). On UDP the tools are clients of the controller's host
 * link: they send to its clients' port, 47802 unless given. */
#ifndef SWELL_LINK_CLIENT_H
#define SWELL_LINK_CLIENT_H

#include <stddef.h>
#include <stdint.h>

#include "swell/link_spec.h"

struct swell_link;

struct swell_client_spec {
	/* SWELL_LINK_ACCEPT_HOST_SIDE; UDP: the controller's clients' port on 127.0.0.1 (swell-ctl's listen=) */
	struct swell_link_spec link;
	int node; /* 0..15, or -1: the one controller heard */
};

/* Open the link. A USB device not there yet (it is re-enumerating after a reset) is waited for up
 * to wait_ms. 0 or a negative errno. */
int swell_client_open(const struct swell_client_spec *s, int wait_ms, struct swell_link **out);

/* UDP: the controller keeps a client while it hears from it: when *due_ns (CLOCK_MONOTONIC; 0 at
 * first) has come, send a HEARTBEAT of node (-1: one for each node 0..15, every 100 ms instead of every
 * second, until the controller is known) and set the next time. Returns the ms until the next one is
 * due, for a receive to wait at most; -1 on other carriers (a heartbeat on a CAN bus would pass for
 * the controller's). */
int swell_client_keepalive(struct swell_link *l, int node, uint64_t *due_ns);

#endif
