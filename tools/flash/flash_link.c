/* swell-flash: host link specs; see flash_link.h. */
#define _GNU_SOURCE
#include "flash_link.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/link.h"
#include "swell/transport.h"

#define SPELLINGS "udp[:PORT], can:IFACE or usb[:VID:PID]"

static int refuse(char *err, size_t len, const char *fmt, const char *spec)
{
	snprintf(err, len, fmt, spec);
	return -1;
}

/* 1 to 4 hex digits, nothing else. */
static int hex16(const char *s, size_t n, uint16_t *v)
{
	unsigned x = 0;
	size_t k;

	if (n < 1 || n > 4)
		return -1;
	for (k = 0; k < n; k++) {
		char c = s[k];
		unsigned d = c >= '0' && c <= '9' ? (unsigned)(c - '0')
			: c >= 'a' && c <= 'f'    ? (unsigned)(c - 'a' + 10)
			: c >= 'A' && c <= 'F'    ? (unsigned)(c - 'A' + 10)
						  : 16u;
		if (d > 15)
			return -1;
		x = x * 16 + d;
	}
	*v = (uint16_t)x;
	return 0;
}

int flash_link_parse(const char *spec, struct flash_link_spec *out, char *err, size_t errlen)
{
	struct flash_link_spec s;

	if (!spec || !out)
		return refuse(err, errlen, "no link given (%s)", SPELLINGS);
	memset(&s, 0, sizeof(s));
	s.node = -1;
	s.udp_port = SWELL_UDP_PORT_CLIENTS;
	s.usb_vid = SWELL_USB_VID;
	s.usb_pid = SWELL_USB_PID;
	if (!strcmp(spec, "udp") || !strncmp(spec, "udp:", 4)) {
		s.kind = FLASH_LINK_UDP;
		if (spec[3]) {
			char *end;
			long port;

			errno = 0;
			port = strtol(spec + 4, &end, 10);
			if (errno || !spec[4] || *end || port < 1 || port > 65535 || spec[4] == '+' || spec[4] == '-')
				return refuse(err, errlen, "'%s': UDP port not in 1..65535", spec);
			s.udp_port = (uint16_t)port;
		}
	} else if (!strncmp(spec, "can:", 4)) {
		const char *ifn = spec + 4;
		size_t n = strlen(ifn);

		s.kind = FLASH_LINK_CAN;
		if (n == 0)
			return refuse(err, errlen, "'%s': give the CAN interface, e.g. can:can0", spec);
		if (n >= FLASH_LINK_IFNAME_MAX)
			return refuse(err, errlen, "'%s': interface name longer than 15 characters", spec);
		/* what the kernel takes as an interface name (dev_valid_name): no '/', ':' or space */
		if (strpbrk(ifn, "/: \t\n,") || !strcmp(ifn, ".") || !strcmp(ifn, ".."))
			return refuse(err, errlen, "'%s': not an interface name (the node is chosen with --node)",
				      spec);
		memcpy(s.can_if, ifn, n + 1);
	} else if (!strncmp(spec, "canfd:", 6)) {
		return refuse(err, errlen,
			      "'%s': the controller's host link is classic CAN (swell-ctl --host can:IFACE, the "
			      "F405's bxCAN): use can:IFACE",
			      spec);
	} else if (!strcmp(spec, "usb") || !strncmp(spec, "usb:", 4)) {
		s.kind = FLASH_LINK_USB;
		if (spec[3]) {
			const char *a = spec + 4, *colon = strchr(a, ':');

			if (!colon || hex16(a, (size_t)(colon - a), &s.usb_vid) ||
			    hex16(colon + 1, strlen(colon + 1), &s.usb_pid))
				return refuse(
					err, errlen,
					"'%s': not usb:VID:PID in hex (usb:FFS_DIR is swell-ctl's side of the link)",
					spec);
		}
	} else {
		return refuse(err, errlen, "'%s': not a host link: " SPELLINGS, spec);
	}
	*out = s;
	return 0;
}

void flash_link_describe(const struct flash_link_spec *s, char *buf, size_t len)
{
	switch (s->kind) {
	case FLASH_LINK_UDP:
		snprintf(buf, len, "udp %s:%u", SWELL_UDP_HOST, (unsigned)s->udp_port);
		return;
	case FLASH_LINK_CAN:
		snprintf(buf, len, "can %s", s->can_if);
		return;
	case FLASH_LINK_USB:
		snprintf(buf, len, "usb %04x:%04x interface %u", s->usb_vid, s->usb_pid, (unsigned)s->usb_iface);
		return;
	}
	snprintf(buf, len, "?");
}

int flash_link_open(const struct flash_link_spec *s, int wait_ms, struct swell_link **out)
{
	uint64_t end = swell_link_now_ns() + (uint64_t)(wait_ms > 0 ? wait_ms : 0) * 1000000u;

	switch (s->kind) {
	case FLASH_LINK_UDP:
		for (unsigned k = 0; k < SWELL_UDP_PORT_TOOLS_COUNT; k++) {
			int rc = swell_link_open_udp(out, SWELL_UDP_HOST, (uint16_t)(SWELL_UDP_PORT_TOOLS_FIRST + k),
						     SWELL_UDP_HOST, s->udp_port);

			if (rc != -EADDRINUSE)
				return rc;
		}
		return swell_link_open_udp(out, SWELL_UDP_HOST, 0, SWELL_UDP_HOST, s->udp_port);
	case FLASH_LINK_CAN: {
		struct swell_can_opts o;

		memset(&o, 0, sizeof(o)); /* classic frames, every id: other nodes are told apart by decoding */
		return swell_link_open_can(out, s->can_if, &o);
	}
	case FLASH_LINK_USB:
		for (;;) {
			struct swell_usb_opts o;
			struct timespec d = { 0, 100000000 };
			int rc;

			swell_usb_opts_default(&o);
			o.vid = s->usb_vid;
			o.pid = s->usb_pid;
			o.iface = s->usb_iface;
			rc = swell_link_open_usb(out, &o);
			if (rc != -ENODEV || swell_link_now_ns() >= end)
				return rc;
			nanosleep(&d, NULL);
		}
	}
	return -EINVAL;
}

int flash_link_keepalive(struct swell_link *l, int node, uint64_t *due_ns)
{
	const uint64_t now = swell_link_now_ns(), period = (uint64_t)SWELL_UDP_KEEPALIVE_MS * 1000000u;
	struct swell_msg hb;
	int k;

	if (!swell_link_udp_port(l))
		return -1;
	if (now < *due_ns)
		return (int)((*due_ns - now + 999999u) / 1000000u);
	memset(&hb, 0, sizeof(hb));
	hb.type = SWELL_MSG_HEARTBEAT;
	hb.u.heartbeat.version = SWELL_PROTO_VERSION;
	for (k = node < 0 ? 0 : node; k <= (node < 0 ? 15 : node); k++) {
		struct swell_frame f;
		size_t used;

		hb.node = (uint8_t)k;
		if (swell_link_encode(SWELL_CARRIER_PKT, (uint8_t)k, 0, &hb, 1, &f, &used) == SWELL_OK)
			(void)swell_link_send(l, &f); /* a lost one: the next comes in a second */
	}
	/* until the controller is heard, every 100 ms: one that starts after the tool admits it at once */
	*due_ns = now + (node < 0 ? period / 10u : period);
	return node < 0 ? (int)SWELL_UDP_KEEPALIVE_MS / 10 : (int)SWELL_UDP_KEEPALIVE_MS;
}
