/* swell-ffs-echo: the USB device of the VM bench. Writes the vendor interface (class 0xFF, bulk OUT
 * 0x01, bulk IN 0x81, 64-byte packets) to a FunctionFS instance and echoes every OUT packet on IN. */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/usb_ffs.h"

#define PACKET 64u

static volatile sig_atomic_t stop;

static void on_signal(int sig)
{
	(void)sig;
	stop = 1;
}

static void usage(FILE *to)
{
	fprintf(to,
		"usage: swell-ffs-echo [--count N] [--verbose] DIR\n"
		"Be the USB device of the hardware-in-the-loop VM: write the descriptors of one vendor\n"
		"interface (class 0xFF, bulk OUT 0x01, bulk IN 0x81, %u-byte full-speed packets) to DIR/ep0\n"
		"of a mounted FunctionFS instance, then send every packet received on OUT back on IN.\n"
		"  --count N   exit after N packets echoed (default 0: until SIGTERM/SIGINT)\n"
		"  --verbose   print every ep0 event\n"
		"On exit prints the packets and bytes echoed. The gadget (VID/PID, UDC) is set up in\n"
		"configfs by the caller (hil-tests/vm/vm-gadget).\n",
		PACKET);
}

static const char *event_name(enum swell_usb_ffs_event ev)
{
	static const char *const name[] = { "none",    "bind",  "unbind", "enable", "disable", "setup (stalled)",
					    "suspend", "resume" };
	return (unsigned)ev < sizeof(name) / sizeof(name[0]) ? name[ev] : "?";
}

int main(int argc, char **argv)
{
	static struct swell_usb_ffs ffs;
	static uint8_t buf[PACKET];
	const struct swell_usb_ffs_iface iface = {
		.class_code = 0xFF,
		.subclass = 0,
		.protocol = 0,
		.ep_out = 0x01,
		.ep_in = 0x81,
		.fs_packet = PACKET,
		.name = "swell vendor link",
	};
	unsigned long long count = 0, echoed = 0, bytes = 0;
	size_t pending = 0; /* bytes of a received packet not yet queued back */
	const char *dir = NULL;
	int verbose = 0;

	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
			usage(stdout);
			return 0;
		} else if (!strcmp(argv[i], "--count") && i + 1 < argc) {
			char *end;
			errno = 0;
			count = strtoull(argv[++i], &end, 10);
			if (errno || *end || argv[i][0] == '-') {
				fprintf(stderr, "swell-ffs-echo: --count needs a number of packets, not '%s'\n",
					argv[i]);
				return 2;
			}
		} else if (!strcmp(argv[i], "--verbose")) {
			verbose = 1;
		} else if (argv[i][0] != '-' && !dir) {
			dir = argv[i];
		} else {
			fprintf(stderr, "swell-ffs-echo: unexpected argument '%s' (see --help)\n", argv[i]);
			return 2;
		}
	}
	if (!dir) {
		fprintf(stderr, "swell-ffs-echo: missing DIR, the FunctionFS mount point (see --help)\n");
		return 2;
	}

	struct sigaction sa;
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal; /* no SA_RESTART: poll returns EINTR */
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);

	enum swell_err err = swell_usb_ffs_open(&ffs, dir, &iface);
	if (err != SWELL_OK) {
		fprintf(stderr, "swell-ffs-echo: %s/ep0: %s (%s)\n", dir, swell_err_str(err), strerror(ffs.last_errno));
		return 1;
	}
	if (verbose)
		printf("swell-ffs-echo: descriptors written to %s/ep0\n", dir);

	int rc = 0;
	while (!stop && (count == 0 || echoed < count)) {
		/* Sleep until an ep0 event or a finished transfer; nothing below blocks. */
		struct pollfd pfd[2] = {
			{ .fd = ffs.ep0, .events = POLLIN, .revents = 0 },
			{ .fd = swell_usb_ffs_data_fd(&ffs), .events = POLLIN, .revents = 0 },
		};
		if (poll(pfd, 2, 100) < 0 && errno != EINTR) {
			perror("swell-ffs-echo: poll");
			rc = 1;
			break;
		}
		enum swell_usb_ffs_event ev;
		err = swell_usb_ffs_poll(&ffs, 0, &ev);
		if (err != SWELL_OK) {
			fprintf(stderr, "swell-ffs-echo: ep0: %s (%s)\n", swell_err_str(err), strerror(ffs.last_errno));
			rc = 1;
			break;
		}
		if (ev != SWELL_USB_FFS_NONE && verbose)
			printf("swell-ffs-echo: event %s\n", event_name(ev));
		if (!swell_usb_ffs_enabled(&ffs))
			continue;
		size_t n;
		/* Echo what has arrived; a full IN queue leaves the packet for the next round. */
		while (!pending && swell_usb_ffs_read(&ffs, buf, sizeof(buf), &n) == SWELL_OK && n > 0) {
			pending = n;
			if (swell_usb_ffs_write(&ffs, buf, n) != SWELL_OK)
				break;
			pending = 0;
			echoed++;
			bytes += n;
		}
		if (pending && swell_usb_ffs_write(&ffs, buf, pending) == SWELL_OK) {
			echoed++;
			bytes += pending;
			pending = 0;
		}
	}
	printf("swell-ffs-echo: %llu packets echoed, %llu bytes, %u control requests stalled, "
	       "%u writes waited for a free IN slot\n",
	       echoed, bytes, (unsigned)ffs.setup_stalled, (unsigned)ffs.tx_busy_drops);
	swell_usb_ffs_close(&ffs);
	return rc;
}
