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

/* CAN: 1 Mbit/s nominal; CAN FD data phase 2 Mbit/s unless the port says otherwise. */
#define SWELL_CAN_BITRATE 1000000u
#define SWELL_CANFD_DBITRATE 2000000u

#endif
