/* libusb link: one swell packet per bulk transfer; survives unplug and replug. One IN transfer stays
 * submitted between receives: a packet the device sends while nobody waits lands in it, and a receive
 * that finds nothing (timeout 0: a poll) costs no transfer cancelled on the bus. A synchronous
 * transfer with a timeout would be cancelled at each timeout: over USB/IP (vhci-hcd) every cancel is
 * an unlink round trip, and libusb waits at least 1 ms for a poll. */
#define _GNU_SOURCE
#include "link_priv.h"

#include <errno.h>
#include <libusb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/transport.h"

#define REOPEN_INTERVAL_NS 100000000u /* try to re-open an unplugged device at most every 100 ms */

struct usb_link {
	struct swell_link base;
	struct swell_usb_opts o;
	libusb_context *ctx;
	libusb_device_handle *h;
	uint8_t ep_out, ep_in; /* in use: the configured ones, or what the descriptor has */
	uint64_t last_try_ns;
	struct libusb_transfer *in; /* the IN transfer of this handle (NULL: none yet) */
	int in_state; /* IN_IDLE, IN_FLIGHT (submitted), IN_DONE (completed, not yet taken) */
	unsigned char in_buf[SWELL_LINK_MTU];
};

enum {
	IN_IDLE,
	IN_FLIGHT,
	IN_DONE
};

static void LIBUSB_CALL in_done(struct libusb_transfer *t)
{
	((struct usb_link *)t->user_data)->in_state = IN_DONE;
}

/* libusb's events for up to ms (0: what is there now, -1: until one). */
static int pump(struct usb_link *u, int ms)
{
	struct timeval tv = { ms / 1000, (ms % 1000) * 1000 };

	return ms < 0 ? libusb_handle_events(u->ctx) : libusb_handle_events_timeout_completed(u->ctx, &tv, NULL);
}

void swell_usb_opts_default(struct swell_usb_opts *o)
{
	o->vid = SWELL_USB_VID;
	o->pid = SWELL_USB_PID;
	o->iface = SWELL_USB_IFACE;
	o->ep_out = SWELL_USB_EP_OUT;
	o->ep_in = SWELL_USB_EP_IN;
}

static int errno_of(int e)
{
	static const int to[] = { [-LIBUSB_ERROR_TIMEOUT] = ETIMEDOUT, [-LIBUSB_ERROR_NO_DEVICE] = ENODEV,
				  [-LIBUSB_ERROR_NOT_FOUND] = ENODEV,  [-LIBUSB_ERROR_ACCESS] = EACCES,
				  [-LIBUSB_ERROR_BUSY] = EBUSY,        [-LIBUSB_ERROR_OVERFLOW] = EMSGSIZE,
				  [-LIBUSB_ERROR_PIPE] = EPIPE,        [-LIBUSB_ERROR_NO_MEM] = ENOMEM,
				  [-LIBUSB_ERROR_INTERRUPTED] = EINTR };

	return e < 0 && -e < (int)(sizeof(to) / sizeof(to[0])) && to[-e] ? -to[-e] : -EIO;
}

static void drop(struct usb_link *u)
{
	if (!u->h)
		return;
	if (u->in_state == IN_FLIGHT) {
		/* completed before the handle closes, whatever the cancel says (a device gone completes it
		 * with NO_DEVICE at the next events) */
		(void)libusb_cancel_transfer(u->in);
		for (int i = 0; i < 100 && u->in_state == IN_FLIGHT; i++)
			(void)pump(u, 10);
	}
	/* The transfer goes with the handle: libusb keeps the device it was submitted to until it is
	 * freed or submitted again, and submitted again after the context was renewed (ensure) that
	 * old device's release read the freed context and crashed swell-hm after a replug. One that
	 * never completed stays libusb's (left, not freed). */
	if (u->in && u->in_state != IN_FLIGHT)
		libusb_free_transfer(u->in);
	u->in = NULL;
	u->in_state = IN_IDLE; /* what it held is lost with the device */
	libusb_release_interface(u->h, u->o.iface);
	libusb_close(u->h);
	u->h = NULL;
}

/* The device decides its endpoint addresses (a FunctionFS gadget on dummy_hcd gets OUT 0x02, not
 * 0x01): take the configured ones if the interface has them, else its first bulk OUT and IN. */
static int find_endpoints(struct usb_link *u, libusb_device_handle *h)
{
	struct libusb_config_descriptor *cfg;
	uint8_t out = 0, in = 0;
	int i, e;

	if (libusb_get_active_config_descriptor(libusb_get_device(h), &cfg) != 0)
		return -EIO;
	for (i = 0; i < cfg->bNumInterfaces; i++) {
		const struct libusb_interface *itf = &cfg->interface[i];
		const struct libusb_interface_descriptor *d;

		if (itf->num_altsetting < 1 || itf->altsetting[0].bInterfaceNumber != u->o.iface)
			continue;
		d = &itf->altsetting[0];
		for (e = 0; e < d->bNumEndpoints; e++) {
			uint8_t a = d->endpoint[e].bEndpointAddress;

			if ((d->endpoint[e].bmAttributes & 3) != LIBUSB_TRANSFER_TYPE_BULK)
				continue;
			if (a & LIBUSB_ENDPOINT_IN) {
				if (!in || a == u->o.ep_in)
					in = a;
			} else if (!out || a == u->o.ep_out) {
				out = a;
			}
		}
	}
	libusb_free_config_descriptor(cfg);
	if (!out || !in)
		return -EPROTO; /* no bulk pair on that interface: not a swell device */
	u->ep_out = out;
	u->ep_in = in;
	return 0;
}

static int attach(struct usb_link *u)
{
	libusb_device_handle *h;
	int rc;

	u->last_try_ns = swell_link_now_ns();
	h = libusb_open_device_with_vid_pid(u->ctx, u->o.vid, u->o.pid);
	if (!h)
		return -ENODEV;
	libusb_set_auto_detach_kernel_driver(h, 1);
	rc = libusb_claim_interface(h, u->o.iface);
	if (rc < 0) {
		libusb_close(h);
		return errno_of(rc);
	}
	u->h = h;
	rc = find_endpoints(u, h);
	if (rc) {
		drop(u); /* released and closed */
		return rc;
	}
	snprintf(u->base.name, sizeof(u->base.name), "usb %04x:%04x if %d ep 0x%02x/0x%02x", u->o.vid, u->o.pid,
		 u->o.iface, u->ep_out, u->ep_in);
	return 0;
}

/* 0 with a handle, or -ENODEV while the device is away (re-opened at most every 100 ms). */
static int ensure(struct usb_link *u)
{
	int rc;

	if (u->h)
		return 0;
	if (swell_link_now_ns() - u->last_try_ns < REOPEN_INTERVAL_NS)
		return -ENODEV;
	/* a fresh context enumerates afresh: without udev (the VM bench) the old one may not see the
	 * device come back */
	libusb_exit(u->ctx);
	u->ctx = NULL;
	rc = libusb_init(&u->ctx);
	if (rc < 0) {
		u->ctx = NULL;
		u->last_try_ns = swell_link_now_ns();
		return -ENODEV;
	}
	rc = attach(u);
	if (rc == 0)
		u->base.cnt.reconnects++;
	return rc;
}

static int usb_send(struct swell_link *l, const struct swell_frame *f)
{
	struct usb_link *u = (struct usb_link *)l;
	int done = 0, rc = ensure(u);

	if (rc)
		return rc;
	rc = libusb_bulk_transfer(u->h, u->ep_out, (unsigned char *)f->data, f->len, &done, 1000);
	if (rc == LIBUSB_ERROR_NO_DEVICE || rc == LIBUSB_ERROR_IO) {
		drop(u);
		return -ENODEV;
	}
	if (rc < 0)
		return errno_of(rc);
	return done == f->len ? 0 : -EIO;
}

static int usb_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct usb_link *u = (struct usb_link *)l;
	uint64_t deadline = swell_link_deadline(timeout_ms);

	for (;;) {
		int left = swell_link_ms_left(deadline, timeout_ms), rc = ensure(u);

		if (rc == -ENODEV) {
			/* unplugged: wait for it to come back until the deadline */
			struct timespec ts = { 0, 20000000 };

			if (left == 0)
				return -ENODEV;
			nanosleep(&ts, NULL);
			continue;
		}
		if (rc)
			return rc;
		if (!u->in && !(u->in = libusb_alloc_transfer(0)))
			return -ENOMEM;
		if (u->in_state == IN_IDLE) {
			libusb_fill_bulk_transfer(u->in, u->h, u->ep_in, u->in_buf, sizeof(u->in_buf), in_done, u, 0);
			rc = libusb_submit_transfer(u->in);
			if (rc == LIBUSB_ERROR_NO_DEVICE || rc == LIBUSB_ERROR_IO) {
				drop(u);
				continue;
			}
			if (rc < 0)
				return errno_of(rc);
			u->in_state = IN_FLIGHT;
		}
		while (u->in_state == IN_FLIGHT) {
			rc = pump(u, left);
			if (rc < 0 && rc != LIBUSB_ERROR_INTERRUPTED)
				return errno_of(rc);
			if (u->in_state != IN_FLIGHT)
				break;
			if (rc == LIBUSB_ERROR_INTERRUPTED)
				return -EINTR;
			left = swell_link_ms_left(deadline, timeout_ms);
			if (left == 0)
				return -ETIMEDOUT; /* the transfer stays submitted for the next receive */
		}
		u->in_state = IN_IDLE;
		switch (u->in->status) {
		case LIBUSB_TRANSFER_COMPLETED:
			break;
		case LIBUSB_TRANSFER_OVERFLOW:
			l->cnt.rx_dropped++;
			continue;
		case LIBUSB_TRANSFER_STALL:
			return -EPIPE;
		case LIBUSB_TRANSFER_CANCELLED:
			continue;
		default: /* an error or the device gone: opened again */
			drop(u);
			continue;
		}
		memset(f, 0, sizeof(*f));
		f->t_ns = swell_link_now_ns();
		f->len = (uint16_t)u->in->actual_length;
		memcpy(f->data, u->in_buf, (size_t)u->in->actual_length);
		return 0;
	}
}

static void usb_close(struct swell_link *l)
{
	struct usb_link *u = (struct usb_link *)l;

	drop(u);
	if (u->ctx)
		libusb_exit(u->ctx);
	free(u);
}

static const struct swell_link_ops usb_ops = { usb_send, usb_recv, usb_close, NULL };

int swell_link_open_usb(struct swell_link **out, const struct swell_usb_opts *opts)
{
	struct usb_link *u;
	int rc;

	if (!out)
		return -EINVAL;
	u = calloc(1, sizeof(*u));
	if (!u)
		return -ENOMEM;
	if (opts)
		u->o = *opts;
	else
		swell_usb_opts_default(&u->o);
	u->base.ops = &usb_ops;
	u->base.carrier = SWELL_CARRIER_PKT;
	rc = libusb_init(&u->ctx);
	rc = rc < 0 ? errno_of(rc) : attach(u);
	if (rc) {
		usb_close(&u->base); /* u->ctx NULL when libusb_init failed: usb_close leaves it alone */
		return rc;
	}
	*out = &u->base;
	return 0;
}
