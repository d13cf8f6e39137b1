/* Link specs: the one spelling of a link on every command line (the spellings: docs/links.md, "Link
 * specs"), parsed by one function with one form of error ("'SPEC': reason", one line). Part of the
 * host link library: POSIX-hosted, linked by the host programs and swell-ctl, never by the core. */
#ifndef SWELL_LINK_SPEC_H
#define SWELL_LINK_SPEC_H

#include <netinet/in.h>
#include <stddef.h>
#include <stdint.h>

enum swell_link_kind {
	SWELL_LINK_UDP,
	SWELL_LINK_CAN,
	SWELL_LINK_CANFD,
	SWELL_LINK_USB, /* libusb */
	SWELL_LINK_FFS, /* FunctionFS */
	SWELL_LINK_HM,
	SWELL_LINK_REPLAY,
	SWELL_LINK_KINDS
};

/* What a program accepts: a bit per kind, and the two UDP options. */
#define SWELL_LINK_ACCEPT(kind) (1u << (kind))
#define SWELL_LINK_ACCEPT_PEER (1u << 16)
#define SWELL_LINK_ACCEPT_LISTEN (1u << 17)

/* The links of a program on the host's side of a controller (tools, the device model, the bridge). */
#define SWELL_LINK_ACCEPT_HOST_SIDE \
	(SWELL_LINK_ACCEPT(SWELL_LINK_UDP) | SWELL_LINK_ACCEPT(SWELL_LINK_CAN) | SWELL_LINK_ACCEPT(SWELL_LINK_USB))

#define SWELL_LINK_IFNAME_MAX 16 /* IFNAMSIZ, terminator included */

struct swell_link_spec {
	enum swell_link_kind kind;
	uint16_t port; /* UDP: PORT, or the caller's default when not spelled */
	int port_given; /* UDP: PORT was spelled */
	int have_peer, have_listen; /* UDP options: peer=, listen= (ADDR: 127.0.0.1 when left out) */
	struct sockaddr_in peer, listen_at;
	char name[256]; /* CAN: interface; FFS: directory; HM: HOST[:PORT]; REPLAY: file */
	uint16_t vid, pid; /* USB: SWELL_USB_VID / SWELL_USB_PID unless spelled */
	uint8_t iface; /* USB: interface number, 0 (programs set it from their --iface) */
	int realtime; /* REPLAY: 1 for replay:, 0 for replay-fast: */
};

/* Parse text into *out: 0, or -1 with the reason in err (one line, the spec quoted first) and *out
 * untouched. accept: SWELL_LINK_ACCEPT bits; udp_port: the UDP port when none is spelled. */
int swell_link_spec_parse(const char *text, unsigned accept, uint16_t udp_port, struct swell_link_spec *out, char *err,
			  size_t errlen);

/* "udp 127.0.0.1:47802", "can can1", "usb 1209:0001 interface 0", ... */
void swell_link_spec_describe(const struct swell_link_spec *s, char *buf, size_t len);

#endif
