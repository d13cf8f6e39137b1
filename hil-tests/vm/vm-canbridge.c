/* swell-vm-canbridge: joins the CAN tunnel (a serial line carrying classic CAN frames as the
 * 16 bytes of Linux struct can_frame, can_id little-endian) to a SocketCAN interface, both ways,
 * so programs in the VM see the peer at the tunnel's other end (the emulated STM32F405) as a node
 * on that bus. Neither direction waits for the other: frames for the line wait in a queue of their
 * own while the line is full, and the line is read all the while. (Written in one go, a full line
 * stopped the bridge from reading it; the peer, whose frames then filled the other direction, stopped
 * reading its end: both waited for good. A third node's flood did that.) */
#define _DEFAULT_SOURCE

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include "swell/cli.h"
#include "vm-line.h"
#include "vm-util.h"

#define TUNNEL_FRAME_BYTES 16u

static const char usage[] =
	"usage: swell-vm-canbridge [--tty PATH] [--if IFACE] [--ready-file PATH]\n"
	"Copies classic CAN frames between the tunnel serial line PATH (default /dev/ttyS1; each\n"
	"frame is 16 bytes: u32 can_id little-endian with the EFF/RTR/ERR flags, u8 len, 3 pad,\n"
	"8 data) and the SocketCAN interface IFACE (default can0), both ways, until SIGTERM or\n"
	"SIGINT, or until the line closes. Frames with len > 8 from the line are counted and dropped.\n"
	"Frames for the line wait in a queue of 64 while the line is full; a frame that comes when it\n"
	"is full drops the queue's lowest-priority frame (highest id) if it outranks it, else itself,\n"
	"as arbitration leaves the least urgent frames unsent on a saturated bus; counted.\n"
	"Writes PATH of --ready-file once both ends are open. At the end prints the frame counts.\n"
	"Exit status: 0 stopped by a signal or the line closed, 1 a line or CAN I/O error, 2 bad arguments.\n";

struct bridge_counts {
	uint64_t line_to_can;
	uint64_t can_to_line;
	uint64_t bad_len;
	uint64_t can_write_fail;
	uint64_t line_dropped; /* for the line, dropped from a full queue */
};

/* Frames for the line: q[0] may be partly written (head_sent bytes of it). */
#define LINE_QUEUE 64u
struct line_queue {
	struct can_frame q[LINE_QUEUE];
	size_t n, head_sent;
};

static int open_can(const char *iface)
{
	struct sockaddr_can addr;
	unsigned int index = if_nametoindex(iface);
	int fd;

	if (index == 0)
		return -1;
	fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
	if (fd < 0)
		return -1;
	memset(&addr, 0, sizeof(addr));
	addr.can_family = AF_CAN;
	addr.can_ifindex = (int)index;
	if (bind(fd, (struct sockaddr *)&addr, sizeof(addr)) != 0) {
		close(fd);
		return -1;
	}
	return fd;
}

static void frame_to_bytes(const struct can_frame *f, uint8_t out[TUNNEL_FRAME_BYTES])
{
	memset(out, 0, TUNNEL_FRAME_BYTES);
	out[0] = (uint8_t)(f->can_id & 0xffu);
	out[1] = (uint8_t)((f->can_id >> 8) & 0xffu);
	out[2] = (uint8_t)((f->can_id >> 16) & 0xffu);
	out[3] = (uint8_t)((f->can_id >> 24) & 0xffu);
	out[4] = f->len;
	memcpy(out + 8, f->data, 8);
}

static int bytes_to_frame(const uint8_t in[TUNNEL_FRAME_BYTES], struct can_frame *f)
{
	if (in[4] > CAN_MAX_DLEN)
		return -1;
	memset(f, 0, sizeof(*f));
	f->can_id = (canid_t)in[0] | (canid_t)in[1] << 8 | (canid_t)in[2] << 16 | (canid_t)in[3] << 24;
	f->len = in[4];
	memcpy(f->data, in + 8, 8);
	return 0;
}

/* Frames moved per system call at most: under TCG each call costs the VM tens of microseconds, so a
 * backlog goes in batches rather than one frame a call. */
#define BATCH_FRAMES 64u

/* Writes every whole frame of buf[0..*have) to the interface and keeps the partial one's bytes at
 * the front. */
static void line_frames_to_can(int can_fd, uint8_t *buf, size_t *have, struct bridge_counts *c)
{
	size_t off = 0;

	for (; *have - off >= TUNNEL_FRAME_BYTES; off += TUNNEL_FRAME_BYTES) {
		struct can_frame f;

		if (bytes_to_frame(buf + off, &f) != 0) {
			c->bad_len++;
		} else if (write(can_fd, &f, sizeof(f)) != (ssize_t)sizeof(f)) {
			/* a full queue or bus-off on the VM side: the frame is lost, as on a bus */
			c->can_write_fail++;
		} else {
			c->line_to_can++;
		}
	}
	memmove(buf, buf + off, *have - off);
	*have -= off;
}

/* Arbitration's rank of a frame: the lower, the more urgent (a standard id before an extended one
 * of the same base id). */
static uint32_t rank(const struct can_frame *f)
{
	return f->can_id & CAN_EFF_FLAG ? ((f->can_id & CAN_EFF_MASK) >> 18) << 1 | 1u
					: (f->can_id & CAN_SFF_MASK) << 1;
}

/* A frame into the queue; a full queue gives up its least urgent frame not yet begun, or this one. */
static void enqueue(struct line_queue *lq, const struct can_frame *f, struct bridge_counts *c)
{
	size_t worst = lq->head_sent ? 1 : 0, i;

	if (lq->n < LINE_QUEUE) {
		lq->q[lq->n++] = *f;
		return;
	}
	c->line_dropped++;
	for (i = worst + 1; i < lq->n; i++)
		if (rank(&lq->q[i]) >= rank(&lq->q[worst]))
			worst = i; /* the latest of the least urgent */
	if (worst >= lq->n || rank(f) >= rank(&lq->q[worst]))
		return;
	memmove(&lq->q[worst], &lq->q[worst + 1], (lq->n - worst - 1) * sizeof(lq->q[0]));
	lq->q[lq->n - 1] = *f;
}

/* Reads the frames the interface has queued (at most BATCH_FRAMES) into the line's queue. */
static void can_frames_to_queue(int can_fd, struct line_queue *lq, struct bridge_counts *c)
{
	for (size_t n = 0; n < BATCH_FRAMES; n++) {
		struct can_frame f;

		if (recv(can_fd, &f, sizeof(f), MSG_DONTWAIT) != (ssize_t)sizeof(f))
			break;
		enqueue(lq, &f, c);
		c->can_to_line++;
	}
}

/* Writes what the line takes of the queue without waiting. 0, or -1 on an I/O error of the line. */
static int queue_to_line(int line_fd, struct line_queue *lq)
{
	uint8_t out[BATCH_FRAMES * TUNNEL_FRAME_BYTES];
	size_t k = lq->n < BATCH_FRAMES ? lq->n : BATCH_FRAMES, done;
	ssize_t w;

	for (size_t i = 0; i < k; i++)
		frame_to_bytes(&lq->q[i], out + i * TUNNEL_FRAME_BYTES);
	w = write(line_fd, out + lq->head_sent, k * TUNNEL_FRAME_BYTES - lq->head_sent);
	if (w < 0)
		return errno == EINTR || errno == EAGAIN ? 0 : -1;
	done = lq->head_sent + (size_t)w;
	lq->head_sent = done % TUNNEL_FRAME_BYTES;
	done /= TUNNEL_FRAME_BYTES;
	memmove(&lq->q[0], &lq->q[done], (lq->n - done) * sizeof(lq->q[0]));
	lq->n -= done;
	return 0;
}

/* Moves frames until a stop signal or the end of the line; returns 0, or -1 on an I/O error. */
static int run_bridge(int line_fd, int can_fd, struct bridge_counts *c)
{
	uint8_t acc[BATCH_FRAMES * TUNNEL_FRAME_BYTES];
	size_t have = 0;
	static struct line_queue lq;

	(void)fcntl(line_fd, F_SETFL, fcntl(line_fd, F_GETFL) | O_NONBLOCK);
	while (!vm_stop) {
		struct pollfd pfd[2] = { { .fd = line_fd, .events = POLLIN }, { .fd = can_fd, .events = POLLIN } };
		int n;

		if (lq.n)
			pfd[0].events |= POLLOUT;
		n = poll(pfd, 2, 200);

		if (n < 0) {
			if (errno == EINTR)
				continue;
			return -1;
		}
		if (pfd[0].revents & (POLLIN | POLLHUP | POLLERR)) {
			ssize_t r = read(line_fd, acc + have, sizeof(acc) - have);

			if (r == 0)
				return 0; /* the peer closed the line */
			if (r < 0 && errno != EINTR && errno != EAGAIN)
				return -1;
			if (r > 0) {
				have += (size_t)r;
				line_frames_to_can(can_fd, acc, &have, c);
			}
		}
		if (pfd[1].revents & POLLIN)
			can_frames_to_queue(can_fd, &lq, c);
		if (lq.n && queue_to_line(line_fd, &lq) != 0)
			return -1;
	}
	return 0;
}

int main(int argc, char **argv)
{
	const char *tty = "/dev/ttyS1", *iface = "can0", *ready = NULL;
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_STR("--tty", tty),
		SWELL_CLI_STR("--if", iface),
		SWELL_CLI_STR("--ready-file", ready),
	};
	struct swell_cli cli = {
		.prog = "swell-vm-canbridge", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts)
	};
	struct bridge_counts c = { 0 };
	int line_fd, can_fd, rc;

	swell_cli_parse(&cli, argc, argv);
	vm_catch_stop();
	can_fd = open_can(iface);
	if (can_fd < 0) {
		fprintf(stderr, "swell-vm-canbridge: cannot open CAN interface %s: %s\n", iface, strerror(errno));
		return 1;
	}
	line_fd = vm_open_line(tty);
	if (line_fd < 0) {
		fprintf(stderr, "swell-vm-canbridge: cannot open the tunnel line %s: %s\n", tty, strerror(errno));
		close(can_fd);
		return 1;
	}
	if (ready) {
		FILE *f = fopen(ready, "w");

		if (f)
			fclose(f);
	}
	rc = run_bridge(line_fd, can_fd, &c);
	printf("swell-vm-canbridge: %s <-> %s: %" PRIu64 " frames line->can, %" PRIu64 " can->line, %" PRIu64
	       " bad length, %" PRIu64 " refused by the interface, %" PRIu64 " of can->line dropped from the full "
	       "queue\n",
	       tty, iface, c.line_to_can, c.can_to_line, c.bad_len, c.can_write_fail, c.line_dropped);
	if (rc != 0)
		fprintf(stderr, "swell-vm-canbridge: I/O error: %s\n", strerror(errno));
	close(line_fd);
	close(can_fd);
	return rc != 0 ? 1 : 0;
}
