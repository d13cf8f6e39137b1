/* USB device side without registers: the descriptors of the swell controller (full speed, one
 * vendor interface, class 0xFF, bulk OUT 0x01 and bulk IN 0x81 of 64 bytes, VID/PID from
 * swell/transport.h, the same as the Linux port's FunctionFS function) and the decision for each
 * standard control request (USB 2.0 chapter 9). The driver only moves bytes. */
#ifndef SWELL_FW_USB_DESC_H
#define SWELL_FW_USB_DESC_H

#include <stdint.h>

#define USB_DEVICE_DESC_LEN 18
#define USB_CONFIG_DESC_LEN 32 /* configuration 9 + interface 9 + 2 endpoints x 7 */
#define USB_EP0_SIZE 64
#define USB_STRING_MAX 64 /* bytes of the largest string descriptor we build */

extern const uint8_t usb_device_desc[USB_DEVICE_DESC_LEN];
extern const uint8_t usb_config_desc[USB_CONFIG_DESC_LEN];

struct usb_setup {
	uint8_t bmRequestType, bRequest;
	uint16_t wValue, wIndex, wLength;
};

enum usb_ctrl_action {
	USB_CTRL_STALL = 0, /* not supported or invalid: stall EP0 */
	USB_CTRL_DATA_IN, /* send data[0..len) then expect a zero-length OUT status */
	USB_CTRL_STATUS, /* no data stage: send a zero-length IN status */
	USB_CTRL_SET_ADDRESS, /* set the address to value, then status */
	USB_CTRL_SET_CONFIG, /* configure (value 1) or deconfigure (0) the bulk endpoints, then status */
	USB_CTRL_SET_HALT, /* stall endpoint `ep`, then status */
	USB_CTRL_CLEAR_HALT, /* un-stall endpoint `ep` and reset its data toggle, then status */
};

struct usb_ctrl_reply {
	enum usb_ctrl_action action;
	const uint8_t *data;
	uint16_t len;
	uint8_t value; /* address or configuration */
	uint8_t ep; /* endpoint address for halt requests */
};

/* Device state the decisions depend on (USB 2.0 9.1: default, address, configured). */
struct usb_dev_state {
	uint8_t address; /* 0: default state */
	uint8_t config; /* 0: not configured */
	uint8_t halted; /* bit 0: EP 0x01 halted, bit 1: EP 0x81 halted */
};

void usb_setup_parse(const uint8_t raw[8], struct usb_setup *s);

/* Decide the answer to a SETUP packet. scratch (USB_STRING_MAX bytes, caller's) holds string and
 * status replies; reply data never exceeds wLength. Nothing else is written. */
void usb_ctrl_decide(const struct usb_setup *s, const struct usb_dev_state *st, uint8_t *scratch,
		     struct usb_ctrl_reply *r);

#endif
