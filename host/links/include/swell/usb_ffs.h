/* USB device side through Linux FunctionFS: one vendor interface with one bulk OUT and one bulk IN
 * endpoint, the shape of the controller's USB link (full speed, 64-byte packets).
 *
 * The gadget itself (VID/PID, configuration, UDC binding) is set up in configfs by the caller; this
 * module owns what FunctionFS owns: the descriptors and strings written to ep0, the ep0 events, and
 * the two data endpoints. No allocation; all storage is in struct swell_usb_ffs.
 *
 * Life cycle: swell_usb_ffs_open() (descriptors written: the function can now be bound to a UDC),
 * then swell_usb_ffs_poll() for events; after SWELL_USB_FFS_ENABLE, swell_usb_ffs_read() and
 * swell_usb_ffs_write() move packets until SWELL_USB_FFS_DISABLE or a read/write fails with
 * SWELL_ESTATE (host disabled the configuration or unplugged); swell_usb_ffs_close() at the end.
 *
 * Nothing here blocks after open: FunctionFS data endpoints cannot be poll()ed and a plain read()
 * waits until the host sends, so transfers go through Linux AIO. One OUT transfer is always
 * queued; read() takes a finished one or returns at once with *len = 0. write() queues up to
 * SWELL_USB_FFS_TX_SLOTS IN transfers. To sleep until something happens, poll() both
 * f->ep0 (events) and swell_usb_ffs_data_fd(f) (a transfer finished). */
#ifndef SWELL_USB_FFS_H
#define SWELL_USB_FFS_H

#include <linux/aio_abi.h>
#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"

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

enum swell_usb_ffs_event {
	SWELL_USB_FFS_NONE = 0, /* nothing happened before the timeout */
	SWELL_USB_FFS_BIND,
	SWELL_USB_FFS_UNBIND,
	SWELL_USB_FFS_ENABLE, /* configuration set: data endpoints are open */
	SWELL_USB_FFS_DISABLE, /* configuration cleared or bus reset: data endpoints are closed */
	SWELL_USB_FFS_SETUP, /* a control request to the interface: answered with a stall */
	SWELL_USB_FFS_SUSPEND,
	SWELL_USB_FFS_RESUME
};

struct swell_usb_ffs {
	int ep0; /* file descriptors, -1 when closed */
	int ep_out;
	int ep_in;
	int efd; /* eventfd: readable when a transfer finished */
	int last_errno; /* errno of the last failed system call, 0 if none */
	uint32_t setup_stalled; /* control requests answered with a stall */
	uint32_t tx_busy_drops; /* writes refused because every IN slot was in flight */
	/* AIO state: private */
	aio_context_t ctx;
	struct iocb rx_cb;
	struct iocb tx_cb[SWELL_USB_FFS_TX_SLOTS];
	int64_t rx_res; /* result of the finished OUT transfer */
	uint16_t rx_packet; /* OUT wMaxPacketSize at the connected speed: one packet a read */
	uint8_t rx_state; /* 0 idle, 1 queued, 2 finished */
	uint8_t tx_queued[SWELL_USB_FFS_TX_SLOTS];
	uint8_t link_lost; /* a transfer ended with an error: endpoints are going away */
	uint8_t rx_buf[SWELL_USB_FFS_XFER_MAX];
	uint8_t tx_buf[SWELL_USB_FFS_TX_SLOTS][SWELL_USB_FFS_XFER_MAX];
	char dir[SWELL_USB_FFS_PATH_MAX];
};

/* The FunctionFS v2 descriptor block (full- and high-speed sets: interface + bulk OUT + bulk IN,
 * OUT first so it is file ep1 and IN is ep2) and the string block (language 0x0409, one string),
 * little-endian as ep0 expects. Pure: usable and testable anywhere. */
enum swell_err swell_usb_ffs_descriptors(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap,
					 size_t *len);
enum swell_err swell_usb_ffs_strings(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap, size_t *len);

/* Open DIR/ep0 of a mounted FunctionFS instance and write the descriptors and strings. A rejected
 * argument (SWELL_EINVAL, SWELL_ERANGE, SWELL_ESIZE) leaves *f untouched; when the system refuses
 * (SWELL_ESTATE, SWELL_ETRUNC: errno in last_errno) nothing stays open. */
enum swell_err swell_usb_ffs_open(struct swell_usb_ffs *f, const char *dir, const struct swell_usb_ffs_iface *iface);

/* Wait up to timeout_ms (-1: forever, 0: don't wait) for one ep0 event and act on it: ENABLE opens
 * the data endpoints, DISABLE and UNBIND close them, SETUP is stalled. *ev tells what happened. */
enum swell_err swell_usb_ffs_poll(struct swell_usb_ffs *f, int timeout_ms, enum swell_usb_ffs_event *ev);

/* 1 when the data endpoints are open (after ENABLE, before DISABLE). */
int swell_usb_ffs_enabled(const struct swell_usb_ffs *f);

/* File descriptor that becomes readable when a data transfer finishes (-1 before open). */
int swell_usb_ffs_data_fd(const struct swell_usb_ffs *f);

/* Never wait. read: the next received OUT transfer, up to cap bytes (a longer one is cut to cap),
 * *len = 0 when none has arrived. write: queue one IN transfer of len <= SWELL_USB_FFS_XFER_MAX
 * bytes; SWELL_ESIZE when every slot is still in flight (counted in tx_busy_drops), nothing queued.
 * Both: SWELL_ESTATE when the endpoints are not enabled or the host went away (errno in
 * last_errno); the DISABLE event follows on ep0. */
enum swell_err swell_usb_ffs_read(struct swell_usb_ffs *f, uint8_t *buf, size_t cap, size_t *len);
enum swell_err swell_usb_ffs_write(struct swell_usb_ffs *f, const uint8_t *buf, size_t len);

/* Close every open file. Safe to call twice. */
void swell_usb_ffs_close(struct swell_usb_ffs *f);

#endif
