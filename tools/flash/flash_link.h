/* swell-flash: which host link to talk to a running controller on. The spellings are swell-view's
 * sources (host/view/sources.c): udp[:PORT], can:IFACE, usb[:VID:PID]; the controller's node and a
 * USB interface other than 0 come from options (--node, --iface, as swell-ctl and swell-hm spell
 * them). One code path for every carrier: the host link library (swell/link.h). On UDP the tools are
 * clients of the controller's host link: they send to its clients' port, 47802 unless given. */
#ifndef SWELL_FLASH_LINK_H
#define SWELL_FLASH_LINK_H

#include <stddef.h>
#include <stdint.h>

struct swell_link;

enum flash_link_kind {
	FLASH_LINK_UDP,
	FLASH_LINK_CAN,
	FLASH_LINK_USB
};

#define FLASH_LINK_IFNAME_MAX 16 /* IFNAMSIZ, terminator included */

struct flash_link_spec {
	enum flash_link_kind kind;
	uint16_t udp_port; /* UDP: the controller's clients' port on 127.0.0.1 (swell-ctl's listen=) */
	char can_if[FLASH_LINK_IFNAME_MAX]; /* CAN: the SocketCAN interface */
	uint16_t usb_vid, usb_pid; /* USB: the controller's device */
	uint8_t usb_iface; /* USB: its host-link interface (0; 1 when both links are USB) */
	int node; /* 0..15, or -1: the one controller heard */
};

/* Parse spec into *out. 0 on success; -1 with a one-line reason in err (out untouched). Defaults:
 * udp port 47802, USB 1209:0001 interface 0, node -1. */
int flash_link_parse(const char *spec, struct flash_link_spec *out, char *err, size_t errlen);

/* "udp 127.0.0.1:47802", "can can1", "usb 1209:0001 interface 0". */
void flash_link_describe(const struct flash_link_spec *s, char *buf, size_t len);

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
