/* The controller's links on Linux: the device link (HapticMaster) and the host link (viewer), each on
 * UDP (software in the loop), SocketCAN (classic CAN frames) or USB (a FunctionFS function: the
 * controller is the USB device, as the MCU is). Messages in and out are struct swell_msg; encoding,
 * decoding and the counting of bad frames are the protocol module's. */
#ifndef SWELL_CTL_LINK_H
#define SWELL_CTL_LINK_H

#include <netinet/in.h>
#include <stddef.h>
#include <stdint.h>

#include "swell/proto.h"
#include "usb_ffs.h"

enum ctl_link_kind { CTL_LINK_UDP, CTL_LINK_CAN, CTL_LINK_USB };

struct ctl_link {
	enum ctl_link_kind kind;
	int fd;
	struct sockaddr_in peer; /* UDP: where to send (host link: the viewer; device link: last sender) */
	int have_peer;
	uint8_t node, seq;
	struct swell_usb_ffs usb;
	int usb_up;
	struct swell_proto_stats st;
	uint32_t frames_rx, frames_tx, tx_errors;
	uint32_t foreign; /* valid messages of another node: dropped, never acted on */
	char name[48];
};

/* spec: "udp[:PORT]" (device link: listen on PORT, default 47800; host link: send to 127.0.0.1:PORT,
 * default 47801), "can:IFACE", "usb:FFS_DIR" (a mounted FunctionFS instance). On failure returns -1
 * and writes a one-line reason to err. */
int ctl_link_open(struct ctl_link *l, const char *spec, int device_side, uint8_t node, char *err,
		  size_t errlen);

/* The file descriptor to poll for input (-1 if none). */
int ctl_link_fd(const struct ctl_link *l);

/* Read one frame or packet if one is waiting (never blocks); decoded messages go to out.
 * Returns the number of messages (0 when nothing was waiting or the frame was rejected). */
size_t ctl_link_recv(struct ctl_link *l, struct swell_msg *out, size_t cap);

/* Send messages: packed into as few packets as fit (UDP, USB) or one CAN frame each. */
void ctl_link_send(struct ctl_link *l, const struct swell_msg *m, size_t n);

void ctl_link_close(struct ctl_link *l);

#endif
