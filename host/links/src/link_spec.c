/* Link specs: see swell/link_spec.h. */
#include "swell/link_spec.h"

#include <arpa/inet.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/transport.h"

static const char *const spellings[SWELL_LINK_KINDS] = {
	[SWELL_LINK_UDP] = "udp[:PORT]",
	[SWELL_LINK_CAN] = "can:IFACE",
	[SWELL_LINK_CANFD] = "canfd:IFACE",
	[SWELL_LINK_USB] = "usb[:VID:PID]",
	[SWELL_LINK_FFS] = "usb:FFS_DIR",
	[SWELL_LINK_HM] = "hm:HOST[:PORT]",
	[SWELL_LINK_REPLAY] = "replay:FILE or replay-fast:FILE",
};

static int refuse(char *err, size_t len, const char *text, const char *why)
{
	snprintf(err, len, "'%s': %s", text, why);
	return -1;
}

/* A decimal number in lo..65535 of exactly n characters, no sign, nothing else. */
static int port_of(const char *s, size_t n, long lo, uint16_t *port)
{
	long v = n >= 1 && n <= 5 && strspn(s, "0123456789") >= n ? strtol(s, NULL, 10) : -1;

	if (v < lo || v > 65535)
		return -1;
	*port = (uint16_t)v;
	return 0;
}

/* "[ADDR:]PORT" (ADDR a dotted IPv4 address, 127.0.0.1 when left out). */
static int addr_of(const char *s, long lo, struct sockaddr_in *a)
{
	const char *colon = strrchr(s, ':');
	char host[16];
	uint16_t port;

	memset(a, 0, sizeof(*a));
	a->sin_family = AF_INET;
	a->sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (colon) {
		if ((size_t)(colon - s) >= sizeof(host))
			return -1;
		memcpy(host, s, (size_t)(colon - s));
		host[colon - s] = '\0';
		if (inet_pton(AF_INET, host, &a->sin_addr) != 1)
			return -1;
		s = colon + 1;
	}
	if (port_of(s, strlen(s), lo, &port))
		return -1;
	a->sin_port = htons(port);
	return 0;
}

/* 1 to 4 hex digits, nothing else. */
static int hex16(const char *s, size_t n, uint16_t *v)
{
	if (n < 1 || n > 4 || strspn(s, "0123456789abcdefABCDEF") < n)
		return -1;
	*v = (uint16_t)strtoul(s, NULL, 16);
	return 0;
}

static int parse_udp(const char *text, const char *arg, unsigned accept, struct swell_link_spec *s, char *err,
		     size_t len)
{
	const char *comma = (accept & (SWELL_LINK_ACCEPT_PEER | SWELL_LINK_ACCEPT_LISTEN)) ? strchr(arg, ',') : NULL;
	size_t plen = comma ? (size_t)(comma - arg) : strlen(arg);

	if (*arg == ':') {
		if (port_of(arg + 1, plen - 1, 1, &s->port))
			return refuse(err, len, text, "UDP port not in 1..65535");
		s->port_given = 1;
	} else if (plen) {
		return -2; /* "udpx": not this kind */
	}
	if (!comma)
		return 0;
	if ((accept & SWELL_LINK_ACCEPT_PEER) && !strncmp(comma, ",peer=", 6) && !addr_of(comma + 6, 1, &s->peer)) {
		s->have_peer = 1;
		return 0;
	}
	if ((accept & SWELL_LINK_ACCEPT_LISTEN) && !strncmp(comma, ",listen=", 8) &&
	    !addr_of(comma + 8, 0, &s->listen_at)) {
		s->have_listen = 1;
		return 0;
	}
	return refuse(err, len, text,
		      accept & SWELL_LINK_ACCEPT_PEER ? "the option is not peer=ADDR:PORT (the device's address)"
						      : "the option is not listen=[ADDR:]PORT (the clients' port)");
}

static int parse_can(const char *text, const char *ifn, struct swell_link_spec *s, char *err, size_t len)
{
	size_t n = strlen(ifn);

	if (n == 0)
		return refuse(err, len, text, "give the CAN interface, e.g. can:can0");
	if (n >= SWELL_LINK_IFNAME_MAX)
		return refuse(err, len, text, "interface name longer than 15 characters");
	/* what the kernel takes as an interface name (dev_valid_name): no '/', ':' or space */
	if (strpbrk(ifn, "/: \t\n,") || !strcmp(ifn, ".") || !strcmp(ifn, ".."))
		return refuse(err, len, text, "not an interface name (the node is chosen with --node)");
	memcpy(s->name, ifn, n + 1);
	return 0;
}

/* "usb", "usb:VID:PID" (libusb) or "usb:DIR" (FunctionFS, where libusb is not accepted). */
static int parse_usb(const char *text, const char *arg, unsigned accept, struct swell_link_spec *s, char *err,
		     size_t len)
{
	const char *colon;

	if (*arg && *arg != ':')
		return -2;
	if (!(accept & SWELL_LINK_ACCEPT(SWELL_LINK_USB))) {
		if (!*arg || !arg[1])
			return refuse(err, len, text, "give the FunctionFS mount, e.g. usb:/dev/ffs-swell");
		s->kind = SWELL_LINK_FFS;
		snprintf(s->name, sizeof(s->name), "%s", arg + 1);
		return 0;
	}
	s->kind = SWELL_LINK_USB;
	if (!*arg)
		return 0;
	arg++;
	colon = strchr(arg, ':');
	if (!colon || hex16(arg, (size_t)(colon - arg), &s->vid) || hex16(colon + 1, strlen(colon + 1), &s->pid))
		return refuse(err, len, text, "not usb:VID:PID in hex (usb:FFS_DIR is swell-ctl's side of the link)");
	return 0;
}

/* kind "name:" followed by at least one character; 1 when text has the prefix. */
static int prefixed(const char *text, const char *prefix, const char **rest)
{
	size_t n = strlen(prefix);

	if (strncmp(text, prefix, n))
		return 0;
	*rest = text + n;
	return 1;
}

static int unknown(const char *text, unsigned accept, char *err, size_t len)
{
	char list[200] = "";
	size_t used = 0;
	int k;

	for (k = 0; k < SWELL_LINK_KINDS; k++)
		if (accept & SWELL_LINK_ACCEPT(k) && used < sizeof(list))
			used += (size_t)snprintf(list + used, sizeof(list) - used, "%s%s", used ? ", " : "",
						 spellings[k]);
	snprintf(err, len, "'%s': not a link: %s", text, list);
	return -1;
}

int swell_link_spec_parse(const char *text, unsigned accept, uint16_t udp_port, struct swell_link_spec *out, char *err,
			  size_t errlen)
{
	struct swell_link_spec s;
	const char *rest;
	int rc = -2;

	if (!text || !out)
		return unknown("", accept, err, errlen);
	if (strlen(text) >= sizeof(s.name)) {
		snprintf(err, errlen, "'%.32s...': longer than 255 characters", text);
		return -1;
	}
	memset(&s, 0, sizeof(s));
	s.port = udp_port;
	s.vid = SWELL_USB_VID;
	s.pid = SWELL_USB_PID;
	if (prefixed(text, "udp", &rest) && (accept & SWELL_LINK_ACCEPT(SWELL_LINK_UDP))) {
		s.kind = SWELL_LINK_UDP;
		rc = parse_udp(text, rest, accept, &s, err, errlen);
	} else if (prefixed(text, "can:", &rest) && (accept & SWELL_LINK_ACCEPT(SWELL_LINK_CAN))) {
		s.kind = SWELL_LINK_CAN;
		rc = parse_can(text, rest, &s, err, errlen);
	} else if (prefixed(text, "canfd:", &rest) && (accept & SWELL_LINK_ACCEPT(SWELL_LINK_CANFD))) {
		s.kind = SWELL_LINK_CANFD;
		rc = parse_can(text, rest, &s, err, errlen);
	} else if (prefixed(text, "canfd:", &rest) && (accept & SWELL_LINK_ACCEPT(SWELL_LINK_CAN))) {
		rc = refuse(err, errlen, text,
			    "swell's controller links are classic CAN (swell-ctl's can:IFACE, the F405's bxCAN): use "
			    "can:IFACE");
	} else if (prefixed(text, "usb", &rest) &&
		   (accept & (SWELL_LINK_ACCEPT(SWELL_LINK_USB) | SWELL_LINK_ACCEPT(SWELL_LINK_FFS)))) {
		rc = parse_usb(text, rest, accept, &s, err, errlen);
	} else if (prefixed(text, "hm:", &rest) && (accept & SWELL_LINK_ACCEPT(SWELL_LINK_HM))) {
		s.kind = SWELL_LINK_HM;
		rc = *rest ? 0 : refuse(err, errlen, text, "want hm:HOST[:PORT]");
		snprintf(s.name, sizeof(s.name), "%s", rest);
	} else if ((prefixed(text, "replay:", &rest) || prefixed(text, "replay-fast:", &rest)) &&
		   (accept & SWELL_LINK_ACCEPT(SWELL_LINK_REPLAY))) {
		s.kind = SWELL_LINK_REPLAY;
		s.realtime = text[6] == ':';
		rc = *rest ? 0 : refuse(err, errlen, text, "give the recording, e.g. replay:run.rec");
		snprintf(s.name, sizeof(s.name), "%s", rest);
	}
	if (rc == -2)
		return unknown(text, accept, err, errlen);
	if (rc == 0)
		*out = s;
	return rc;
}

void swell_link_spec_describe(const struct swell_link_spec *s, char *buf, size_t len)
{
	static const char *const words[SWELL_LINK_KINDS] = { "udp", "can", "canfd", "usb", "usb", "hm", "replay" };

	if (s->kind == SWELL_LINK_UDP)
		snprintf(buf, len, "udp %s:%u", SWELL_UDP_HOST, (unsigned)s->port);
	else if (s->kind == SWELL_LINK_USB)
		snprintf(buf, len, "usb %04x:%04x interface %u", s->vid, s->pid, (unsigned)s->iface);
	else
		snprintf(buf, len, "%s %s", words[s->kind < SWELL_LINK_KINDS ? s->kind : SWELL_LINK_REPLAY], s->name);
}
