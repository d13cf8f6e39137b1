/* swell-ffs-echo: the USB device of the VM bench. Writes the vendor interface (class 0xFF, bulk OUT
 * 0x01, bulk IN 0x81, 64-byte packets) to a FunctionFS instance and echoes every OUT packet on IN,
 * through the link library's FunctionFS link (swell_link_open_ffs). */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/cli.h"
#include "swell/link.h"
#include "vm-util.h"

#define PACKET 64u

/* "64-byte": PACKET */
static const char usage[] =
	"usage: swell-ffs-echo [--count N] DIR\n"
	"Be the USB device of the hardware-in-the-loop VM: write the descriptors of one vendor\n"
	"interface (class 0xFF, bulk OUT 0x01, bulk IN 0x81, 64-byte full-speed packets) to DIR/ep0\n"
	"of a mounted FunctionFS instance, then send every packet received on OUT back on IN.\n"
	"  --count N   exit after N packets echoed (default 0: until SIGTERM/SIGINT)\n"
	"On exit prints the packets and bytes echoed. The gadget (VID/PID, UDC) is set up in\n"
	"configfs by the caller (hil-tests/vm/vm-gadget).\n"
	"Exit status: 0 done (N packets echoed, or SIGTERM/SIGINT), 1 the FunctionFS instance cannot be\n"
	"opened or a transfer failed, 2 bad arguments.\n";

/* The link library's FunctionFS link: what swell-ctl's USB links are. A packet that finds every IN
 * slot in flight waits for one (a transfer's end wakes the poll); one received before an unplug is
 * not echoed into the next session. Returns 1 when it is done with (sent or dropped). */
static int echo(struct swell_link *l, const struct swell_frame *f, unsigned long long *bytes)
{
	const int rc = swell_link_send(l, f);
	struct pollfd p = { .fd = swell_link_poll_fd(l), .events = POLLIN, .revents = 0 };

	if (rc == 0)
		*bytes += f->len;
	if (rc != -EBUSY)
		return 1;
	(void)poll(&p, 1, 100);
	return 0;
}

int main(int argc, char **argv)
{
	const struct swell_usb_ffs_iface iface = {
		.class_code = 0xFF,
		.ep_out = 0x01,
		.ep_in = 0x81,
		.fs_packet = PACKET,
		.name = "swell vendor link",
	};
	unsigned long long count = 0, bytes = 0;
	const char *dir = NULL;
	struct swell_link *l;
	struct swell_frame f;
	int pending = 0, rc;

	const struct swell_cli_opt opts[] = { SWELL_CLI_WHOLE("--count", count, 0, 1e18, "packets") };
	struct swell_cli cli = { .prog = "swell-ffs-echo",
				 .usage = usage,
				 .opt = opts,
				 .n_opt = SWELL_CLI_N(opts),
				 .words = &dir,
				 .max_words = 1 };

	swell_cli_parse(&cli, argc, argv);
	if (!dir) {
		fprintf(stderr, "swell-ffs-echo: missing DIR, the FunctionFS mount point (see --help)\n");
		return 2;
	}

	vm_catch_stop();

	rc = swell_link_open_ffs(&l, dir, &iface);
	if (rc < 0) {
		fprintf(stderr, "swell-ffs-echo: %s/ep0: %s\n", dir, strerror(-rc));
		return 1;
	}
	rc = 0;
	while (!vm_stop && (count == 0 || swell_link_get_counters(l)->tx_frames < count)) {
		if (!pending) { /* ep0's events and the next packet, waiting up to 100 ms */
			const int r = swell_link_recv(l, &f, 100);

			pending = r == 0;
			if (r < 0 && r != -ETIMEDOUT && r != -ENODEV) {
				fprintf(stderr, "swell-ffs-echo: %s\n", strerror(-r));
				rc = 1;
				break;
			}
		}
		if (pending && echo(l, &f, &bytes))
			pending = 0;
	}
	const struct swell_usb_ffs_stats *u = swell_link_ffs_stats(l);
	printf("swell-ffs-echo: %llu packets echoed, %llu bytes, %u control requests stalled, "
	       "%u writes waited for a free IN slot\n",
	       (unsigned long long)swell_link_get_counters(l)->tx_frames, bytes, (unsigned)u->setup_stalled,
	       (unsigned)u->tx_busy_drops);
	swell_link_close(l);
	return rc;
}
