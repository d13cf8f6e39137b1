/* swell links: one small interface over SocketCAN, libusb, FunctionFS, UDP and recordings, for the
 * host programs and swell-ctl (docs/links.md). A link moves frames: CAN (classic or FD) or packets
 * (USB bulk, UDP), up to 64 bytes. Functions returning int give 0 or a negative errno: -ETIMEDOUT when
 * a receive timed out, -ENODATA at the end of a replay, -ENODEV while a USB device is unplugged. */
#ifndef SWELL_LINK_H
#define SWELL_LINK_H

#include <linux/can.h>
#include <stddef.h>
#include <stdint.h>

#include "swell/link_spec.h"
#include "swell/proto.h"

#define SWELL_LINK_MTU 64u

enum swell_carrier {
	SWELL_CARRIER_CAN, /* classic CAN: one message per frame */
	SWELL_CARRIER_CANFD, /* CAN FD: messages of one type per frame */
	SWELL_CARRIER_PKT, /* USB bulk or UDP: swell packets with CRC */
};

#define SWELL_FRAME_FD 0x01u /* CAN FD frame (send with bit-rate switch) */
#define SWELL_FRAME_EFF 0x02u /* received with a 29-bit identifier (never a swell frame) */

struct swell_frame {
	uint64_t t_ns; /* receive time, CLOCK_MONOTONIC; on replay the recorded time since its start */
	uint32_t id; /* CAN identifier; 0 for packets */
	uint16_t len;
	uint8_t flags; /* SWELL_FRAME_* */
	uint8_t data[SWELL_LINK_MTU];
};

struct swell_link_counters {
	uint64_t tx_frames, tx_bytes, tx_errors;
	uint64_t rx_frames, rx_bytes, rx_errors; /* rx_errors: failed reads */
	uint64_t rx_timeouts;
	uint64_t rx_dropped; /* oversized datagrams, remote frames, CAN frames heard while bus-off */
	uint64_t bus_errors; /* CAN error frames received (the bus state: swell_link_can_health) */
	uint64_t reconnects; /* USB device opened again after an unplug */
};

struct swell_link;

int swell_link_send(struct swell_link *l, const struct swell_frame *f);
/* timeout_ms < 0 waits for ever, 0 only takes what is already there. */
int swell_link_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms);
void swell_link_close(struct swell_link *l);
const struct swell_link_counters *swell_link_get_counters(const struct swell_link *l);
enum swell_carrier swell_link_carrier(const struct swell_link *l);
const char *swell_link_name(const struct swell_link *l);
/* The descriptor that poll() reports readable when input may be waiting; -1 for a link that has none
 * to offer (only the FunctionFS link offers one: ep0 until enabled, then the transfers' eventfd). */
int swell_link_poll_fd(const struct swell_link *l);
/* CLOCK_MONOTONIC in ns: the clock of swell_frame.t_ns. */
uint64_t swell_link_now_ns(void);

/* UDP: bind to bind_host:bind_port (port 0: any free port) and send to peer_host:peer_port, hearing
 * only datagrams from there (others count in rx_dropped); with peer_host NULL, send to whoever sent
 * the last datagram. Hosts are dotted IPv4 ("127.0.0.1"). */
int swell_link_open_udp(struct swell_link **out, const char *bind_host, uint16_t bind_port, const char *peer_host,
			uint16_t peer_port);
/* The local port actually bound (useful after binding port 0); 0 if l is not a UDP link. */
uint16_t swell_link_udp_port(const struct swell_link *l);

/* The UDP socket calls of the link above and of swell-ctl's links (swell/link_peers.h on top). */
/* A datagram socket bound to *at (port 0: any free port; when the port is taken and any_if_taken, any
 * free port of the same address, with *taken set to 1), close-on-exec, non-blocking when nonblock, with
 * a receive queue deep enough for a burst of a few thousand small datagrams. *bound gets the address
 * bound. The descriptor, or a negative errno with nothing left open. */
int swell_udp_socket(const struct sockaddr_in *at, int nonblock, int any_if_taken, int *taken,
		     struct sockaddr_in *bound);
/* One datagram from anyone into buf, waiting up to timeout_ms (< 0: for ever; 0: only what is there).
 * Its whole length (more than cap when it did not fit: never a swell packet), -ETIMEDOUT, or a
 * negative errno. */
long swell_udp_recv(int fd, void *buf, size_t cap, struct sockaddr_in *from, int timeout_ms);
/* 0 when all len bytes went to *to, else a negative errno (-EIO for a short send). */
int swell_udp_send(int fd, const struct sockaddr_in *to, const void *p, size_t len);
int swell_udp_same(const struct sockaddr_in *a, const struct sockaddr_in *b);

struct swell_can_filter {
	uint32_t id, mask; /* accept when (frame_id & mask) == (id & mask) */
};
struct swell_can_opts {
	uint32_t bitrate; /* set through libsocketcan (needs CAP_NET_ADMIN); 0: leave as is */
	int fd; /* 1: CAN FD frames (the interface must be in FD mode) */
	int error_frames; /* 1: receive error frames and count them in bus_errors */
	uint32_t error_mask; /* with error_frames: the classes (CAN_ERR_* of linux/can/error.h); 0: all */
	const struct swell_can_filter *filters; /* NULL: everything */
	size_t nfilters;
};
/* SocketCAN raw socket on ifname ("can0", "vcan0"). It reads with swell_can_read below: error frames
 * make its bus state, and while the bus is off it hands nothing up. */
int swell_link_open_can(struct swell_link **out, const char *ifname, const struct swell_can_opts *opts);
/* The raw socket of both sides (the link above and swell-ctl's CAN links): bound to ifname with opts'
 * frames, filters and error classes (bitrate is the link's), non-blocking when nonblock. The
 * descriptor, or a negative errno with nothing left open. */
int swell_can_socket(const char *ifname, const struct swell_can_opts *opts, int nonblock);

/* The CAN controller's fault confinement state, as the driver's error frames tell it. */
enum swell_can_state {
	SWELL_CAN_ACTIVE = 0,
	SWELL_CAN_WARNING,
	SWELL_CAN_PASSIVE,
	SWELL_CAN_BUS_OFF
};

/* What an error frame changed. */
enum swell_can_event {
	SWELL_CAN_EV_NONE = 0, /* counted, nothing to act on */
	SWELL_CAN_EV_STATE, /* warning / passive / back to active: counted and reported */
	SWELL_CAN_EV_BUS_OFF, /* the controller left the bus: nothing goes out or comes in */
	SWELL_CAN_EV_RESTARTED, /* back on the bus after a bus-off (restart-ms or a manual restart) */
};

struct swell_can_health {
	uint8_t state; /* enum swell_can_state */
	uint8_t tx_err, rx_err; /* the error counters of the last frame that carried them */
	uint32_t error_frames; /* every error frame read */
	uint32_t warnings, passives, bus_offs, restarts, actives; /* state changes into each state */
	uint32_t no_ack, prot, overflows, tx_timeouts, lost_arb, transceiver;
	uint32_t dropped_off; /* data frames that arrived while bus-off (dropped, never acted on) */
	uint32_t downs; /* the interface went down (a down/up restart leaves bus-off too) */
	uint8_t down_seen; /* ENETDOWN seen and no frame read or written since: one down, counted once */
};

/* Take one error frame (can_id carries CAN_ERR_FLAG; data the 8 bytes of linux/can/error.h) into h.
 * Pure: no I/O. Bus-off holds until a RESTARTED frame or a CRTL_ACTIVE one; a frame without
 * CAN_ERR_FLAG is refused (SWELL_CAN_EV_NONE, h untouched). */
enum swell_can_event swell_can_error_frame(struct swell_can_health *h, uint32_t can_id, const uint8_t data[8]);

const char *swell_can_state_name(enum swell_can_state s);
/* The bus state of a CAN link (swell_link_open_can); NULL for any other link. */
const struct swell_can_health *swell_link_can_health(const struct swell_link *l);

/* One frame of a raw CAN socket into f (never waits on a non-blocking one): its size for a data frame
 * (CAN_MTU, or CANFD_MTU on an FD socket), 0 for a frame that is not handed up, -1 when nothing was
 * read (errno says why; EIO for a read of another size). Error frames go into h. While the bus is off,
 * data frames are counted in h->dropped_off and dropped: a controller off the bus hears nothing. The
 * interface going down (ENETDOWN) counts in h->downs and ends a bus-off: brought up again it starts
 * error-active, and a down/up restart sends no RESTARTED frame. */
int swell_can_read(int fd, struct swell_can_health *h, struct canfd_frame *f);
/* What a socket operation on the interface said, into h: -ENETDOWN (the interface went down: the
 * kernel reports it once to the first read or write after it, and to every write while it stays
 * down) counts one down and ends a bus-off, as swell_can_read does; 0 (a frame went through) ends the
 * spell, so that the next ENETDOWN is a new down. Other values change nothing. The writers call it
 * with swell_can_write's result: a write that came first takes the report from the read. */
void swell_can_io_result(struct swell_can_health *h, int rc);
/* One frame written to a SocketCAN socket, never waiting: 0, or a negative errno (-ENOBUFS when the
 * transmit queue is full, -EMSGSIZE for an FD frame on a classic socket: fd_mode 0). The CAN link's
 * send waits for room; swell-ctl's tick drops instead, the next tick sends a fresher value. */
int swell_can_write(int fd, const struct swell_frame *f, int fd_mode);

struct swell_usb_opts {
	uint16_t vid, pid; /* SWELL_USB_VID / SWELL_USB_PID by default */
	int iface; /* interface number */
	uint8_t ep_out, ep_in; /* preferred; if the interface lacks them, its first bulk OUT / IN */
};
/* libusb bulk link. If the device is unplugged, send and receive return -ENODEV and the link
 * re-opens it (same VID/PID/interface) as soon as it is back, counting a reconnect. */
int swell_link_open_usb(struct swell_link **out, const struct swell_usb_opts *opts);
void swell_usb_opts_default(struct swell_usb_opts *o);

/* FunctionFS, the USB device's side: one vendor interface, one bulk OUT and one bulk IN endpoint (the
 * controller's USB link). The gadget (VID/PID, configuration, UDC) is the caller's, in configfs; the
 * link writes iface's descriptors and strings to DIR/ep0, acts on ep0's events (ENABLE opens the data
 * endpoints, DISABLE and UNBIND close them, control requests are stalled) and moves packets through
 * Linux AIO: one OUT transfer always queued, up to SWELL_USB_FFS_TX_SLOTS IN transfers in flight. */
#define SWELL_USB_FFS_PATH_MAX 96 /* FunctionFS mount directory, including the NUL */
#define SWELL_USB_FFS_NAME_MAX 63 /* interface string, ASCII, without the NUL */
#define SWELL_USB_FFS_DESC_MAX 80 /* bytes of the descriptor block (66 used) */
#define SWELL_USB_FFS_STR_MAX (18 + SWELL_USB_FFS_NAME_MAX + 1)
#define SWELL_USB_FFS_XFER_MAX 512 /* bytes of one transfer (a high-speed bulk packet) */
#define SWELL_USB_FFS_TX_SLOTS 4 /* IN transfers in flight */

struct swell_usb_ffs_iface {
	uint8_t class_code; /* 0xFF: vendor specific */
	uint8_t subclass;
	uint8_t protocol;
	uint8_t ep_out; /* bulk OUT address, 0x01..0x0F */
	uint8_t ep_in; /* bulk IN address, 0x81..0x8F */
	uint16_t fs_packet; /* full-speed wMaxPacketSize: 8, 16, 32 or 64 bytes (high speed: 512) */
	const char *name; /* interface string (iInterface), printable ASCII */
};

struct swell_usb_ffs_stats {
	uint32_t setup_stalled; /* control requests answered with a stall */
	uint32_t tx_busy_drops; /* sends refused because every IN slot was in flight */
	int last_errno; /* errno of the last failed system call, 0 if none */
};

/* The FunctionFS v2 descriptor block (full- and high-speed sets: interface + bulk OUT + bulk IN,
 * OUT first so it is file ep1 and IN is ep2) and the string block (language 0x0409, one string),
 * little-endian as ep0 expects. Pure. A rejected iface (SWELL_EINVAL, SWELL_ERANGE) or a buffer too
 * small (SWELL_ESIZE) leaves *len untouched. */
enum swell_err swell_usb_ffs_descriptors(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap,
					 size_t *len);
enum swell_err swell_usb_ffs_strings(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap, size_t *len);

/* Never waits for the host. Send: -ENODEV while the host has not enabled the interface (or is gone),
 * -EBUSY with every IN slot busy. Open: the system's errno (-ENOENT: no such mount), -EINVAL for a bad
 * iface, -ENAMETOOLONG. */
int swell_link_open_ffs(struct swell_link **out, const char *dir, const struct swell_usb_ffs_iface *iface);
/* The counters of a FunctionFS link, NULL for any other link. */
const struct swell_usb_ffs_stats *swell_link_ffs_stats(const struct swell_link *l);

/* Recording: a link that passes everything through to `inner` (which it then owns) and writes
 * every received frame with its time to path. */
int swell_link_open_record(struct swell_link **out, struct swell_link *inner, const char *path);
/* Replay of a recording: receive gives the recorded frames, paced as recorded (realtime = 1) or
 * as fast as possible (realtime = 0); send is refused (-EROFS). */
int swell_link_open_replay(struct swell_link **out, const char *path, int realtime);

/* ---- opening a parsed spec (swell/link_spec.h) on the host's side ---- */
struct swell_link_open_opts {
	const char *udp_host; /* the address bound and sent to; NULL: 127.0.0.1 */
	uint16_t udp_bind_port; /* 0: any free port */
	uint16_t udp_bind_tries; /* > 0: the first free of this many ports from udp_bind_port, else any free one */
	int udp_answer; /* 1: bind the spec's port and answer whoever sent last; 0: send to the spec's port */
	int can_errors; /* CAN: receive error frames (counted in bus_errors) */
	const struct swell_can_filter *can_filters; /* classic CAN: the ids taken (NULL: every id) */
	size_t can_nfilters;
	const struct swell_usb_ffs_iface *ffs_iface; /* FunctionFS: the interface written; NULL: refused */
};
/* UDP, CAN (classic frames; FD for canfd:), USB (libusb, the spec's VID, PID and interface),
 * FunctionFS (with ffs_iface) or a replay. 0 or a negative errno; -EINVAL for hm: (hm_client.h). */
int swell_link_open_spec(struct swell_link **out, const struct swell_link_spec *s,
			 const struct swell_link_open_opts *o);

/* ---- messages over a link's carrier ---- */
/* Packs as many of m[0..n) as one frame of the carrier takes (CAN: 1; CAN FD: same type; packet:
 * up to 64 bytes under node and pkt_seq). *used says how many went in. */
enum swell_err swell_link_encode(enum swell_carrier c, uint8_t node, uint8_t pkt_seq, const struct swell_msg *m,
				 size_t n, struct swell_frame *f, size_t *used);
/* Decodes a received frame; on packets *pkt_seq gets the packet sequence number (may be NULL).
 * cap >= SWELL_CANFD_MSGS_MAX takes any frame. Rejections are counted in st (may be NULL). */
enum swell_err swell_link_decode(enum swell_carrier c, const struct swell_frame *f, struct swell_msg *out, size_t cap,
				 size_t *n, uint8_t *pkt_seq, struct swell_proto_stats *st);

#endif
