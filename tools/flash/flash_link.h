/* swell-flash: which host link to talk to a running controller on. The spellings are swell-view's
 * sources, parsed by swell/link_spec.h: udp[:PORT], can:IFACE, usb[:VID:PID]; the controller's node and a
 * USB interface other than 0 come from options (--node, --iface, as swell-ctl and swell-hm spell
 * them). One code path for every carrier: the host link library (swell/link.h). On UDP the tools are
 * clients of the controller's host link: they send to its clients' port, 47802 unless given. */
#ifndef SWELL_FLASH_LINK_H
#define SWELL_FLASH_LINK_H

#include <stddef.h>
#include <stdint.h>

#include "swell/link_spec.h"

struct swell_link;

struct flash_link_spec {
	/* SWELL_LINK_ACCEPT_HOST_SIDE; UDP: the controller's clients' port on 127.0.0.1 (swell-ctl's listen=) */
	struct swell_link_spec link;
	int node; /* 0..15, or -1: the one controller heard */
};

/* Open the link. A USB device not there yet (it is re-enumerating after a reset) is waited for up
 * to wait_ms. 0 or a negative errno. */
int flash_link_open(const struct flash_link_spec *s, int wait_ms, struct swell_link **out);

/* UDP: the controller keeps a client while it hears from it (SWELL_UDP_CLIENT_SILENT_MS) and
 * admits it by its first packet of its node: when *due_ns (CLOCK_MONOTONIC; 0 at first) has come,
 * send a HEARTBEAT of node (-1: one for each node 0..15, the controller is not known yet, and the
 * next ones come every 100 ms instead of every second) and set the next time. Returns the ms until the next one is due, for a receive to wait at most; -1 on
 * other carriers (nothing sent: a heartbeat on a CAN bus would pass for the controller's). */
int flash_link_keepalive(struct swell_link *l, int node, uint64_t *due_ns);

#endif
