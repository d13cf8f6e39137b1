/* Carrier constants shared by the controller ports, the host links and the benches: the project's
 * USB identity and the software-in-the-loop UDP ports. The byte formats are in swell/proto.h. */
#ifndef SWELL_TRANSPORT_H
#define SWELL_TRANSPORT_H

/* USB full speed, one vendor-class interface (the STM32 device and the Linux FunctionFS gadget).
 * VID 0x1209 / PID 0x0001 is the pid.codes test PID: fine for development, not for shipping. */
#define SWELL_USB_VID 0x1209u
#define SWELL_USB_PID 0x0001u
#define SWELL_USB_IFACE 0u /* interface number, class 0xFF */
#define SWELL_USB_CLASS 0xFFu
#define SWELL_USB_EP_OUT 0x01u /* bulk, host -> controller */
#define SWELL_USB_EP_IN 0x81u /* bulk, controller -> host */
#define SWELL_USB_PACKET 64u /* wMaxPacketSize; one swell packet per USB packet */

/* UDP software-in-the-loop: same bytes as the USB packets, one packet per datagram. */
#define SWELL_UDP_HOST "127.0.0.1"
#define SWELL_UDP_PORT_DEVICE 47800u /* the controller listens here for the device (HapticMaster) */
#define SWELL_UDP_PORT_VIEWER 47801u /* the controller sends telemetry here to the viewer */
#define SWELL_UDP_PORT_CLIENTS 47802u /* the controller's host link takes clients (tools) here */
/* A client of the host link is dropped after 3 s without a valid packet; tools send a HEARTBEAT of
 * the controller's node this often while they run. */
#define SWELL_UDP_CLIENT_SILENT_MS 3000u
#define SWELL_UDP_KEEPALIVE_MS 1000u
/* Tools bind the first free port of these, so that a tool run again on the same machine takes over
 * the client slot the one before it left (the controller knows clients by address); any free port
 * when all are taken. */
#define SWELL_UDP_PORT_TOOLS_FIRST 47803u
#define SWELL_UDP_PORT_TOOLS_COUNT 8u

/* CAN: 1 Mbit/s nominal; CAN FD data phase 2 Mbit/s unless the port says otherwise. */
#define SWELL_CAN_BITRATE 1000000u
#define SWELL_CANFD_DBITRATE 2000000u

#endif
