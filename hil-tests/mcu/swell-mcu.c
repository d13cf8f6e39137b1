/* swell-mcu: the emulated STM32F405 running the product image (docs/stm32f405-emulator.md). */
#define _GNU_SOURCE
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include "mcu.h"
#include "mcu_can1.h"
#include "mcu_usb.h"
#include "swell/cli.h"

static const char usage[] =
	"usage: swell-mcu --image ELF [--seconds S] [--console FILE] [--cpi C] [--hse-hz HZ]\n"
	"                 [--hse-delay-us US] [--trace-irq FILE] [--can-tunnel PATH [--no-hello]]\n"
	"                 [--paced-by-device MS] [--tx-log FILE]\n"
	"                 [--report FILE] [--no-can] [--usb] [--usb-tunnel PATH [--usb-lockstep]\n"
	"                 [--usb-replug MS] [--usb-log FILE]] [--stop-tim2 S] [--on-reset end|restart]\n"
	"                 [--quiet]\n"
	"Runs the STM32F405 image ELF (the product image, swell-fw.elf, unmodified) on an emulated\n"
	"Cortex-M4 (unicorn) with register-level models of the peripherals it uses, in virtual time:\n"
	"a run repeats bit for bit. Prints the image's console (its USART) and, on stderr, a summary:\n"
	"virtual and host time, instructions, interrupts taken, time asleep in WFI.\n"
	"  --image ELF        the image (ELF32 ARM; its PT_LOAD segments go to flash and RAM)\n"
	"  --seconds S        virtual seconds to run (default 1)\n"
	"  --console FILE     the console USART's output (default: stdout)\n"
	"  --cpi C            cycles per instruction, a fixed cost (default 1: the repository's cycle\n"
	"                     figures count instructions, QEMU -icount)\n"
	"  --hse-hz HZ        the board's crystal (default 8000000, the image's default board; 0: none,\n"
	"                     the image falls back to HSI)\n"
	"  --hse-delay-us US  HSERDY this long after HSEON (default 1000)\n"
	"  --trace-irq FILE   every exception entry, tail-chain and return with its virtual time\n"
	"  --can-tunnel PATH  CAN1's bus on a Unix stream socket: listens on PATH, takes one connection\n"
	"                     (hil-tests/vm/run-vm --can-tunnel PATH), then runs with virtual time paced\n"
	"                     to wall time: never ahead of it, and a lag over 5 ms is not made up (virtual\n"
	"                     time goes on in step from there; the summary adds up what was lost). Frames\n"
	"                     both ways as 16-byte Linux struct can_frame records (le32 can_id with the\n"
	"                     EFF/RTR/ERR flags, u8 len, 3 pad, 8 data); a peer that does not take them\n"
	"                     holds the emulator up. The peer's frames wait in a queue of 64 for the bus,\n"
	"                     which takes the lowest id among each node's first (the id's low 4 bits);\n"
	"                     a full queue drops its least urgent frame, counted. The MCU starts when the\n"
	"                     peer's first frame comes (a hello: before it the VM's end of the line is not\n"
	"                     open); it goes onto the bus as any frame. Ends when the peer leaves (status\n"
	"                     0) or the time runs out.\n"
	"                     A frame of extended id 0x1F05B0FF from the peer is no frame: it puts CAN1\n"
	"                     bus-off when its turn comes (the HIL scenarios' bus-off, run-scenario f405-can)\n"
	"  --no-hello         with --can-tunnel: start at once, without waiting for the peer's first frame\n"
	"  --paced-by-device MS  with --can-tunnel or --usb-tunnel: the device clocks virtual time instead\n"
	"                     of the wall clock: before each TIM2 tick it waits until the device's sample\n"
	"                     came since the tick before (CAN: a DEVICE_POS from the peer, 0.6 ms ahead of\n"
	"                     the tick; USB: bulk OUT data from the host, 0.1 ms ahead: a quarter of the\n"
	"                     2500 Hz tick the image runs with its device on USB; a device in lockstep,\n"
	"                     swell-hm --lockstep, sends the next one when the tick's FORCE_CMD reaches it),\n"
	"                     at most MS of wall time; a wait that runs out means the device is gone:\n"
	"                     wall-time pacing until its next sample, so the image's silence limit counts\n"
	"                     ticks as on silicon (0: off; not with --usb-lockstep, where the host clocks)\n"
	"  --quiet            no summary on stderr\n"
	"  --tx-log FILE      every frame CAN1 sent: 'T_NS ID DLC DATA' (virtual ns of its EOF, hex id and\n"
	"                     bytes)\n"
	"  --report FILE      the run's figures that repeat bit for bit, one 'NAME VALUE' a line: virtual\n"
	"                     seconds, instructions, cycles, seconds asleep, exceptions taken by kind, IWDG\n"
	"                     refreshes, CAN1 frames sent, resets carried out, the exit status\n"
	"  --no-can           no CAN1 model (its registers read 0): the image finds no link and stops\n"
	"  --usb              the OTG FS model, no host attached (without --usb or --usb-tunnel the OTG FS\n"
	"                     registers read 0 and the image finds no USB; on silicon the core answers)\n"
	"  --usb-tunnel PATH  the OTG FS model behind a USB/IP server: listens on the Unix socket PATH, takes\n"
	"                     one connection (hil-tests/vm/run-vm --usb-tunnel PATH), address 3; paced to\n"
	"                     wall time as with --can-tunnel; ends when the host lets go (the session's end\n"
	"                     is the cable pulled out: the OTG FS core's suspend 6 ms later)\n"
	"  --usb-lockstep     with --usb-tunnel: the host clocks virtual time instead of the wall clock: it\n"
	"                     runs only while a URB (or the server's enumeration) waits on the device, and\n"
	"                     stands while the server has nothing pending, so a host that submits its next\n"
	"                     URB once the last is answered makes a run repeat bit for bit; with the cable\n"
	"                     out it runs by itself (--usb-replug)\n"
	"  --usb-replug MS    with --usb-tunnel: a host that lets go pulls the cable out and the run goes\n"
	"                     on; MS ms of virtual time later the next connection on PATH is the cable put\n"
	"                     back (bus reset, enumeration: a new session), taken when it comes\n"
	"                     (--usb-lockstep: virtual time stands until it comes); SIGTERM or SIGINT then\n"
	"                     ends the run with its summary\n"
	"  --usb-log FILE     with --usb-tunnel: the USB side in virtual time, one 'T_NS EVENT' a line:\n"
	"                     'session N in|out' (the cable), 'reset' (a host's bus reset), 'suspend' (the\n"
	"                     core's USBSUSP raised), 'suspend-seen' (the image's driver acknowledged it),\n"
	"                     'configured 0|1' (bulk IN endpoint 1 (de)activated, seen within 20 us),\n"
	"                     'tick' (each TIM2 update) and 'force FX FY FZ' (the image's record of the\n"
	"                     force it commands, safe.c, in cN, when it changes, seen within 20 us)\n"
	"  --stop-tim2 S      fault injection: TIM2's counter stops at S virtual seconds, until the next\n"
	"                     reset (the image's tick stops: its watchdog must bite)\n"
	"  --on-reset end|restart  a reset (the watchdog's, or one the image requests) ends the run (end,\n"
	"                     the default: status 3 or 5) or restarts the MCU (restart: every register to\n"
	"                     its reset value, RCC_CSR's flags saying why, memory kept) and runs on\n"
	"CAN1 is the bxCAN model; without --can-tunnel its bus is ideal and empty: every frame the image\n"
	"sends is acknowledged, nothing else comes.\n"
	"Exit status: 0 the virtual time ran out, 1 set-up error (image, files), 2 bad arguments,\n"
	"3 watchdog reset (the IWDG was not refreshed), 4 the CPU stopped (an instruction or access the\n"
	"emulator does not carry out: the report names the pc), 5 the image asked for a system reset.\n";

struct opts {
	const char *image, *console, *trace_irq, *tunnel, *tx_log, *report, *usb_tunnel, *usb_log;
	int no_can, usb, on_reset, no_hello, usb_lockstep;
	double usb_replug_ms;
	double stop_tim2, device_ms;
	double seconds, cpi;
	uint32_t hse_hz, hse_delay_us;
	int quiet;
};

static double host_seconds(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* The CAN tunnel: the bus side of CAN1 on a Unix stream socket, paced to wall time. */
#define TUNNEL_FRAME 16u
#define CAN_EFF 0x80000000u
#define CAN_RTR 0x40000000u
#define CAN_ERR 0x20000000u

#define TUNNEL_QUEUE 64u
#define TUNNEL_BUSOFF_ID 0x1F05B0FFu /* a frame of this extended id from the peer puts CAN1 bus-off */
#define MAX_LAG_S 0.005 /* pacing: behind by more than this, virtual time goes on from where it is */
#define TUNNEL_SNDBUF 4096 /* bytes queued towards the peer: 256 frames, at most a fraction of a second */
#define USB_ADDRESS 3u /* the address the USB/IP server gives the device */
/* --paced-by-device: virtual time waits this long before a tick for the device's sample (its frames
 * then take about 350 us on the bus, and the RX interrupt runs before the tick) */
#define DEVICE_LEAD_S 0.0006
/* over USB the sample is in the receive FIFO once its OUT is acknowledged: the OTG interrupt runs
 * before the tick within a quarter of the 2500 Hz tick, and the tick before has sent its FORCE_CMD */
#define DEVICE_LEAD_USB_S 0.0001

static volatile sig_atomic_t stop_signal; /* --usb-replug: SIGTERM or SIGINT ends the run */

static void on_stop_signal(int sig)
{
	stop_signal = sig;
}
#define LOCKSTEP_WAIT_MS 60000 /* --usb-lockstep: a host silent this long (wall time) ends the run */

struct tunnel {
	int fd;
	struct mcu_can1_dev *can;
	uint8_t buf[TUNNEL_FRAME];
	size_t have;
	/* frames from the peer wait here for the bus, in the order they came: one after the other, each
	 * its length in bits, the next by arbitration among each node's first (tunnel_deliver) */
	struct bxcan_frame q[TUNNEL_QUEUE];
	uint32_t qn;
	uint64_t bus_full; /* frames the bus could not carry: dropped from a full queue */
	uint32_t usb_out_seen; /* --paced-by-device over USB: the server's bulk OUT bytes at the last look */
	uint64_t bus_free; /* virtual time the last frame from the peer ends */
	/* pacing: virtual time runs at most as fast as the wall clock from wall0; when it falls more than
	 * MAX_LAG_S behind (a slow stretch, or a peer that did not take frames), wall0 moves up so that it
	 * goes on in step instead of racing to catch up; behind_s sums those moves */
	double wall0, behind_s;
	uint64_t lag_events;
	uint64_t rx, tx, dropped;
	int closed;
	FILE *log; /* --tx-log */
	struct mcu_usb_dev *usb; /* --usb-tunnel: the USB/IP server's device (NULL: none) */
	int usb_fd; /* the session's connection; -1 between sessions (the cable out) */
	int usb_lfd, usb_lockstep; /* --usb-replug: the listening socket, kept; --usb-lockstep */
	const char *usb_path;
	uint64_t usb_replug_units, replug_at; /* --usb-replug (MCU_NEVER: off); the next session's earliest */
	unsigned sessions;
	FILE *usb_log; /* --usb-log, with what it last saw */
	uint32_t force_addr, ulog_resets, ulog_suspends, ulog_seen;
	int32_t ulog_force[3];
	int ulog_cfg;
	uint64_t ulog_tick;
	/* --paced-by-device: before each TIM2 tick virtual time waits (at most device_s of wall time)
	 * until a DEVICE_POS came from the peer since the last tick; a wait that runs out means the device
	 * is gone (lost): wall-time pacing until its next sample */
	double device_s;
	const struct mcu_periph *tim2;
	uint64_t tick_at, waits, waited_out, busoffs;
	int sample, lost;
};

/* Listen on the Unix stream socket PATH; the listening fd, or -1. */
static int listen_on(const char *opt, const char *path)
{
	struct sockaddr_un a = { .sun_family = AF_UNIX };
	struct stat st;
	int lfd;

	if (strlen(path) >= sizeof(a.sun_path)) {
		fprintf(stderr, "swell-mcu: %s %s: path too long for a Unix socket\n", opt, path);
		return -1;
	}
	if (stat(path, &st) == 0) {
		if (!S_ISSOCK(st.st_mode)) {
			fprintf(stderr, "swell-mcu: %s %s: exists and is no socket\n", opt, path);
			return -1;
		}
		unlink(path); /* a socket left by an earlier run */
	}
	memcpy(a.sun_path, path, strlen(path) + 1);
	lfd = socket(AF_UNIX, SOCK_STREAM, 0);
	if (lfd < 0 || bind(lfd, (struct sockaddr *)&a, sizeof(a)) != 0 || listen(lfd, 1) != 0) {
		fprintf(stderr, "swell-mcu: %s %s: %s\n", opt, path, strerror(errno));
		if (lfd >= 0)
			close(lfd);
		return -1;
	}
	fprintf(stderr, "swell-mcu: %s: listening on %s\n", opt, path);
	return lfd;
}

/* Take one connection on the listening fd lfd (blocking); the connected fd, or -1. */
static int accept_one(const char *opt, const char *path, int lfd)
{
	int fd = accept(lfd, NULL, NULL);

	if (fd < 0)
		fprintf(stderr, "swell-mcu: %s %s: accept: %s\n", opt, path, strerror(errno));
	else
		fprintf(stderr, "swell-mcu: %s: peer connected\n", opt);
	return fd;
}

/* Listen on the Unix stream socket PATH and take one connection; the connected fd, or -1. */
static int listen_one(const char *opt, const char *path)
{
	int lfd = listen_on(opt, path), fd;

	if (lfd < 0)
		return -1;
	fd = accept_one(opt, path, lfd);
	close(lfd);
	unlink(path);
	return fd;
}

static void tunnel_tx(void *user, const struct bxcan_frame *f, uint64_t t_ns)
{
	struct tunnel *t = user;
	uint8_t rec[TUNNEL_FRAME] = { 0 };
	uint32_t id = (f->ide ? (f->id & 0x1FFFFFFFu) | CAN_EFF : f->id & 0x7FFu) | (f->rtr ? CAN_RTR : 0u);
	unsigned n = f->dlc > 8 ? 8u : f->dlc;

	if (t->log) {
		fprintf(t->log, "%llu %03x %u ", (unsigned long long)t_ns, (unsigned)f->id, (unsigned)f->dlc);
		for (unsigned i = 0; !f->rtr && i < n; i++)
			fprintf(t->log, "%02x", f->data[i]);
		fputc('\n', t->log);
	}
	if (t->fd < 0) {
		t->tx++;
		return;
	}
	if (t->closed)
		return;
	for (int i = 0; i < 4; i++)
		rec[i] = (uint8_t)(id >> (8 * i));
	rec[4] = (uint8_t)n;
	if (!f->rtr)
		memcpy(rec + 8, f->data, n);
	if (send(t->fd, rec, sizeof(rec), MSG_NOSIGNAL) != (ssize_t)sizeof(rec))
		t->closed = 1;
	else
		t->tx++;
}

/* Arbitration's rank: the lower, the more urgent (a standard id before an extended one of the same
 * base id); the swell protocol's node is an id's low 4 bits. */
static uint32_t frame_rank(const struct bxcan_frame *f)
{
	return f->ide ? (f->id >> 18) << 1 | 1u : f->id << 1;
}

static int node_first(const struct tunnel *t, uint32_t i)
{
	for (uint32_t j = 0; j < i; j++)
		if ((t->q[j].id & 0xFu) == (t->q[i].id & 0xFu))
			return 0;
	return 1;
}

static void tunnel_take(struct tunnel *t, uint32_t k)
{
	memmove(&t->q[k], &t->q[k + 1], (t->qn - k - 1) * sizeof(t->q[0]));
	t->qn--;
}

/* A frame from the peer into the queue; a full one gives up its least urgent frame (the latest of
 * them) for it, or this one when it is no more urgent. 1 when it was queued. */
static int tunnel_queue(struct tunnel *t, const struct bxcan_frame *f)
{
	uint32_t worst = 0;

	if (t->qn == TUNNEL_QUEUE) {
		t->bus_full++;
		for (uint32_t i = 1; i < t->qn; i++)
			if (frame_rank(&t->q[i]) >= frame_rank(&t->q[worst]))
				worst = i;
		if (frame_rank(f) >= frame_rank(&t->q[worst]) ||
		    (t->q[worst].ide && t->q[worst].id == TUNNEL_BUSOFF_ID))
			return 0;
		tunnel_take(t, worst);
	}
	t->q[t->qn++] = *f;
	return 1;
}

static void tunnel_frame(struct tunnel *t)
{
	const uint8_t *r = t->buf;
	uint32_t id = (uint32_t)r[0] | (uint32_t)r[1] << 8 | (uint32_t)r[2] << 16 | (uint32_t)r[3] << 24;
	struct bxcan_frame f = { 0 };

	if ((id & CAN_ERR) || r[4] > 8) {
		t->dropped++;
		return;
	}
	f.ide = (id & CAN_EFF) != 0;
	f.rtr = (id & CAN_RTR) != 0;
	f.id = f.ide ? id & 0x1FFFFFFFu : id & 0x7FFu;
	f.dlc = r[4];
	memcpy(f.data, r + 8, 8);
	if (!tunnel_queue(t, &f))
		return;
	if (!f.ide && !f.rtr && f.id >> 4 == 0x02u) /* DEVICE_POS (swell/proto_table.h), any node */
		t->sample = 1, t->lost = 0;
}

/* The queued frame whose turn on the bus has come: each ends at least a frame's length (with the 3
 * bits of intermission) after the one before it; it is taken as ending now, the hook's time. The
 * frames wait for virtual time, which the device's pace holds at a fraction of the wall clock, while
 * a flooding node in the VM sends at wall-clock speed: the bus takes the next frame by arbitration
 * (the lowest id among each node's first, a node's own frames in order), so that a device's sample
 * does not wait behind a flood of less urgent frames, and a full queue drops its least urgent frame
 * (tunnel_queue), as a saturated bus leaves those unsent. */
static void tunnel_deliver(struct mcu *m, struct tunnel *t)
{
	while (t->qn) {
		uint32_t k = 0;
		uint64_t len;

		if (t->q[0].ide && t->q[0].id == TUNNEL_BUSOFF_ID) { /* no frame: the tests' bus-off, now */
			bxcan_inject_bus_off(&t->can->b, mcu_can1_ns(m->now));
			mcu_can1_bus_rx(m, t->can, NULL);
			tunnel_take(t, 0);
			t->busoffs++;
			fprintf(stderr,
				"swell-mcu: CAN tunnel: CAN1 put bus-off at %.6f s virtual (the peer's request)\n",
				mcu_seconds(m->now));
			continue;
		}
		for (uint32_t i = 1; i < t->qn; i++)
			if (frame_rank(&t->q[i]) < frame_rank(&t->q[k]) && node_first(t, i))
				k = i;
		len = mcu_can1_units(bxcan_bits_ns(&t->can->b, bxcan_frame_bits(&t->q[k], NULL) + 3u));
		if (t->bus_free + len > m->now)
			return; /* not yet: the bus is still busy with the one before */
		t->bus_free = m->now;
		mcu_can1_bus_rx(m, t->can, &t->q[k]);
		tunnel_take(t, k);
		t->rx++;
	}
}

/* A readable CAN tunnel: the bytes of the next frame. -1 when the peer left. */
static int tunnel_read(struct mcu *m, struct tunnel *t)
{
	ssize_t n = read(t->fd, t->buf + t->have, TUNNEL_FRAME - t->have);

	if (n == 0 || (n < 0 && errno != EINTR && errno != EAGAIN)) {
		fprintf(stderr, "swell-mcu: CAN tunnel: the peer left at %.6f s virtual\n", mcu_seconds(m->now));
		t->closed = 1;
		return -1;
	}
	if (n > 0)
		t->have += (size_t)n;
	if (t->have == TUNNEL_FRAME) {
		tunnel_frame(t);
		t->have = 0;
	}
	return 0;
}

/* The tunnel's first frame comes from the peer (a hello, any frame): only then is the VM's end of
 * the line open, and bytes sent before it would reach its tty, not the bridge. The MCU starts then;
 * the hello goes onto the bus as any frame. -1 when the peer leaves first. */
static int wait_hello(struct tunnel *t)
{
	fprintf(stderr, "swell-mcu: CAN tunnel: waiting for the peer's first frame\n");
	while (t->have < TUNNEL_FRAME) {
		ssize_t n = read(t->fd, t->buf + t->have, TUNNEL_FRAME - t->have);

		if (n == 0 || (n < 0 && errno != EINTR)) {
			fprintf(stderr, "swell-mcu: CAN tunnel: the peer left before its first frame\n");
			return -1;
		}
		if (n > 0)
			t->have += (size_t)n;
	}
	tunnel_frame(t);
	t->have = 0;
	fprintf(stderr, "swell-mcu: CAN tunnel: the peer's first frame came: the MCU starts\n");
	return 0;
}

static int usb_hook(struct mcu *m, struct tunnel *t, short *events);

/* The USB device's sample: bulk OUT data the server handed the model since the last look (the host
 * link's requests share the endpoint: one of those counts as well, and so does a new session's
 * count starting again). */
static void usb_sample(struct tunnel *t)
{
	if (t->usb_fd >= 0 && t->usb->srv.stats.bytes_out != t->usb_out_seen) {
		t->usb_out_seen = t->usb->srv.stats.bytes_out;
		t->sample = 1, t->lost = 0;
	}
}

/* --paced-by-device, before a tick: read the tunnel (and step the USB server) until the device's
 * sample has come or device_s of wall time passed (then lost). 0, -1 when the peer left, or an exit
 * status. */
static int device_wait(struct mcu *m, struct tunnel *t)
{
	const double end = host_seconds() + t->device_s;

	t->waits++;
	while (!t->sample) {
		const double left = end - host_seconds();
		struct pollfd p[2] = { { t->fd, POLLIN, 0 }, { -1, POLLIN, 0 } };
		struct timespec ts = { 0, 0 };
		int r;

		if (t->usb) {
			r = usb_hook(m, t, &p[1].events);
			if (r)
				return r;
			usb_sample(t);
			if (t->sample)
				break;
			p[1].fd = t->usb_fd;
		}
		if (left <= 0 || stop_signal || (t->fd < 0 && t->usb_fd < 0)) {
			t->lost = 1;
			t->waited_out++;
			return 0;
		}
		/* USB: a NAKed transfer is retried at the next step, 1 ms at most apart */
		if (t->usb && left > 0.001) {
			ts.tv_nsec = 1000000;
		} else {
			ts.tv_sec = (time_t)left;
			ts.tv_nsec = (long)((left - (double)ts.tv_sec) * 1e9);
		}
		r = ppoll(p, 2, &ts, NULL);
		if (r < 0 && errno != EINTR)
			return -1;
		if (r > 0 && t->fd >= 0 && (p[0].revents & (POLLIN | POLLHUP | POLLERR)) && tunnel_read(m, t) != 0)
			return -1;
	}
	return 0;
}

static unsigned long long units_ns(uint64_t t)
{
	return (unsigned long long)(t * 1000u / (MCU_TIME_HZ / 1000000u));
}

/* --usb-log: what changed since the hook last looked (the model's events at their own times). */
static void usb_log_step(struct mcu *m, struct tunnel *t)
{
	const struct otgfs *o = &t->usb->otg;
	FILE *f = t->usb_log;
	int32_t fc[3] = { 0, 0, 0 };
	int cfg = (o->diepctl[1] >> 15) & 1; /* USBAEP of IN endpoint 1: the image's configuration */

	if (!f)
		return;
	if (t->tim2) {
		const uint64_t u = t->tim2->next_event(m, t->tim2->ctx);

		if (u != t->ulog_tick) {
			if (t->ulog_tick && t->ulog_tick <= m->now)
				fprintf(f, "%llu tick\n", units_ns(t->ulog_tick));
			t->ulog_tick = u;
		}
	}
	if (o->stats.resets != t->ulog_resets) {
		t->ulog_resets = o->stats.resets;
		fprintf(f, "%llu reset\n", units_ns(m->now));
	}
	if (o->stats.suspends != t->ulog_suspends) {
		t->ulog_suspends = o->stats.suspends;
		fprintf(f, "%llu suspend\n", units_ns(o->suspend_at));
	}
	if (o->stats.suspends_seen != t->ulog_seen) {
		t->ulog_seen = o->stats.suspends_seen;
		fprintf(f, "%llu suspend-seen\n", units_ns(o->suspend_seen_at));
	}
	if (cfg != t->ulog_cfg) {
		t->ulog_cfg = cfg;
		fprintf(f, "%llu configured %d\n", units_ns(m->now), cfg);
	}
	if (t->force_addr && uc_mem_read(m->uc, t->force_addr, fc, sizeof(fc)) == UC_ERR_OK &&
	    memcmp(fc, t->ulog_force, sizeof(fc)) != 0) {
		memcpy(t->ulog_force, fc, sizeof(fc));
		fprintf(f, "%llu force %d %d %d\n", units_ns(m->now), fc[0], fc[1], fc[2]);
	}
}

/* The USB side at a hook: the session's step, and between sessions (--usb-replug) the cable out until
 * the next connection. With --usb-lockstep it waits for the host while nothing waits on the device.
 * 0 on (*events: what the session's fd waits for), -1 the run ends (the host let go), or an exit
 * status. */
static int usb_hook(struct mcu *m, struct tunnel *t, short *events)
{
	*events = POLLIN;
	usb_log_step(m, t);
	if (t->usb_fd < 0) {
		struct pollfd p = { t->usb_lfd, POLLIN, 0 };
		int r;

		if (m->now < t->replug_at)
			return 0;
		r = poll(&p, 1, t->usb_lockstep ? LOCKSTEP_WAIT_MS : 0);
		if (r == 0 && t->usb_lockstep) {
			fprintf(stderr, "swell-mcu: USB tunnel: no new session within %d s (--usb-lockstep)\n",
				LOCKSTEP_WAIT_MS / 1000);
			return MCU_EXIT_ERROR;
		}
		if (r <= 0)
			return r < 0 && errno != EINTR ? MCU_EXIT_ERROR : 0; /* nobody yet: the cable stays out */
		if ((t->usb_fd = accept_one("--usb-tunnel", t->usb_path, t->usb_lfd)) < 0)
			return MCU_EXIT_ERROR;
		mcu_usb_serve(t->usb, t->usb_fd, USB_ADDRESS);
		t->sessions++;
		fprintf(stderr, "swell-mcu: USB tunnel: session %u (the cable in) at %.6f s virtual\n", t->sessions,
			mcu_seconds(m->now));
		if (t->usb_log)
			fprintf(t->usb_log, "%llu session %u in\n", units_ns(m->now), t->sessions);
	}
	for (;;) {
		enum usbip_step st = mcu_usb_step(m, t->usb);
		struct pollfd p;
		int r;

		if (st == USBIP_CLOSED) {
			fprintf(stderr, "swell-mcu: USB tunnel: the host let go at %.6f s virtual (%s)\n",
				mcu_seconds(m->now), t->usb->srv.error ? t->usb->srv.error : "closed");
			if (t->usb_log)
				fprintf(t->usb_log, "%llu session %u out\n", units_ns(m->now), t->sessions);
			if (t->usb_replug_units == MCU_NEVER)
				return -1;
			close(t->usb_fd);
			t->usb_fd = -1;
			t->replug_at = m->now + t->usb_replug_units;
			return 0;
		}
		if (usbip_server_wants_write(&t->usb->srv))
			*events |= POLLOUT;
		if (!t->usb_lockstep || usbip_server_waiting(&t->usb->srv))
			return 0;
		/* lockstep: nothing waits on the device, time stands until the host says more */
		p = (struct pollfd){ t->usb_fd, *events, 0 };
		r = poll(&p, 1, LOCKSTEP_WAIT_MS);
		if (r == 0) {
			fprintf(stderr, "swell-mcu: USB tunnel: the host sent nothing for %d s (--usb-lockstep)\n",
				LOCKSTEP_WAIT_MS / 1000);
			return MCU_EXIT_ERROR;
		}
		if (r < 0 && errno != EINTR)
			return MCU_EXIT_ERROR;
	}
}

/* The run's I/O hook with a tunnel: frames and USB/IP traffic in and out, virtual time held back to
 * wall time (the sleep wakes on either socket), or with --paced-by-device to the device's samples. */
static int tunnel_hook(struct mcu *m, void *ctx)
{
	struct tunnel *t = ctx;

	if (stop_signal)
		return -1;
	if (t->device_s > 0 && t->tim2 && (t->fd >= 0 || (t->usb && !t->usb_lockstep))) {
		const uint64_t u = t->tim2->next_event(m, t->tim2->ctx);
		const double lead = t->fd >= 0 ? DEVICE_LEAD_S : DEVICE_LEAD_USB_S;
		int r;

		if (u != t->tick_at) { /* a tick began: the next one waits for the next sample */
			t->tick_at = u;
			t->sample = 0;
		}
		if (!t->lost && u != MCU_NEVER && !t->sample && mcu_seconds(u - m->now) <= lead &&
		    (r = device_wait(m, t)) != 0)
			return r;
		if (!t->lost) /* the device clocks: no wall-time pacing, and none to make up after */
			t->wall0 = host_seconds() - mcu_seconds(m->now);
	}
	if (t->usb && t->usb_lockstep) { /* the host clocks: no wall-time pacing (no CAN tunnel then) */
		short ev;

		return usb_hook(m, t, &ev);
	}
	for (;;) {
		double ahead = mcu_seconds(m->now) - (host_seconds() - t->wall0);
		struct pollfd p[2] = { { t->fd, POLLIN, 0 }, { -1, POLLIN, 0 } };
		struct timespec ts = { 0, 0 };
		int r;

		if (t->closed)
			return -1;
		if (t->fd >= 0)
			tunnel_deliver(m, t);
		if (t->usb) {
			r = usb_hook(m, t, &p[1].events);
			if (r)
				return r;
			usb_sample(t);
			p[1].fd = t->usb_fd;
		}
		if (-ahead > MAX_LAG_S) {
			t->wall0 += -ahead;
			t->behind_s += -ahead;
			t->lag_events++;
			ahead = 0;
		}
		if (ahead > 0) {
			ts.tv_sec = (time_t)ahead;
			ts.tv_nsec = (long)((ahead - (double)ts.tv_sec) * 1e9);
		}
		r = ppoll(p, 2, &ts, NULL);
		if (r < 0 && errno != EINTR)
			return MCU_EXIT_ERROR;
		if (r <= 0) {
			if (ahead <= 0)
				return 0;
			continue;
		}
		if (t->fd >= 0 && (p[0].revents & (POLLIN | POLLHUP | POLLERR)) && tunnel_read(m, t) != 0)
			return -1;
		if (ahead <= 0 && !(p[0].revents & POLLIN))
			return 0; /* the USB side is stepped at the next hook */
	}
}

static const char *exc_name(unsigned e, char *buf, size_t len)
{
	static const char *const sys[16] = { "",           "Reset", "NMI",    "HardFault", "MemManage", "BusFault",
					     "UsageFault", "",      "",       "",          "",          "SVCall",
					     "DebugMon",   "",      "PendSV", "SysTick" };

	if (e < 16)
		return sys[e];
	switch (e - 16) {
	case 20:
		return "CAN1_RX0";
	case 19:
		return "CAN1_TX";
	case 21:
		return "CAN1_RX1";
	case 22:
		return "CAN1_SCE";
	case 28:
		return "TIM2";
	case 67:
		return "OTG_FS";
	default:
		snprintf(buf, len, "IRQ%u", e - 16);
		return buf;
	}
}

static int write_report(const char *path, struct mcu *m, const struct tunnel *t, int rc)
{
	FILE *f = fopen(path, "w");
	char b[16];

	if (!f) {
		fprintf(stderr, "swell-mcu: %s: %s\n", path, strerror(errno));
		return -1;
	}
	fprintf(f, "virtual_s %.9f\ninstructions %llu\ncycles %llu\nasleep_s %.9f\n", mcu_seconds(m->now),
		(unsigned long long)m->insns, (unsigned long long)m->cycles, mcu_seconds(m->wfi_units));
	for (unsigned e = 1; e < MCU_EXCS; e++)
		if (m->irq_taken[e])
			fprintf(f, "exceptions %s %llu\n", exc_name(e, b, sizeof(b)),
				(unsigned long long)m->irq_taken[e]);
	fprintf(f, "iwdg_refreshes %llu\ncan1_frames_sent %llu\nresets %llu\nexit %d\n",
		(unsigned long long)m->iwdg_refreshes, (unsigned long long)t->tx, (unsigned long long)m->resets, rc);
	return fclose(f) == 0 ? 0 : -1;
}

static void summary(struct mcu *m, double host_s, int rc)
{
	char b[16];
	double v = mcu_seconds(m->now);

	fprintf(stderr,
		"swell-mcu: %.6f s virtual in %.2f s host (%.2f x real time), %llu instructions, cpi %.3f, "
		"sysclk %u Hz, asleep in WFI %.1f %% of the time, exit %d\n",
		v, host_s, host_s > 0 ? v / host_s : 0.0, (unsigned long long)m->insns, m->cpi_milli / 1000.0,
		m->clk.sysclk_hz, v > 0 ? 100.0 * mcu_seconds(m->wfi_units) / v : 0.0, rc);
	fprintf(stderr, "swell-mcu: exceptions taken:");
	for (unsigned e = 1; e < MCU_EXCS; e++)
		if (m->irq_taken[e])
			fprintf(stderr, " %s %llu", exc_name(e, b, sizeof(b)), (unsigned long long)m->irq_taken[e]);
	fprintf(stderr, "\n");
}

/* Everything a run holds, allocated once. */
struct world {
	struct mcu m;
	struct mcu_can1_dev can;
	struct mcu_usb_dev usb;
	struct tunnel t;
	FILE *con;
};

static FILE *open_out(const char *path)
{
	FILE *f = fopen(path, "w");

	if (!f)
		fprintf(stderr, "swell-mcu: %s: %s\n", path, strerror(errno));
	return f;
}

/* Set up, run, report; the caller releases what w holds. */
static int run(const struct opts *o, struct world *w)
{
	struct mcu *m = &w->m;
	struct tunnel *t = &w->t;
	struct mcu_stm32_opts so;
	char why[256];
	double t0;
	int rc;

	if ((o->console && strcmp(o->console, "-") != 0 && !(w->con = open_out(o->console))) ||
	    (o->trace_irq && !(m->trace_irq = open_out(o->trace_irq))) ||
	    (o->tx_log && !(t->log = open_out(o->tx_log))))
		return MCU_EXIT_ERROR;
	so = (struct mcu_stm32_opts){ w->con, o->hse_hz, o->hse_delay_us };
	m->restart_on_reset = o->on_reset == 1;
	m->tim2_stop_at = o->stop_tim2 >= 0 ? (uint64_t)(o->stop_tim2 * (double)MCU_TIME_HZ + 0.5) : MCU_NEVER;
	if (mcu_init(m, (uint32_t)(o->cpi * 1000.0 + 0.5), why, sizeof(why)) != 0 ||
	    mcu_load_elf(m, o->image, why, sizeof(why)) != 0 || mcu_reset(m, why, sizeof(why)) != 0) {
		fprintf(stderr, "swell-mcu: %s\n", why);
		return MCU_EXIT_ERROR;
	}
	if (mcu_scs_add(m) != 0 || mcu_stm32_add(m, &so) != 0 || (!o->no_can && mcu_can1_add(m, &w->can) != 0) ||
	    ((o->usb || o->usb_tunnel) && mcu_usb_add(m, &w->usb) != 0)) {
		fprintf(stderr, "swell-mcu: the peripheral models could not be mapped\n");
		return MCU_EXIT_ERROR;
	}
	if (o->usb_tunnel) {
		t->usb_path = o->usb_tunnel;
		t->usb_lockstep = o->usb_lockstep;
		t->usb_replug_units = o->usb_replug_ms >= 0
			? (uint64_t)(o->usb_replug_ms * 1e-3 * (double)MCU_TIME_HZ + 0.5)
			: MCU_NEVER;
		if (o->usb_log) {
			if (!(t->usb_log = open_out(o->usb_log)))
				return MCU_EXIT_ERROR;
			setvbuf(t->usb_log, NULL, _IOLBF, 0); /* whole lines for a reader while it runs */
			t->force_addr = mcu_symbol_addr(m, "force_cN"); /* safe.c: the force last commanded */
			fprintf(t->usb_log, "# swell-mcu USB log: T_NS EVENT (virtual ns)%s\n",
				t->force_addr ? "" : "; the image has no force_cN: no force lines");
		}
		if (t->usb_replug_units == MCU_NEVER)
			t->usb_fd = listen_one("--usb-tunnel", o->usb_tunnel);
		else if ((t->usb_lfd = listen_on("--usb-tunnel", o->usb_tunnel)) >= 0)
			t->usb_fd = accept_one("--usb-tunnel", o->usb_tunnel, t->usb_lfd);
		if (t->usb_fd < 0)
			return MCU_EXIT_ERROR;
		mcu_usb_serve(&w->usb, t->usb_fd, USB_ADDRESS);
		t->usb = &w->usb;
		t->sessions = 1;
		if (t->usb_log)
			fprintf(t->usb_log, "0 session 1 in\n");
	}
	t->can = &w->can;
	t->device_s = o->device_ms / 1000.0;
	for (unsigned i = 0; i < m->n_periph; i++)
		if (!strcmp(m->periph[i].name, "TIM2"))
			t->tim2 = &m->periph[i];
	if (o->tunnel) {
		const int sndbuf = TUNNEL_SNDBUF;

		if ((t->fd = listen_one("--can-tunnel", o->tunnel)) < 0)
			return MCU_EXIT_ERROR;
		(void)setsockopt(t->fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof(sndbuf));
		if (!o->no_hello && wait_hello(t) != 0)
			return MCU_EXIT_OK;
	}
	if (!o->no_can)
		bxcan_set_tx_callback(&w->can.b, tunnel_tx, t);
	t0 = host_seconds();
	t->wall0 = t0;
	/* paced: the hook every 20 us of virtual time (a frame takes 47 us or more at 1 Mbit/s) */
	rc = mcu_run(m, (uint64_t)(o->seconds * (double)MCU_TIME_HZ + 0.5), MCU_TIME_HZ / 50000u,
		     o->tunnel || o->usb_tunnel ? tunnel_hook : 0, t);
	fflush(w->con);
	if (!o->quiet)
		summary(m, host_seconds() - t0, rc);
	if (o->tunnel && !o->quiet)
		fprintf(stderr,
			"swell-mcu: CAN tunnel: %llu frames to the peer, %llu from it (%llu dropped: error frames or "
			"length > 8; %llu the bus could not carry: dropped from the full queue)\n",
			(unsigned long long)t->tx, (unsigned long long)t->rx, (unsigned long long)t->dropped,
			(unsigned long long)t->bus_full);
	if ((o->tunnel || (o->usb_tunnel && !o->usb_lockstep)) && !o->quiet)
		fprintf(stderr,
			"swell-mcu: paced to the wall clock: virtual time fell behind it by %.1f ms in all, in %llu "
			"stretches over %.0f ms\n",
			1e3 * t->behind_s, (unsigned long long)t->lag_events, 1e3 * MAX_LAG_S);
	if ((o->tunnel || (o->usb_tunnel && !o->usb_lockstep)) && t->device_s > 0 && !o->quiet)
		fprintf(stderr,
			"swell-mcu: paced by the device: %llu ticks waited for its sample, %llu waits ran out "
			"(%.0f ms: the device gone, wall-time pacing until it came back)\n",
			(unsigned long long)t->waits, (unsigned long long)t->waited_out, 1e3 * t->device_s);
	if (o->usb_tunnel && !o->quiet)
		fprintf(stderr,
			"swell-mcu: USB tunnel: %u session(s); the last: %u URBs submitted, %u answered (%u with an "
			"error), %u bytes in, %u out\n",
			t->sessions, w->usb.srv.stats.submits, w->usb.srv.stats.ret_submits, w->usb.srv.stats.errors,
			w->usb.srv.stats.bytes_in, w->usb.srv.stats.bytes_out);
	if (o->report && write_report(o->report, m, t, rc) != 0 && rc == MCU_EXIT_OK)
		rc = MCU_EXIT_ERROR;
	return rc;
}

int main(int argc, char **argv)
{
	struct opts o = { .seconds = 1.0,
			  .cpi = 1.0,
			  .hse_hz = 8000000u,
			  .hse_delay_us = 1000u,
			  .stop_tim2 = -1,
			  .usb_replug_ms = -1 };
	const struct swell_cli_opt table[] = {
		SWELL_CLI_STR("--image", o.image),
		SWELL_CLI_NUM_ABOVE("--seconds", o.seconds, 0, 86400, "s"),
		SWELL_CLI_STR("--console", o.console),
		SWELL_CLI_NUM("--cpi", o.cpi, 0.5, 8, "cycles"),
		SWELL_CLI_WHOLE("--hse-hz", o.hse_hz, 0, 50000000, "Hz"),
		SWELL_CLI_WHOLE("--hse-delay-us", o.hse_delay_us, 0, 1000000, "us"),
		SWELL_CLI_STR("--trace-irq", o.trace_irq),
		SWELL_CLI_STR("--can-tunnel", o.tunnel),
		SWELL_CLI_FLAG("--no-hello", o.no_hello),
		SWELL_CLI_NUM("--paced-by-device", o.device_ms, 0, 60000, "ms"),
		SWELL_CLI_STR("--tx-log", o.tx_log),
		SWELL_CLI_STR("--report", o.report),
		SWELL_CLI_FLAG("--no-can", o.no_can),
		SWELL_CLI_FLAG("--usb", o.usb),
		SWELL_CLI_STR("--usb-tunnel", o.usb_tunnel),
		SWELL_CLI_FLAG("--usb-lockstep", o.usb_lockstep),
		SWELL_CLI_NUM("--usb-replug", o.usb_replug_ms, 0, 3600000, "ms"),
		SWELL_CLI_STR("--usb-log", o.usb_log),
		SWELL_CLI_NUM("--stop-tim2", o.stop_tim2, 0, 86400, "s"),
		SWELL_CLI_CHOICE("--on-reset", o.on_reset, "end|restart"),
		SWELL_CLI_FLAG("--quiet", o.quiet),
	};
	struct swell_cli cli = { .prog = "swell-mcu", .usage = usage, .opt = table, .n_opt = SWELL_CLI_N(table) };
	struct world *w;
	int rc;

	swell_cli_parse(&cli, argc, argv);
	if (!o.image)
		swell_cli_die("swell-mcu", "--image ELF is needed (see --help)");
	if (o.hse_hz && (MCU_TIME_HZ % o.hse_hz || o.hse_hz < 4000000u))
		swell_cli_die("swell-mcu", "--hse-hz %u: 4..50 MHz dividing %llu Hz", o.hse_hz,
			      (unsigned long long)MCU_TIME_HZ);
	if (o.no_can && (o.tunnel || o.tx_log))
		swell_cli_die("swell-mcu", "--no-can leaves no CAN1 for --can-tunnel or --tx-log");
	if (!o.usb_tunnel && (o.usb_lockstep || o.usb_replug_ms >= 0 || o.usb_log))
		swell_cli_die("swell-mcu", "--usb-lockstep, --usb-replug and --usb-log need --usb-tunnel");
	if (o.usb_lockstep && o.tunnel)
		swell_cli_die("swell-mcu", "--usb-lockstep: the USB host clocks virtual time, a CAN tunnel cannot");
	if (o.usb_lockstep && o.device_ms > 0)
		swell_cli_die("swell-mcu",
			      "--usb-lockstep: the USB host clocks virtual time, --paced-by-device cannot");
	if (o.usb_replug_ms >= 0) {
		signal(SIGTERM, on_stop_signal);
		signal(SIGINT, on_stop_signal);
	}
	w = calloc(1, sizeof(*w));
	if (!w)
		return MCU_EXIT_ERROR;
	w->con = stdout;
	w->t.fd = w->t.usb_fd = w->t.usb_lfd = -1;
	rc = run(&o, w);
	if (w->t.fd >= 0)
		close(w->t.fd);
	if (w->t.usb_fd >= 0)
		close(w->t.usb_fd);
	if (w->t.usb_lfd >= 0) {
		close(w->t.usb_lfd);
		unlink(o.usb_tunnel);
	}
	if (w->t.usb_log)
		fclose(w->t.usb_log);
	if (w->t.log)
		fclose(w->t.log);
	if (w->con && w->con != stdout)
		fclose(w->con);
	if (w->m.trace_irq)
		fclose(w->m.trace_irq);
	mcu_free(&w->m);
	free(w);
	return rc;
}
