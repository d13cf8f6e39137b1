/* The USB/IP server side for the OTG FS model (otgfs.h): the protocol of the Linux kernel's
 * Documentation/usb/usbip_protocol.rst (version 0x0111, big-endian) on a connected byte stream,
 * turning URBs into the model's host-side transactions.
 *
 *   OP_REQ_IMPORT  -> the server enumerates the device itself (bus reset, GET_DESCRIPTOR device,
 *                     SET_ADDRESS, GET_DESCRIPTOR configuration), as a USB/IP host's own stack
 *                     would have done before exporting it, then answers OP_REP_IMPORT
 *   OP_REQ_DEVLIST -> OP_REP_DEVLIST with the one device (enumerated the same way)
 *   USBIP_CMD_SUBMIT -> control transfers on endpoint 0 (SETUP, data stage, status stage) and bulk
 *                     transfers on the others (64-byte packets; an IN transfer ends at a short
 *                     packet or a full buffer; URB_ZERO_PACKET adds the zero-length packet), one
 *                     transfer at a time per endpoint and direction, answered by USBIP_RET_SUBMIT
 *                     (status 0, -EPIPE on a STALL, -EPROTO when the device does not answer)
 *   USBIP_CMD_UNLINK -> USBIP_RET_UNLINK: -ECONNRESET and no RET_SUBMIT when the URB was still
 *                     pending, 0 when it had already been answered
 * A device that leaves the bus after the import (its pull-up off: DCTL.SDIS, a core reset, the
 * clock stopped) ends the session (USBIP_CLOSED): USB/IP has no message for an unplug, and the
 * importing host takes the connection's end as one. The other way round, a session that ends (the
 * peer closed, or a protocol error) pulls the cable (otgfs_host_unplug: the device's suspend 6 ms
 * later). The caller closes the fd and may accept the next connection with a fresh server, which
 * enumerates the device again once it is back (its bus reset plugs the cable in).
 * A NAK is retried at the next step: the caller (the emulator's loop) runs the CPU in between and
 * calls usbip_server_step again soon while it returns USBIP_BUSY. Nothing is allocated: struct
 * usbip_server is the whole state. */
#ifndef SWELL_MCU_USBIP_H
#define SWELL_MCU_USBIP_H

#include <stddef.h>
#include <stdint.h>

#include "otgfs.h"

#ifdef __cplusplus
extern "C" {
#endif

#define USBIP_VERSION 0x0111u
#define USBIP_OP_REQ_DEVLIST 0x8005u
#define USBIP_OP_REP_DEVLIST 0x0005u
#define USBIP_OP_REQ_IMPORT 0x8003u
#define USBIP_OP_REP_IMPORT 0x0003u
#define USBIP_CMD_SUBMIT 1u
#define USBIP_CMD_UNLINK 2u
#define USBIP_RET_SUBMIT 3u
#define USBIP_RET_UNLINK 4u
#define USBIP_DIR_OUT 0u
#define USBIP_DIR_IN 1u
#define USBIP_URB_ZERO_PACKET 0x40u

#define USBIP_HDR_LEN 48u /* every URB header, padded to the same length */
#define USBIP_OP_HDR_LEN 8u
#define USBIP_BUSID_LEN 32u
#define USBIP_DEV_LEN 312u /* the device record of OP_REP_IMPORT / OP_REP_DEVLIST */
#define USBIP_XFER_MAX 4096u /* largest transfer buffer a URB may have here */
#define USBIP_URBS_MAX 16u /* URBs pending at once */
#define USBIP_BUSID "1-1"
#define USBIP_BUSNUM 1u

/* Linux errno values as RET_SUBMIT / RET_UNLINK carry them. */
#define USBIP_EPIPE (-32)
#define USBIP_EPROTO (-71)
#define USBIP_EOVERFLOW (-75)
#define USBIP_ECONNRESET (-104)
#define USBIP_ESHUTDOWN (-108)

/* A URB header (usbip_header_basic and its command's fields), host byte order. */
struct usbip_hdr {
	uint32_t command, seqnum, devid, direction, ep;
	union {
		struct {
			uint32_t flags, length, start_frame, number_of_packets, interval;
			uint8_t setup[8];
		} submit;
		struct {
			int32_t status;
			uint32_t actual_length, start_frame, number_of_packets, error_count;
		} ret_submit;
		struct {
			uint32_t seqnum;
		} unlink;
		struct {
			int32_t status;
		} ret_unlink;
	} u;
};

/* The device record of OP_REP_IMPORT and OP_REP_DEVLIST. */
struct usbip_dev {
	char path[256], busid[USBIP_BUSID_LEN];
	uint32_t busnum, devnum, speed; /* speed: 2 full (enum usb_device_speed) */
	uint16_t id_vendor, id_product, bcd_device;
	uint8_t dev_class, dev_subclass, dev_protocol, config_value, num_configs, num_interfaces;
};

/* Codec: 48 bytes each way; decode returns 0, or -1 for an unknown command (h untouched). */
void usbip_hdr_encode(const struct usbip_hdr *h, uint8_t out[USBIP_HDR_LEN]);
int usbip_hdr_decode(const uint8_t in[USBIP_HDR_LEN], struct usbip_hdr *h);
void usbip_dev_encode(const struct usbip_dev *d, uint8_t out[USBIP_DEV_LEN]);
int usbip_dev_decode(const uint8_t in[USBIP_DEV_LEN], struct usbip_dev *d);
/* OP header: version, code, status. */
void usbip_op_encode(uint16_t code, uint32_t status, uint8_t out[USBIP_OP_HDR_LEN]);
void usbip_op_decode(const uint8_t in[USBIP_OP_HDR_LEN], uint16_t *version, uint16_t *code, uint32_t *status);

enum usbip_step {
	USBIP_IDLE = 0, /* nothing pending: wait for the fd to be readable */
	USBIP_BUSY, /* transfers wait on the device (NAK) or replies on the fd: step again soon */
	USBIP_CLOSED, /* the peer closed, or sent what the protocol does not allow: close the fd */
};

struct usbip_urb {
	struct usbip_hdr h;
	uint32_t order; /* submission order */
	uint32_t actual;
	uint8_t in_use, internal; /* internal: the server's own enumeration request */
	uint8_t stage; /* control: 0 SETUP, 1 data, 2 status; bulk: 1 */
	uint8_t zlp_sent;
	uint32_t noresp;
	uint8_t buf[USBIP_XFER_MAX];
};

struct usbip_stats {
	uint32_t submits, unlinks, ret_submits, bytes_in, bytes_out;
	uint32_t errors; /* RET_SUBMITs with a status, of which: */
	uint32_t stalls, no_answers, babbles; /* -EPIPE, -EPROTO, -EOVERFLOW */
};

struct usbip_server {
	int fd;
	struct otgfs *dev;
	uint8_t address; /* the address the server gives the device */
	uint8_t bus_addr; /* the address transactions go to (0 until SET_ADDRESS) */
	uint8_t enumerated;
	int phase; /* 0 operations, 1 enumerating, 2 URBs */
	uint16_t op_pending; /* the OP request waiting for the enumeration */
	int enum_step;
	uint8_t ep0_mps;
	uint8_t dev_desc[18], cfg_head[9];
	uint8_t rx[USBIP_HDR_LEN + USBIP_XFER_MAX];
	uint32_t rx_len;
	uint8_t tx[4 * (USBIP_HDR_LEN + USBIP_XFER_MAX)];
	uint32_t tx_len;
	struct usbip_urb urbs[USBIP_URBS_MAX];
	uint32_t next_order;
	const char *error; /* why the server stopped (USBIP_CLOSED), or NULL */
	struct usbip_stats stats;
};

/* fd: a connected stream, made non-blocking here. address: 1..127, the device's USB address. */
void usbip_server_init(struct usbip_server *s, int fd, struct otgfs *dev, uint8_t address);
/* Read what the fd holds, move transfers on at virtual time now (the model's clock), write
 * replies. */
enum usbip_step usbip_server_step(struct usbip_server *s, uint64_t now);
/* Replies wait for the fd to take them (poll for POLLOUT). */
int usbip_server_wants_write(const struct usbip_server *s);
/* A URB, or the server's own enumeration, waits on the device (time must run for it to move on). */
int usbip_server_waiting(const struct usbip_server *s);

#ifdef __cplusplus
}
#endif

#endif
