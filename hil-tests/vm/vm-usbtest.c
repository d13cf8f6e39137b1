/* swell-vm-usbtest: the USB host side of the VM bench. Opens the vendor device with libusb, claims
 * its vendor interface and checks that every bulk OUT packet comes back intact on bulk IN. */
#define _DEFAULT_SOURCE

#include <errno.h>
#include <libusb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/cli.h"
#include "vm-util.h"

#define PACKET_MAX 64

static const char usage[] =
	"usage: swell-vm-usbtest [--vid HEX] [--pid HEX] [--count N] [--timeout-ms MS]\n"
	"                        [--lengths fixed|vary] [--expect-ep-out HEX] [--expect-ep-in HEX]\n"
	"Open USB device VID:PID (default 1209:0001) with libusb, claim its vendor interface\n"
	"(class 0xFF) with one bulk OUT and one bulk IN endpoint, send N numbered packets\n"
	"(default 1000; 64 bytes, or 1..64 bytes with --lengths vary) and check each comes back\n"
	"intact and in order within MS (default 1000 ms). First checks that vendor control\n"
	"requests to the interface are stalled. --expect-ep-* also checks the endpoint\n"
	"addresses. Prints speed, endpoints, packets/s and round-trip times; exits non-zero on\n"
	"any lost, short or corrupted packet.\n";

static const char *speed_name(int s)
{
	static const char *const names[] = { [LIBUSB_SPEED_LOW] = "low speed",
					     [LIBUSB_SPEED_FULL] = "full speed",
					     [LIBUSB_SPEED_HIGH] = "high speed",
					     [LIBUSB_SPEED_SUPER] = "super speed" };

	return s >= 0 && s < (int)(sizeof(names) / sizeof(names[0])) && names[s] ? names[s] : "unknown speed";
}

/* Packet i: its length and its bytes depend on i (byte 0..3: i, little-endian). */
static int fill(uint32_t i, int vary, uint8_t *p)
{
	int len = vary ? (int)(1 + (i * 37u) % PACKET_MAX) : PACKET_MAX;
	for (int k = 0; k < len; k++)
		p[k] = (uint8_t)((k < 4 ? i >> (8 * k) : i * 7u + (uint32_t)k * 13u) ^ 0x3Cu);
	return len;
}

struct link {
	int iface;
	uint8_t ep_out, ep_in;
	int mps_out, mps_in;
};

static int find_vendor_iface(libusb_device *dev, struct link *l)
{
	struct libusb_config_descriptor *cfg;
	if (libusb_get_active_config_descriptor(dev, &cfg) != 0)
		return -1;
	int found = -1;
	for (int i = 0; i < cfg->bNumInterfaces && found < 0; i++) {
		const struct libusb_interface_descriptor *d = &cfg->interface[i].altsetting[0];
		if (d->bInterfaceClass != LIBUSB_CLASS_VENDOR_SPEC)
			continue;
		l->ep_out = l->ep_in = 0;
		for (int e = 0; e < d->bNumEndpoints; e++) {
			const struct libusb_endpoint_descriptor *ep = &d->endpoint[e];
			if ((ep->bmAttributes & 3) != LIBUSB_TRANSFER_TYPE_BULK)
				continue;
			if (ep->bEndpointAddress & LIBUSB_ENDPOINT_IN) {
				l->ep_in = ep->bEndpointAddress;
				l->mps_in = ep->wMaxPacketSize;
			} else {
				l->ep_out = ep->bEndpointAddress;
				l->mps_out = ep->wMaxPacketSize;
			}
		}
		if (l->ep_out && l->ep_in) {
			l->iface = d->bInterfaceNumber;
			found = 0;
		}
	}
	libusb_free_config_descriptor(cfg);
	return found;
}

int main(int argc, char **argv)
{
	long vid = 0x1209, pid = 0x0001, count = 1000, timeout_ms = 1000;
	long want_out = -1, want_in = -1;
	int vary = 0;

	const struct swell_cli_opt opts[] = {
		SWELL_CLI_HEX("--vid", vid, 0, 0xFFFF),
		SWELL_CLI_HEX("--pid", pid, 0, 0xFFFF),
		SWELL_CLI_WHOLE("--count", count, 1, 100000000, ""),
		SWELL_CLI_WHOLE("--timeout-ms", timeout_ms, 1, 600000, "ms"),
		SWELL_CLI_HEX("--expect-ep-out", want_out, 1, 0x0F),
		SWELL_CLI_HEX("--expect-ep-in", want_in, 0x81, 0x8F),
		SWELL_CLI_CHOICE("--lengths", vary, "fixed|vary"),
	};
	struct swell_cli cli = { .prog = "swell-vm-usbtest", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts) };

	swell_cli_parse(&cli, argc, argv);

	libusb_context *ctx = NULL;
	int r = libusb_init(&ctx);
	if (r != 0) {
		fprintf(stderr, "swell-vm-usbtest: libusb_init: %s\n", libusb_strerror(r));
		return 1;
	}
	int rc = 1;
	struct link l;
	memset(&l, 0, sizeof(l));
	libusb_device_handle *h = libusb_open_device_with_vid_pid(ctx, (uint16_t)vid, (uint16_t)pid);
	if (!h) {
		fprintf(stderr, "swell-vm-usbtest: no USB device %04lx:%04lx (or no permission)\n", vid, pid);
		goto out_exit;
	}
	libusb_device *dev = libusb_get_device(h);
	if (find_vendor_iface(dev, &l) != 0) {
		fprintf(stderr, "swell-vm-usbtest: %04lx:%04lx has no vendor interface with bulk OUT and IN\n", vid,
			pid);
		goto out_close;
	}
	libusb_set_auto_detach_kernel_driver(h, 1);
	r = libusb_claim_interface(h, l.iface);
	if (r != 0) {
		fprintf(stderr, "swell-vm-usbtest: claim interface %d: %s\n", l.iface, libusb_strerror(r));
		goto out_close;
	}
	printf("usb %04lx:%04lx: %s, bus %u device %u, interface %d, bulk OUT 0x%02x (%d B), "
	       "bulk IN 0x%02x (%d B)\n",
	       vid, pid, speed_name(libusb_get_device_speed(dev)), libusb_get_bus_number(dev),
	       libusb_get_device_address(dev), l.iface, l.ep_out, l.mps_out, l.ep_in, l.mps_in);
	if ((want_out >= 0 && l.ep_out != want_out) || (want_in >= 0 && l.ep_in != want_in)) {
		fprintf(stderr, "swell-vm-usbtest: FAIL: endpoints 0x%02x/0x%02x, expected 0x%02lx/0x%02lx\n", l.ep_out,
			l.ep_in, want_out, want_in);
		goto out_release;
	}
	if (l.mps_out != PACKET_MAX || l.mps_in != PACKET_MAX) {
		fprintf(stderr, "swell-vm-usbtest: FAIL: max packet %d/%d bytes, expected %d\n", l.mps_out, l.mps_in,
			PACKET_MAX);
		goto out_release;
	}

	/* The device answers control requests to its interface with a stall; the link must survive. */
	uint8_t ctl[8];
	int in_r =
		libusb_control_transfer(h, LIBUSB_ENDPOINT_IN | LIBUSB_REQUEST_TYPE_VENDOR | LIBUSB_RECIPIENT_INTERFACE,
					0x01, 0, (uint16_t)l.iface, ctl, sizeof(ctl), (unsigned)timeout_ms);
	int out_r = libusb_control_transfer(
		h, LIBUSB_ENDPOINT_OUT | LIBUSB_REQUEST_TYPE_VENDOR | LIBUSB_RECIPIENT_INTERFACE, 0x02, 0,
		(uint16_t)l.iface, NULL, 0, (unsigned)timeout_ms);
	if (in_r != LIBUSB_ERROR_PIPE || out_r != LIBUSB_ERROR_PIPE) {
		fprintf(stderr,
			"swell-vm-usbtest: FAIL: vendor control requests gave %s (IN) and %s (OUT), "
			"expected a stall (%s)\n",
			in_r < 0 ? libusb_strerror(in_r) : "data", out_r < 0 ? libusb_strerror(out_r) : "success",
			libusb_strerror(LIBUSB_ERROR_PIPE));
		goto out_release;
	}

	uint8_t out[PACKET_MAX], in[PACKET_MAX];
	uint32_t bad = 0;
	double rtt_max = 0.0, t0 = vm_now_s();
	long done = 0;
	for (; done < count; done++) {
		int len = fill((uint32_t)done, vary, out), got = 0;
		double t1 = vm_now_s();
		r = libusb_bulk_transfer(h, l.ep_out, out, len, &got, (unsigned)timeout_ms);
		if (r != 0 || got != len) {
			fprintf(stderr, "swell-vm-usbtest: FAIL: packet %ld OUT: %s, %d of %d bytes sent\n", done,
				libusb_strerror(r), got, len);
			goto out_release;
		}
		r = libusb_bulk_transfer(h, l.ep_in, in, PACKET_MAX, &got, (unsigned)timeout_ms);
		if (r != 0) {
			fprintf(stderr, "swell-vm-usbtest: FAIL: packet %ld IN: %s (%ld of %ld echoed)\n", done,
				libusb_strerror(r), done, count);
			goto out_release;
		}
		double rtt = vm_now_s() - t1;
		if (rtt > rtt_max)
			rtt_max = rtt;
		if (got != len || memcmp(in, out, (size_t)len) != 0) {
			if (bad < 3)
				fprintf(stderr, "swell-vm-usbtest: packet %ld: sent %d bytes, got %d bytes%s\n", done,
					len, got, got == len ? " that differ" : "");
			bad++;
		}
	}
	double dt = vm_now_s() - t0;
	printf("usb echo: vendor control requests IN and OUT stalled; %ld packets (%s lengths), %u bad, %.1f ms, "
	       "%.0f packets/s, round trip mean %.0f us, max %.0f us\n",
	       done, vary ? "1..64 byte" : "64 byte", (unsigned)bad, dt * 1e3, (double)done / dt,
	       dt / (double)done * 1e6, rtt_max * 1e6);
	if (bad) {
		fprintf(stderr, "swell-vm-usbtest: FAIL: %u of %ld packets came back wrong\n", (unsigned)bad, count);
		goto out_release;
	}
	rc = 0;
out_release:
	libusb_release_interface(h, l.iface);
out_close:
	libusb_close(h);
out_exit:
	libusb_exit(ctx);
	return rc;
}
