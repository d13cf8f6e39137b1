/* The tools' link to a running controller; see swell/link_client.h. */
#define _GNU_SOURCE
#include "swell/link_client.h"

#include <errno.h>
#include <string.h>
#include <time.h>

#include "swell/link.h"
#include "swell/transport.h"

int swell_client_open(const struct swell_client_spec *s, int wait_ms, struct swell_link **out)
{
	uint64_t end = swell_link_now_ns() + (uint64_t)(wait_ms > 0 ? wait_ms : 0) * 1000000u;
	const struct swell_link_open_opts o = { .udp_bind_port = SWELL_UDP_PORT_TOOLS_FIRST,
						.udp_bind_tries = SWELL_UDP_PORT_TOOLS_COUNT };

	for (;;) {
		struct timespec d = { 0, 100000000 };
		int rc = swell_link_open_spec(out, &s->link, &o);

		if (rc != -ENODEV || s->link.kind != SWELL_LINK_USB || swell_link_now_ns() >= end)
			return rc;
		nanosleep(&d, NULL);
	}
}

int swell_client_keepalive(struct swell_link *l, int node, uint64_t *due_ns)
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
