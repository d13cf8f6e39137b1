/* swell-vm-cantest: bring up a SocketCAN interface through libsocketcan, and send a numbered frame
 * pattern from one interface to another, checking every frame arrives intact and in order. */
#define _DEFAULT_SOURCE

#include <errno.h>
#include <inttypes.h>
#include <libsocketcan.h>
#include <linux/can.h>
#include <linux/can/netlink.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "swell/cli.h"
#include "vm-util.h"

static const char usage[] =
	"usage: swell-vm-cantest up IFACE [--bitrate BIT_PER_S] [--restart-ms MS]\n"
	"       swell-vm-cantest pair TX RX [--count N] [--window W] [--timeout-ms MS]\n"
	"                                [--rtr-every K] [--rtr-dlc] [--dump]\n"
	"up:   set IFACE's bitrate (default 1000000 bit/s) and bus-off auto-restart (default\n"
	"      100 ms) through libsocketcan and start it; prints the bit timing the driver chose.\n"
	"pair: send N numbered frames (default 1000; standard and extended ids, RTR, DLC 0..8) on TX\n"
	"      with at most W frames in flight (default 8) and check that RX receives every one\n"
	"      intact and in order within MS (default 1000 ms) each. Prints frames/s and exits\n"
	"      non-zero if any frame is lost, corrupted or out of order. Every K-th frame\n"
	"      (default 16, 0: none) is a remote request, with DLC 0 unless --rtr-dlc.\n"
	"      --dump prints every received frame.\n";

static const char *state_name(int state)
{
	static const char *const names[] = {
		[CAN_STATE_ERROR_ACTIVE] = "error-active",
		[CAN_STATE_ERROR_WARNING] = "error-warning",
		[CAN_STATE_ERROR_PASSIVE] = "error-passive",
		[CAN_STATE_BUS_OFF] = "bus-off",
		[CAN_STATE_STOPPED] = "stopped",
		[CAN_STATE_SLEEPING] = "sleeping",
	};

	return state >= 0 && state < (int)(sizeof(names) / sizeof(names[0])) && names[state] ? names[state] : "unknown";
}

static int cmd_up(int argc, char **argv)
{
	long bitrate = 1000000, restart_ms = 100;
	const char *iface = NULL;
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_WHOLE("--bitrate", bitrate, 10000, 1000000, "bit/s"),
		SWELL_CLI_WHOLE("--restart-ms", restart_ms, 0, 60000, "ms"),
	};
	struct swell_cli cli = { .prog = "swell-vm-cantest",
				 .usage = usage,
				 .opt = opts,
				 .n_opt = SWELL_CLI_N(opts),
				 .words = &iface,
				 .max_words = 1 };

	swell_cli_parse(&cli, argc, argv);
	if (!iface) {
		fprintf(stderr, "swell-vm-cantest: up: missing IFACE (e.g. can0)\n");
		return 2;
	}
	if (if_nametoindex(iface) == 0) {
		fprintf(stderr, "swell-vm-cantest: up: no interface %s (driver loaded?)\n", iface);
		return 1;
	}
	can_do_stop(iface); /* the bitrate can only be set while the interface is down */
	if (can_set_bitrate(iface, (uint32_t)bitrate) < 0) {
		fprintf(stderr, "swell-vm-cantest: up: can_set_bitrate(%s, %ld) failed\n", iface, bitrate);
		return 1;
	}
	if (can_set_restart_ms(iface, (uint32_t)restart_ms) < 0) {
		fprintf(stderr, "swell-vm-cantest: up: can_set_restart_ms(%s, %ld) failed\n", iface, restart_ms);
		return 1;
	}
	if (can_do_start(iface) < 0) {
		fprintf(stderr, "swell-vm-cantest: up: can_do_start(%s) failed\n", iface);
		return 1;
	}
	struct can_bittiming bt;
	int state = -1;
	memset(&bt, 0, sizeof(bt));
	if (can_get_bittiming(iface, &bt) < 0 || can_get_state(iface, &state) < 0) {
		fprintf(stderr, "swell-vm-cantest: up: cannot read back %s's bit timing\n", iface);
		return 1;
	}
	if (bt.bitrate != (uint32_t)bitrate) {
		fprintf(stderr, "swell-vm-cantest: up: %s runs at %" PRIu32 " bit/s, asked for %ld\n", iface,
			bt.bitrate, bitrate);
		return 1;
	}
	char link[128], target[128];
	const char *driver = "?";
	snprintf(link, sizeof(link), "/sys/class/net/%s/device/driver", iface);
	ssize_t n = readlink(link, target, sizeof(target) - 1);
	if (n > 0) {
		target[n] = '\0';
		const char *slash = strrchr(target, '/');
		driver = slash ? slash + 1 : target;
	}
	printf("%s: up at %" PRIu32 " bit/s, sample point %.1f %%, tq %" PRIu32
	       " ns, restart %ld ms, state %s, driver %s\n",
	       iface, bt.bitrate, bt.sample_point / 10.0, bt.tq, restart_ms, state_name(state), driver);
	return 0;
}

/* Frame i of the pattern: ids, flags, lengths and bytes all depend on i. */
static long rtr_every = 16;
static int rtr_dlc; /* RTR frames with a DLC: QEMU 7.2's sja1000 then corrupts its RX FIFO */

static void pattern(uint32_t i, struct can_frame *f)
{
	memset(f, 0, sizeof(*f));
	uint32_t mix = i * 2654435761u;
	if (i % 4 == 1)
		f->can_id = CAN_EFF_FLAG | (mix & CAN_EFF_MASK);
	else
		f->can_id = (mix >> 8) & CAN_SFF_MASK;
	f->len = (uint8_t)(i % 9);
	if (rtr_every > 0 && i % (uint32_t)rtr_every == (uint32_t)rtr_every - 1) {
		f->can_id |= CAN_RTR_FLAG;
		if (!rtr_dlc)
			f->len = 0;
		return;
	}
	for (unsigned k = 0; k < f->len; k++)
		f->data[k] = (uint8_t)(i >> (8 * (k % 4)) ^ (k * 0x5Bu) ^ 0xA5u);
}

static int same(const struct can_frame *a, const struct can_frame *b)
{
	/* a remote frame's data is not compared */
	return a->can_id == b->can_id && a->len == b->len &&
		((a->can_id & CAN_RTR_FLAG) || memcmp(a->data, b->data, a->len) == 0);
}

static int open_raw(const char *iface)
{
	struct sockaddr_can addr;
	int s = socket(PF_CAN, SOCK_RAW, CAN_RAW);

	if (s < 0) {
		perror("swell-vm-cantest: socket(PF_CAN)");
		return -1;
	}
	memset(&addr, 0, sizeof(addr));
	addr.can_family = AF_CAN;
	addr.can_ifindex = (int)if_nametoindex(iface);
	if (addr.can_ifindex == 0 || bind(s, (struct sockaddr *)&addr, sizeof(addr)) < 0) {
		fprintf(stderr, "swell-vm-cantest: cannot bind to %s: %s\n", iface, strerror(errno));
		close(s);
		return -1;
	}
	return s;
}

static void print_frame(const char *what, const struct can_frame *f)
{
	fprintf(stderr, "  %s: id 0x%08" PRIx32 " len %u data", what, f->can_id, f->len);
	for (unsigned k = 0; k < f->len && k < 8; k++)
		fprintf(stderr, " %02x", f->data[k]);
	fprintf(stderr, "\n");
}

static int cmd_pair(int argc, char **argv)
{
	long count = 1000, window = 8, timeout_ms = 1000;
	int dump = 0;
	const char *ifs[2] = { NULL, NULL }; /* TX, RX */
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_WHOLE("--count", count, 1, 100000000, ""),
		SWELL_CLI_WHOLE("--window", window, 1, 64, "frames"),
		SWELL_CLI_WHOLE("--timeout-ms", timeout_ms, 1, 600000, "ms"),
		SWELL_CLI_WHOLE("--rtr-every", rtr_every, 0, 1000000, ""),
		SWELL_CLI_FLAG("--rtr-dlc", rtr_dlc),
		SWELL_CLI_FLAG("--dump", dump),
	};
	struct swell_cli cli = { .prog = "swell-vm-cantest",
				 .usage = usage,
				 .opt = opts,
				 .n_opt = SWELL_CLI_N(opts),
				 .words = ifs,
				 .max_words = 2 };
	const char *tx_if, *rx_if;

	swell_cli_parse(&cli, argc, argv);
	tx_if = ifs[0];
	rx_if = ifs[1];
	if (!tx_if || !rx_if) {
		fprintf(stderr, "swell-vm-cantest: pair: needs TX and RX interfaces (e.g. can0 can1)\n");
		return 2;
	}
	int tx = open_raw(tx_if), rx = open_raw(rx_if);
	if (tx < 0 || rx < 0)
		return 1;
	/* Error frames are counted, not compared: they tell of bus trouble. */
	can_err_mask_t err_mask = CAN_ERR_MASK;
	setsockopt(rx, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask));

	uint32_t sent = 0, received = 0, bad = 0, errframes = 0, nobufs = 0;
	double worst_ms = 0.0;
	double t0 = vm_now_s(), last_rx = t0;
	int rc = 0;
	while (received < (uint32_t)count) {
		while (sent < (uint32_t)count && sent - received < (uint32_t)window) {
			struct can_frame f;
			pattern(sent, &f);
			if (write(tx, &f, sizeof(f)) != (ssize_t)sizeof(f)) {
				if (errno == ENOBUFS) { /* the queue is full: let it drain */
					nobufs++;
					break;
				}
				fprintf(stderr, "swell-vm-cantest: write to %s: %s\n", tx_if, strerror(errno));
				rc = 1;
				goto out;
			}
			sent++;
		}
		struct pollfd p = { .fd = rx, .events = POLLIN, .revents = 0 };
		int r = poll(&p, 1, 1);
		double t = vm_now_s();
		if (r <= 0) {
			if ((t - last_rx) * 1e3 > (double)timeout_ms) {
				fprintf(stderr,
					"swell-vm-cantest: FAIL: no frame on %s for %ld ms: %" PRIu32
					" of %ld received, %" PRIu32 " sent\n",
					rx_if, timeout_ms, received, count, sent);
				rc = 1;
				goto out;
			}
			continue;
		}
		struct can_frame got, want;
		if (read(rx, &got, sizeof(got)) != (ssize_t)sizeof(got))
			continue;
		if (dump)
			print_frame("rx", &got);
		if (got.can_id & CAN_ERR_FLAG) {
			errframes++;
			continue;
		}
		if ((t - last_rx) * 1e3 > worst_ms && received > 0)
			worst_ms = (t - last_rx) * 1e3;
		last_rx = t;
		pattern(received, &want);
		if (!same(&got, &want)) {
			if (bad < 3) {
				fprintf(stderr, "swell-vm-cantest: frame %" PRIu32 " differs:\n", received);
				print_frame("sent", &want);
				print_frame("got ", &got);
			}
			bad++;
		}
		received++;
	}
	double dt = vm_now_s() - t0;
	printf("%s -> %s: %" PRIu32 " frames sent, %" PRIu32 " received, %" PRIu32
	       " corrupted or out of order, %" PRIu32 " error frames, %.1f ms, %.0f frames/s, "
	       "longest gap %.2f ms, window %ld, %" PRIu32 " ENOBUFS retries\n",
	       tx_if, rx_if, sent, received, bad, errframes, dt * 1e3, received / dt, worst_ms, window, nobufs);
	if (bad || errframes) {
		fprintf(stderr, "swell-vm-cantest: FAIL: %" PRIu32 " bad frames, %" PRIu32 " error frames in %ld\n",
			bad, errframes, count);
		rc = 1;
	}
out:
	close(tx);
	close(rx);
	return rc;
}

int main(int argc, char **argv)
{
	if (argc >= 2 && (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help"))) {
		fputs(usage, stdout);
		return 0;
	}
	if (argc >= 2 && !strcmp(argv[1], "up"))
		return cmd_up(argc - 1, argv + 1);
	if (argc >= 2 && !strcmp(argv[1], "pair"))
		return cmd_pair(argc - 1, argv + 1);
	fprintf(stderr, "swell-vm-cantest: expected 'up' or 'pair' (see --help)\n");
	return 2;
}
