/* USB device side through Linux FunctionFS: one vendor interface with one bulk OUT and one bulk IN
 * endpoint, the shape of the controller's USB link (full speed, 64-byte packets). The link on it is
 * swell_link_open_ffs (swell/link.h); this header has the interface it writes, the descriptor and
 * string blocks, and the link's counters.
 *
 * The gadget itself (VID/PID, configuration, UDC binding) is set up in configfs by the caller; the
 * link owns what FunctionFS owns: the descriptors and strings written to ep0, the ep0 events (ENABLE
 * opens the data endpoints, DISABLE and UNBIND close them, control requests are stalled) and the two
 * data endpoints. Nothing blocks after open: FunctionFS data endpoints cannot be poll()ed and a plain
 * read() waits until the host sends, so transfers go through Linux AIO. One OUT transfer is always
 * queued; up to SWELL_USB_FFS_TX_SLOTS IN transfers are in flight. No allocation after open. */
#ifndef SWELL_USB_FFS_H
#define SWELL_USB_FFS_H

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

struct swell_usb_ffs_stats {
	uint32_t setup_stalled; /* control requests answered with a stall */
	uint32_t tx_busy_drops; /* sends refused because every IN slot was in flight */
	int last_errno; /* errno of the last failed system call, 0 if none */
};

/* The FunctionFS v2 descriptor block (full- and high-speed sets: interface + bulk OUT + bulk IN,
 * OUT first so it is file ep1 and IN is ep2) and the string block (language 0x0409, one string),
 * little-endian as ep0 expects. Pure: usable and testable anywhere. A rejected iface (SWELL_EINVAL,
 * SWELL_ERANGE) or a buffer too small (SWELL_ESIZE) leaves *len untouched. */
enum swell_err swell_usb_ffs_descriptors(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap,
					 size_t *len);
enum swell_err swell_usb_ffs_strings(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap, size_t *len);

#endif
