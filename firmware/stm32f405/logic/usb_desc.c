#include "usb_desc.h"

#include <stddef.h>

#include "swell/transport.h"

#define LO(x) ((uint8_t)((x)&0xFFu))
#define HI(x) ((uint8_t)(((x) >> 8) & 0xFFu))

/* Request codes and descriptor types, USB 2.0 tables 9-4 and 9-5. */
enum {
	REQ_GET_STATUS = 0,
	REQ_CLEAR_FEATURE = 1,
	REQ_SET_FEATURE = 3,
	REQ_SET_ADDRESS = 5,
	REQ_GET_DESCRIPTOR = 6,
	REQ_GET_CONFIGURATION = 8,
	REQ_SET_CONFIGURATION = 9,
	REQ_GET_INTERFACE = 10,
	REQ_SET_INTERFACE = 11,
};
enum {
	DT_DEVICE = 1,
	DT_CONFIG = 2,
	DT_STRING = 3,
	DT_INTERFACE = 4,
	DT_ENDPOINT = 5
};
#define FEATURE_ENDPOINT_HALT 0
#define BCD_DEVICE 0x0100u

const uint8_t usb_device_desc[USB_DEVICE_DESC_LEN] = {
	USB_DEVICE_DESC_LEN,
	DT_DEVICE,
	LO(0x0200),
	HI(0x0200), /* USB 2.0 (full speed) */
	0x00,
	0x00,
	0x00, /* class per interface */
	USB_EP0_SIZE,
	LO(SWELL_USB_VID),
	HI(SWELL_USB_VID),
	LO(SWELL_USB_PID),
	HI(SWELL_USB_PID),
	LO(BCD_DEVICE),
	HI(BCD_DEVICE),
	1,
	2,
	3, /* manufacturer, product, serial strings */
	1, /* one configuration */
};

const uint8_t usb_config_desc[USB_CONFIG_DESC_LEN] = {
	9,
	DT_CONFIG,
	LO(USB_CONFIG_DESC_LEN),
	HI(USB_CONFIG_DESC_LEN),
	1, /* interfaces */
	1, /* bConfigurationValue */
	0, /* no string */
	0x80, /* bus powered (the board is powered by its own supply but draws nothing from VBUS) */
	50, /* 100 mA */
	9,
	DT_INTERFACE,
	SWELL_USB_IFACE,
	0,
	2,
	SWELL_USB_CLASS,
	0x00,
	0x00,
	0,
	7,
	DT_ENDPOINT,
	SWELL_USB_EP_OUT,
	0x02,
	LO(SWELL_USB_PACKET),
	HI(SWELL_USB_PACKET),
	0,
	7,
	DT_ENDPOINT,
	SWELL_USB_EP_IN,
	0x02,
	LO(SWELL_USB_PACKET),
	HI(SWELL_USB_PACKET),
	0,
};

static const char *const strings[] = { NULL, "swell", "swell controller (STM32F405)", "0001" };
static const uint8_t langids[4] = { 4, DT_STRING, 0x09, 0x04 }; /* en-US */

void usb_setup_parse(const uint8_t raw[8], struct usb_setup *s)
{
	s->bmRequestType = raw[0];
	s->bRequest = raw[1];
	s->wValue = (uint16_t)(raw[2] | raw[3] << 8);
	s->wIndex = (uint16_t)(raw[4] | raw[5] << 8);
	s->wLength = (uint16_t)(raw[6] | raw[7] << 8);
}

static void data_in(struct usb_ctrl_reply *r, const struct usb_setup *s, const uint8_t *d, uint16_t len)
{
	r->action = USB_CTRL_DATA_IN;
	r->data = d;
	r->len = len < s->wLength ? len : s->wLength;
}

/* ASCII to a UTF-16LE string descriptor in scratch. */
static uint16_t build_string(const char *str, uint8_t *out)
{
	uint16_t n = 2;

	while (*str && n + 2 <= USB_STRING_MAX) {
		out[n++] = (uint8_t)*str++;
		out[n++] = 0;
	}
	out[0] = (uint8_t)n;
	out[1] = DT_STRING;
	return n;
}

static int valid_ep(uint16_t ep)
{
	return ep == 0x00 || ep == 0x80 || ep == SWELL_USB_EP_OUT || ep == SWELL_USB_EP_IN;
}

static uint8_t halt_bit(uint16_t ep)
{
	return ep == SWELL_USB_EP_OUT ? 1u : ep == SWELL_USB_EP_IN ? 2u : 0u;
}

void usb_ctrl_decide(const struct usb_setup *s, const struct usb_dev_state *st, uint8_t *scratch,
		     struct usb_ctrl_reply *r)
{
	uint8_t type = (s->bmRequestType >> 5) & 3u, recip = s->bmRequestType & 0x1Fu;
	int in = (s->bmRequestType & 0x80u) != 0;

	*r = (struct usb_ctrl_reply){ .action = USB_CTRL_STALL };
	if (type != 0) /* class and vendor requests: the protocol runs over bulk, not EP0 */
		return;
	switch (s->bRequest) {
	case REQ_GET_DESCRIPTOR: {
		uint8_t dt = HI(s->wValue), idx = LO(s->wValue);

		if (!in || recip != 0)
			return;
		if (dt == DT_DEVICE && idx == 0)
			data_in(r, s, usb_device_desc, USB_DEVICE_DESC_LEN);
		else if (dt == DT_CONFIG && idx == 0)
			data_in(r, s, usb_config_desc, USB_CONFIG_DESC_LEN);
		else if (dt == DT_STRING && idx == 0)
			data_in(r, s, langids, sizeof(langids));
		else if (dt == DT_STRING && idx < sizeof(strings) / sizeof(strings[0]))
			data_in(r, s, scratch, build_string(strings[idx], scratch));
		return; /* device qualifier (full-speed only device) and others: stall */
	}
	case REQ_SET_ADDRESS:
		if (in || recip != 0 || s->wValue > 127 || s->wIndex || s->wLength || st->config)
			return;
		r->action = USB_CTRL_SET_ADDRESS;
		r->value = (uint8_t)s->wValue;
		return;
	case REQ_GET_CONFIGURATION:
		if (!in || recip != 0 || s->wLength != 1)
			return;
		scratch[0] = st->config;
		data_in(r, s, scratch, 1);
		return;
	case REQ_SET_CONFIGURATION:
		if (in || recip != 0 || s->wValue > 1 || !st->address)
			return;
		r->action = USB_CTRL_SET_CONFIG;
		r->value = (uint8_t)s->wValue;
		return;
	case REQ_GET_INTERFACE:
		if (!in || recip != 1 || s->wIndex != SWELL_USB_IFACE || !st->config || s->wLength != 1)
			return;
		scratch[0] = 0;
		data_in(r, s, scratch, 1);
		return;
	case REQ_SET_INTERFACE:
		if (in || recip != 1 || s->wIndex != SWELL_USB_IFACE || s->wValue != 0 || !st->config)
			return;
		r->action = USB_CTRL_STATUS;
		return;
	case REQ_GET_STATUS:
		if (!in || s->wLength != 2)
			return;
		scratch[0] = scratch[1] = 0; /* not self powered, no remote wake-up, not halted */
		if (recip == 1 && (s->wIndex != SWELL_USB_IFACE || !st->config))
			return;
		if (recip == 2) {
			if (!valid_ep(s->wIndex) || (halt_bit(s->wIndex) && !st->config))
				return;
			scratch[0] = (st->halted & halt_bit(s->wIndex)) ? 1 : 0;
		} else if (recip > 2) {
			return;
		}
		data_in(r, s, scratch, 2);
		return;
	case REQ_CLEAR_FEATURE:
	case REQ_SET_FEATURE:
		/* Only ENDPOINT_HALT on our bulk endpoints, when configured. */
		if (in || recip != 2 || s->wValue != FEATURE_ENDPOINT_HALT || !halt_bit(s->wIndex) || !st->config)
			return;
		r->action = s->bRequest == REQ_SET_FEATURE ? USB_CTRL_SET_HALT : USB_CTRL_CLEAR_HALT;
		r->ep = (uint8_t)s->wIndex;
		return;
	default:
		return;
	}
}
