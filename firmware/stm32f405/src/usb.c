#include "usb.h"

#include <stddef.h>

#include "../logic/usb_desc.h"
#include "../regs/stm32f405_otgfs.h"
#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"
#include "irq.h"
#include "isr.h"
#include "swell/transport.h"

#define AHBIDL_WAIT_LOOPS 100000u
#define MODE_WAIT_LOOPS 4000000u /* forcing device mode takes 25 ms */

/* FIFO RAM: 320 words. RX 128 words (room for a setup packet, a 64-byte packet and status
 * entries), TX0 16 words (64 bytes), TX1 16 words. */
#define RX_FIFO_WORDS 128u
#define TX0_FIFO_WORDS 16u
#define TX1_FIFO_WORDS 16u

static struct {
	struct usb_dev_state st;
	void (*on_out)(const uint8_t *data, uint32_t len);
	uint8_t setup[8];
	uint8_t scratch[USB_STRING_MAX];
	uint8_t out_buf[SWELL_USB_PACKET];
	volatile int in_busy;
	/* the bus idle (USBSUSP, RM0090 34.6 "Suspended state": the early suspend after 3 ms of idle
	 * lines, confirmed 3 ms later): the host suspended the device, or the cable is out (no VBUS
	 * sensing: an unplug looks like a suspend); cleared by a resume or a bus reset */
	volatile int suspended;
} usb;

/* Bounded wait for GRSTCTL's mask bits to read want (all set or all clear); 1 when they do. */
static int wait_grstctl(uint32_t mask, uint32_t want)
{
	for (uint32_t n = 0; n < AHBIDL_WAIT_LOOPS; n++)
		if ((OTG->GRSTCTL & mask) == want)
			return 1;
	return 0;
}

/* Flush a FIFO (TXFFLSH with every TX FIFO, or RXFFLSH) and wait for the core to finish. */
static void fifo_flush(uint32_t cmd)
{
	OTG->GRSTCTL = cmd;
	(void)wait_grstctl(cmd & (OTG_GRSTCTL_TXFFLSH | OTG_GRSTCTL_RXFFLSH), 0);
}

int usb_probe(void)
{
	RCC->AHB2ENR |= RCC_AHB2ENR_OTGFS;
	(void)RCC->AHB2ENR;
	if (wait_grstctl(OTG_GRSTCTL_AHBIDL, OTG_GRSTCTL_AHBIDL))
		return 1;
	RCC->AHB2ENR &= ~RCC_AHB2ENR_OTGFS;
	return 0;
}

static void fifo_write(unsigned ep, const uint8_t *d, uint32_t len)
{
	uint32_t i, k, w;

	for (i = 0; i < len; i += 4) {
		for (w = 0, k = 0; k < 4 && i + k < len; k++)
			w |= (uint32_t)d[i + k] << (8 * k);
		OTG_FIFO(ep) = w;
	}
}

static void fifo_read(uint8_t *d, uint32_t len, uint32_t cap)
{
	uint32_t i, w = 0;

	for (i = 0; i < len; i++) {
		if (!(i & 3u))
			w = OTG_FIFO(0); /* every OUT endpoint reads the shared RX FIFO */
		if (i < cap)
			d[i] = (uint8_t)(w >> (8 * (i & 3u)));
	}
}

static void ep0_out_arm(void)
{
	OTG_OUT(0)->DOEPTSIZ = (3u << OTG_DOEPTSIZ0_STUPCNT_SHIFT) | (1u << OTG_TSIZ_PKTCNT_SHIFT) | USB_EP0_SIZE;
	OTG_OUT(0)->DOEPCTL |= OTG_EPCTL_CNAK | OTG_EPCTL_EPENA;
}

/* One packet IN on endpoint ep (0 control, 1 bulk). */
static void ep_in(unsigned ep, const uint8_t *d, uint32_t len)
{
	OTG_IN(ep)->DIEPTSIZ = (1u << OTG_TSIZ_PKTCNT_SHIFT) | len;
	OTG_IN(ep)->DIEPCTL |= OTG_EPCTL_CNAK | OTG_EPCTL_EPENA;
	fifo_write(ep, d, len);
}

static void ep1_out_arm(void)
{
	OTG_OUT(1)->DOEPTSIZ = (1u << OTG_TSIZ_PKTCNT_SHIFT) | SWELL_USB_PACKET;
	OTG_OUT(1)->DOEPCTL |= OTG_EPCTL_CNAK | OTG_EPCTL_EPENA;
}

static void configure(uint8_t config)
{
	const uint32_t bulk = (OTG_EPTYP_BULK << OTG_EPCTL_EPTYP_SHIFT) | SWELL_USB_PACKET;

	usb.st.config = config;
	usb.st.halted = 0;
	usb.in_busy = 0;
	if (config) {
		OTG_IN(1)->DIEPCTL =
			bulk | (1u << OTG_EPCTL_TXFNUM_SHIFT) | OTG_EPCTL_SD0PID | OTG_EPCTL_USBAEP | OTG_EPCTL_SNAK;
		OTG_OUT(1)->DOEPCTL = bulk | OTG_EPCTL_SD0PID | OTG_EPCTL_USBAEP;
		OTG_DEV->DAINTMSK |= (1u << 1) | (1u << 17);
		ep1_out_arm();
	} else {
		OTG_IN(1)->DIEPCTL = 0;
		OTG_OUT(1)->DOEPCTL = 0;
		OTG_DEV->DAINTMSK &= ~((1u << 1) | (1u << 17));
	}
}

static void set_halt(uint8_t ep, int halt)
{
	volatile uint32_t *ctl = ep == SWELL_USB_EP_IN ? &OTG_IN(1)->DIEPCTL : &OTG_OUT(1)->DOEPCTL;
	uint8_t bit = ep == SWELL_USB_EP_IN ? 2u : 1u;

	if (halt) {
		*ctl |= OTG_EPCTL_STALL;
		usb.st.halted |= bit;
	} else {
		*ctl = (*ctl & ~OTG_EPCTL_STALL) | OTG_EPCTL_SD0PID; /* data toggle back to DATA0 */
		usb.st.halted &= (uint8_t)~bit;
		if (ep == SWELL_USB_EP_OUT)
			ep1_out_arm();
	}
}

static void handle_setup(void)
{
	struct usb_setup s;
	struct usb_ctrl_reply r;

	usb_setup_parse(usb.setup, &s);
	usb_ctrl_decide(&s, &usb.st, usb.scratch, &r);
	switch (r.action) {
	case USB_CTRL_DATA_IN:
		ep_in(0, r.data, r.len); /* every reply fits one 64-byte packet (tested on the host) */
		break;
	case USB_CTRL_SET_ADDRESS:
		/* This core takes the new address before the status stage and answers it itself. */
		OTG_DEV->DCFG = (OTG_DEV->DCFG & ~OTG_DCFG_DAD_MASK) | ((uint32_t)r.value << OTG_DCFG_DAD_SHIFT);
		usb.st.address = r.value;
		ep_in(0, NULL, 0);
		break;
	case USB_CTRL_SET_CONFIG:
		configure(r.value);
		ep_in(0, NULL, 0);
		break;
	case USB_CTRL_SET_HALT:
	case USB_CTRL_CLEAR_HALT:
		set_halt(r.ep, r.action == USB_CTRL_SET_HALT);
		ep_in(0, NULL, 0);
		break;
	case USB_CTRL_STATUS:
		ep_in(0, NULL, 0);
		break;
	default:
		OTG_IN(0)->DIEPCTL |= OTG_EPCTL_STALL; /* cleared by the core on the next SETUP */
		OTG_OUT(0)->DOEPCTL |= OTG_EPCTL_STALL;
		break;
	}
	ep0_out_arm();
}

/* Take back the bulk IN packet the host has not read (RM0090 34.17.6, "IN endpoint disable"): NAK
 * the endpoint, disable it, flush its transmit FIFO. For the suspend: the host is gone or asleep, and
 * what the packet says is stale by the time one reads the endpoint again. Bounded waits. */
static void in_abort(void)
{
	OTG_IN(1)->DIEPCTL |= OTG_EPCTL_SNAK;
	if (OTG_IN(1)->DIEPCTL & OTG_EPCTL_EPENA) {
		OTG_IN(1)->DIEPCTL |= OTG_EPCTL_EPDIS | OTG_EPCTL_SNAK;
		for (uint32_t n = 0; n < AHBIDL_WAIT_LOOPS && !(OTG_IN(1)->DIEPINT & OTG_EPINT_EPDISD); n++)
			;
		OTG_IN(1)->DIEPINT = OTG_EPINT_EPDISD;
	}
	fifo_flush(OTG_GRSTCTL_TXFFLSH | (1u << OTG_GRSTCTL_TXFNUM_SHIFT));
	usb.in_busy = 0;
}

static void bus_reset(void)
{
	OTG_DEV->DCFG &= ~OTG_DCFG_DAD_MASK;
	usb.st = (struct usb_dev_state){ 0 };
	configure(0);
	fifo_flush(OTG_GRSTCTL_TXFFLSH | OTG_GRSTCTL_TXFNUM_ALL);
	OTG_DEV->DAINTMSK = (1u << 0) | (1u << 16);
	OTG_DEV->DOEPMSK = OTG_EPINT_XFRC | OTG_DOEPINT_STUP;
	OTG_DEV->DIEPMSK = OTG_EPINT_XFRC;
	ep0_out_arm();
}

static void rx_level(void)
{
	uint32_t sts = OTG->GRXSTSP;
	uint32_t ep = sts & OTG_GRXSTS_EPNUM_MASK;
	uint32_t bcnt = (sts >> OTG_GRXSTS_BCNT_SHIFT) & OTG_GRXSTS_BCNT_MASK;
	uint32_t pkt = (sts >> OTG_GRXSTS_PKTSTS_SHIFT) & OTG_GRXSTS_PKTSTS_MASK;

	if (pkt == OTG_PKTSTS_SETUP_DATA) {
		fifo_read(usb.setup, bcnt, sizeof(usb.setup));
	} else if (pkt == OTG_PKTSTS_OUT_DATA) {
		if (ep == 1) {
			fifo_read(usb.out_buf, bcnt, sizeof(usb.out_buf));
			if (usb.on_out && bcnt <= sizeof(usb.out_buf))
				usb.on_out(usb.out_buf, bcnt);
		} else {
			fifo_read(NULL, bcnt, 0); /* EP0 OUT: the zero-length status stage */
		}
	}
}

void isr_otg_fs(void)
{
	uint32_t gint = OTG->GINTSTS & OTG->GINTMSK, daint, n;

	if (gint & OTG_GINT_USBRST) {
		OTG->GINTSTS = OTG_GINT_USBRST;
		usb.suspended = 0;
		bus_reset();
	}
	if (gint & OTG_GINT_ENUMDNE) {
		OTG->GINTSTS = OTG_GINT_ENUMDNE;
		OTG_IN(0)->DIEPCTL &= ~OTG_EPCTL_MPSIZ_MASK; /* 0: 64-byte EP0 */
		OTG_DEV->DCTL |= OTG_DCTL_CGINAK;
		ep0_out_arm();
	}
	/* Bounded: the RX FIFO holds at most 128 words of entries. */
	for (n = 0; n < RX_FIFO_WORDS && (OTG->GINTSTS & OTG_GINT_RXFLVL); n++)
		rx_level();
	daint = OTG_DEV->DAINT & OTG_DEV->DAINTMSK;
	if (daint & (1u << 16)) {
		uint32_t f = OTG_OUT(0)->DOEPINT;

		OTG_OUT(0)->DOEPINT = f;
		if (f & OTG_DOEPINT_STUP)
			handle_setup();
		else if (f & OTG_EPINT_XFRC)
			ep0_out_arm();
	}
	if (daint & (1u << 17)) {
		uint32_t f = OTG_OUT(1)->DOEPINT;

		OTG_OUT(1)->DOEPINT = f;
		if ((f & OTG_EPINT_XFRC) && !(usb.st.halted & 1u))
			ep1_out_arm();
	}
	if (daint & (1u << 0))
		OTG_IN(0)->DIEPINT = OTG_IN(0)->DIEPINT;
	if (daint & (1u << 1)) {
		uint32_t f = OTG_IN(1)->DIEPINT;

		OTG_IN(1)->DIEPINT = f;
		if (f & OTG_EPINT_XFRC)
			usb.in_busy = 0;
	}
	if (gint & (OTG_GINT_USBSUSP | OTG_GINT_WKUPINT)) { /* rc_w1: both acknowledged in one write */
		OTG->GINTSTS = gint & (OTG_GINT_USBSUSP | OTG_GINT_WKUPINT);
		if (gint & OTG_GINT_USBSUSP) {
			/* usb_send refuses from now on (the tick preempts this handler: it sees the flag first
			 * or has sent before the abort), then the packet waiting for the host goes */
			usb.suspended = 1;
			__asm__ volatile("dmb" ::: "memory");
			if (usb.st.config)
				in_abort();
		}
		if (gint & OTG_GINT_WKUPINT)
			usb.suspended = 0; /* both at once: the resume came last */
	}
}

enum swell_err usb_start(uint8_t prio, void (*on_out)(const uint8_t *data, uint32_t len))
{
	RCC->AHB1ENR |= RCC_AHB1ENR_GPIOA;
	RCC->AHB2ENR |= RCC_AHB2ENR_OTGFS;
	(void)RCC->AHB2ENR;
	/* PA11 DM, PA12 DP: AF10, very high speed. */
	GPIOA->AFR[1] = (GPIOA->AFR[1] & ~(0xFFu << 12)) | (0xAAu << 12);
	GPIOA->OSPEEDR |= (3u << 22) | (3u << 24);
	GPIOA->MODER = (GPIOA->MODER & ~(0xFu << 22)) | (GPIO_MODE_AF << 22) | (GPIO_MODE_AF << 24);

	if (!wait_grstctl(OTG_GRSTCTL_AHBIDL, OTG_GRSTCTL_AHBIDL))
		return SWELL_ESTATE;
	OTG->GRSTCTL = OTG_GRSTCTL_CSRST;
	if (!wait_grstctl(OTG_GRSTCTL_CSRST, 0))
		return SWELL_ESTATE;
	/* Embedded full-speed PHY, forced device mode, turnaround 6 for AHB above 32 MHz. */
	OTG->GUSBCFG = OTG_GUSBCFG_PHYSEL | OTG_GUSBCFG_FDMOD | (6u << OTG_GUSBCFG_TRDT_SHIFT);
	for (volatile uint32_t n = 0; n < MODE_WAIT_LOOPS / 4; n++)
		;
	OTG->GCCFG = OTG_GCCFG_PWRDWN | OTG_GCCFG_NOVBUSSENS; /* PHY on, no VBUS pin sensing */
	OTG_PCGCCTL = 0;
	OTG_DEV->DCFG = OTG_DCFG_DSPD_FS;
	OTG->GRXFSIZ = RX_FIFO_WORDS;
	OTG->DIEPTXF0 = (TX0_FIFO_WORDS << 16) | RX_FIFO_WORDS;
	OTG->DIEPTXF[0] = (TX1_FIFO_WORDS << 16) | (RX_FIFO_WORDS + TX0_FIFO_WORDS);
	fifo_flush(OTG_GRSTCTL_TXFFLSH | OTG_GRSTCTL_TXFNUM_ALL);
	fifo_flush(OTG_GRSTCTL_RXFFLSH);

	usb.on_out = on_out;
	usb.st = (struct usb_dev_state){ 0 };
	OTG->GINTSTS = 0xFFFFFFFFu;
	OTG->GINTMSK = OTG_GINT_USBRST | OTG_GINT_ENUMDNE | OTG_GINT_RXFLVL | OTG_GINT_IEPINT | OTG_GINT_OEPINT |
		OTG_GINT_USBSUSP | OTG_GINT_WKUPINT;
	OTG->GAHBCFG = OTG_GAHBCFG_GINTMSK;
	irq_enable_at(IRQ_OTG_FS, prio);
	OTG_DEV->DCTL &= ~OTG_DCTL_SDIS; /* connect: pull-up on DP */
	return SWELL_OK;
}

enum swell_err usb_send(const uint8_t *data, uint32_t len)
{
	if (!usb.st.config || usb.suspended)
		return SWELL_ESTATE;
	if (!data || len > SWELL_USB_PACKET || usb.in_busy || (usb.st.halted & 2u))
		return SWELL_ESIZE;
	if ((OTG_IN(1)->DTXFSTS & 0xFFFFu) < (len + 3) / 4)
		return SWELL_ESIZE;
	usb.in_busy = 1;
	ep_in(1, data, len);
	return SWELL_OK;
}

int usb_host_active(void)
{
	return usb.st.config != 0 && !usb.suspended;
}
