/* The controller's links on Linux, the device link and the host link, on UDP, SocketCAN, USB
 * (FunctionFS) or, for the device, hm:. Built from the link library (docs/links.md, "swell-ctl's
 * links"); here is the controller's own: the node filter, the held USB answer, the zero force on exit. */
#ifndef SWELL_CTL_LINK_H
#define SWELL_CTL_LINK_H

#include <netinet/in.h>
#include <stddef.h>
#include <stdint.h>

#include "hm_client.h"
#include "hm_fx.h"
#include "swell/link.h"
#include "swell/link_peers.h"
#include "swell/proto.h"
#include "swell/transport.h"

enum ctl_link_kind {
	CTL_LINK_UDP,
	CTL_LINK_CAN,
	CTL_LINK_USB,
	CTL_LINK_HM
};

struct ctl_link {
	enum ctl_link_kind kind;
	int fd; /* UDP, CAN: the socket */
	struct swell_link *usb; /* USB: the FunctionFS link of the link library */
	struct swell_peers peers; /* UDP: who the device is (device link), who the clients are (host link) */
	struct sockaddr_in local; /* UDP: the address the socket is bound to */
	int clients_port_taken; /* host link: the default clients' port was taken, another one is bound */
	uint8_t node, seq;
	uint32_t unsent_run; /* sends in a row in which nothing reached the carrier though it had a destination */
	struct swell_proto_stats st;
	uint32_t frames_rx, frames_tx, tx_errors;
	uint32_t foreign; /* valid messages of another node: dropped, never acted on */
	struct swell_can_health can; /* CAN: error frames and bus state (the port compares bus_offs) */
	/* USB: a packet with a parameter answer that found every IN slot busy (telemetry the host has
	 * not read yet) is held and sent first next time, not dropped: an answer is asked for once */
	struct swell_frame held; /* len 0: none */
	uint32_t answers_held, answers_dropped;
	struct hm_client hm; /* hm: a HapticMaster on its TCP command interface (device side only) */
	struct hm_fx hmfx; /* hm: the effect sets as the HapticMaster's own effects (effect mode) */
	uint32_t hm_refusal_seen; /* hm: the start-up refusal last printed (hm.refusal_seq) */
	char name[48];
};

/* spec, in swell/link_spec.h's spellings: udp[:PORT] (device link: listen there, default 47800,
 * ",peer=" fixes the device; host link: telemetry there, default 47801, clients on ",listen=", default
 * 127.0.0.1:47802 or any free port when that one is taken: l->clients_port_taken), can:IFACE,
 * usb:FFS_DIR, hm:HOST[:PORT] (device link only). Returns 0, -2 for a spec that is not one of these
 * (nothing opened), -1 when the system refused; either way a one-line reason is in err. */
int ctl_link_open(struct ctl_link *l, const char *spec, int device_side, uint8_t node, char *err, size_t errlen);

/* The file descriptor to poll for input (-1 if none). */
int ctl_link_fd(const struct ctl_link *l);

/* Read one frame or packet if one is waiting (never blocks); decoded messages go to out.
 * Returns the number of messages (0 when nothing was waiting or the frame was rejected).
 * CAN error frames update l->can (a port acts on a rise of l->can.bus_offs: every bus-off counts,
 * even one that a restart in the same read burst has ended). While the bus is off, data frames are
 * counted in l->can.dropped_off and dropped: a controller off the bus hears nothing. */
size_t ctl_link_recv(struct ctl_link *l, struct swell_msg *out, size_t cap);

/* Send messages: packed into as few packets as fit (UDP, USB) or one CAN frame each. */
void ctl_link_send(struct ctl_link *l, const struct swell_msg *m, size_t n);

/* The same, one message at a time, each tried again every millisecond for up to wait_ms while the
 * carrier refuses it (a full CAN TX queue, every USB IN slot in flight, a full socket buffer): for the
 * zero force on exit, which has no next tick to send a fresher value. 0 when every message went out;
 * only a message that never did counts in tx_errors. Blocks: never on the tick path. On hm: the
 * effect mode's effects are removed too, and the device confirms both (hm_client_zero_wait). */
int ctl_link_send_wait(struct ctl_link *l, const struct swell_msg *m, size_t n, int wait_ms);

/* A device declared lost is let go with swell_peers_release(&l->peers) (UDP only: on CAN and USB the
 * peer is the bus node or the USB host); the host link's clients are swell_peers_clients(&l->peers). */

void ctl_link_close(struct ctl_link *l);

#endif
