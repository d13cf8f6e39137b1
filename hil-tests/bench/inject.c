/* swell-inject: the bench's third node. Puts bad, foreign or too many frames on a link, and asks a
 * controller for parameter sets it must refuse. Host code (a bench tool, never on the controller). */
#define _GNU_SOURCE
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <linux/can.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include "swell/cli.h"
#include "swell/link.h"
#include "swell/param_table.h"
#include "swell/transport.h"

static const char usage[] =
	"usage: swell-inject garbage LINK [--count N] [--rate HZ] [--seed S]\n"
	"       swell-inject flood LINK [--seconds S] [--id HEX]\n"
	"       swell-inject params LINK [--node N] [--timeout-ms MS]\n"
	"       swell-inject can-errors can:IFACE [--seconds S] [--restart frame|none]\n"
	"The hardware-in-the-loop bench's third node.\n"
	"\n"
	"  garbage  N frames (default 2000) at HZ (default 1000; 0: as fast as the link takes them) that\n"
	"           a controller must count and drop or ignore: short and long frames, fields out of range,\n"
	"           unknown and 29-bit ids, remote frames (CAN); bad CRC, magic, version, count (packets);\n"
	"           valid device samples addressed to another node (--foreign-node, default 5)\n"
	"  flood    valid-looking frames of one id (default 0x7f5: a HEIGHT_QUAD of node 5, lowest\n"
	"           priority) as fast as the link takes them for S seconds (default 2)\n"
	"  params   out-of-range PARAM_SETs to the controller's host link: each must be answered by a\n"
	"           PARAM_NACK and leave the value (read back with PARAM_GET) unchanged; a request whose\n"
	"           answer does not come within the timeout is sent again (up to 3 times)\n"
	"  can-errors  the error frames a CAN driver reports when its controller goes error-warning,\n"
	"           error-passive and bus-off, then, S seconds later (default 0.5), restarted: written to\n"
	"           IFACE as error frames, which the kernel hands to every socket that asked for them only\n"
	"           on a virtual bus (vcan); a controller on IFACE must zero the force, report the bus-off\n"
	"           and recover after the restart. Prints the CLOCK_MONOTONIC time of each frame.\n"
	"           --restart none: no restart frame (the bench restarts the interface itself, e.g. down/up)\n"
	"LINK: can:IFACE (SocketCAN), udp[:PORT] (garbage/flood: to the controller's device port,\n"
	"      default 47800; params: listen on the viewer port, default 47801, answer the controller),\n"
	"      usb[:VID:PID] (params: libusb, default 1209:0001, interface --iface N, default 0; bulk\n"
	"      endpoints from its descriptor)\n"
	"Prints one summary line with counts and rates; exit 0 when every check held, 1 when one failed,\n"
	"2 for bad arguments or a link that cannot be opened.\n";

static void die(const char *msg, const char *arg)
{
	fprintf(stderr, "swell-inject: %s%s\n", msg, arg ? arg : "");
	exit(2);
}

static double now_s(void)
{
	return swell_link_now_ns() / 1e9;
}

static void sleep_until(double t)
{
	struct timespec ts;
	double d = t - now_s();

	if (d <= 0)
		return;
	ts.tv_sec = (time_t)d;
	ts.tv_nsec = (long)((d - (double)ts.tv_sec) * 1e9);
	nanosleep(&ts, NULL);
}

static uint32_t rng_state = 12345u;

static uint32_t rnd(void)
{
	rng_state ^= rng_state << 13;
	rng_state ^= rng_state >> 17;
	rng_state ^= rng_state << 5;
	return rng_state;
}

static void open_link(struct swell_link **l, const struct swell_link_spec *ls, const char *spec, int viewer_side)
{
	const struct swell_link_open_opts o = { .udp_answer = viewer_side };
	int rc = swell_link_open_spec(l, ls, &o);

	if (rc < 0) {
		fprintf(stderr, "swell-inject: cannot open %s: %s\n", spec, strerror(-rc));
		exit(2);
	}
}

/* Garbage and floods need frames the host link refuses to send (29-bit ids, remote frames, wrong
 * lengths), so on CAN they go out through a raw socket of their own. */
static int raw_can = -1;

static void open_raw_can(const char *iface)
{
	static const struct swell_can_opts plain; /* classic frames, every id, no error frames */

	raw_can = swell_can_socket(iface, &plain, 0);
	if (raw_can < 0) {
		fprintf(stderr, "swell-inject: CAN interface %s: %s\n", iface, strerror(-raw_can));
		exit(2);
	}
}

/* 0 sent, -1 not (a full transmit queue is waited for up to 100 ms) */
static int send_raw(struct swell_link *l, const struct swell_frame *f)
{
	struct can_frame fr;
	int tries;

	if (raw_can < 0)
		return swell_link_send(l, f) < 0 ? -1 : 0;
	memset(&fr, 0, sizeof(fr));
	fr.can_id = f->id & (CAN_EFF_MASK | CAN_RTR_FLAG);
	if (f->flags & SWELL_FRAME_EFF)
		fr.can_id |= CAN_EFF_FLAG;
	fr.can_dlc = (uint8_t)(f->len > 8 ? 8 : f->len);
	memcpy(fr.data, f->data, 8);
	for (tries = 0; tries < 1000; tries++) {
		if (write(raw_can, &fr, sizeof(fr)) == (ssize_t)sizeof(fr))
			return 0;
		if (errno != ENOBUFS && errno != EINTR)
			return -1;
		sleep_until(now_s() + 100e-6);
	}
	return -1;
}

/* A valid DEVICE_POS: the frame every bad one is made from. */
static int put_err(uint32_t classes, uint8_t crtl, uint8_t txerr, uint8_t rxerr, const char *what)
{
	struct can_frame f;

	memset(&f, 0, sizeof(f));
	f.can_id = CAN_ERR_FLAG | classes;
	f.can_dlc = CAN_ERR_DLC;
	f.data[1] = crtl;
	f.data[6] = txerr;
	f.data[7] = rxerr;
	if (write(raw_can, &f, sizeof(f)) != (ssize_t)sizeof(f)) {
		fprintf(stderr, "swell-inject: cannot write the %s error frame: %s\n", what, strerror(errno));
		return -1;
	}
	printf("%s at %.6f s (tx/rx error counters %u/%u)\n", what, now_s(), txerr, rxerr);
	return 0;
}

/* The sequence a driver reports for a bus fault (e.g. CANH shorted to CANL, or alone on the bus with
 * no one to ACK), then the restart (restart-ms or `ip link set IFACE type can restart`). */
static int cmd_can_errors(double seconds, int restart_frame)
{
	double t_off;

	if (put_err(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_TX_WARNING, 96, 0, "error-warning") ||
	    put_err(CAN_ERR_CRTL | CAN_ERR_CNT | CAN_ERR_ACK, CAN_ERR_CRTL_TX_PASSIVE, 128, 0, "error-passive"))
		return 1;
	sleep_until(now_s() + 0.05);
	t_off = now_s();
	if (put_err(CAN_ERR_BUSOFF | CAN_ERR_CNT, 0, 255, 0, "bus-off"))
		return 1;
	if (!restart_frame) {
		printf("can-errors: OK: 3 error frames, bus off until the interface is restarted\n");
		return 0;
	}
	sleep_until(t_off + seconds);
	if (put_err(CAN_ERR_RESTARTED | CAN_ERR_CNT, 0, 0, 0, "restarted"))
		return 1;
	printf("can-errors: OK: 4 error frames, bus off for %.3f s\n", now_s() - t_off);
	return 0;
}

static struct swell_msg device_pos(uint8_t node, int16_t z_10um, uint8_t seq)
{
	struct swell_msg m;

	memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_DEVICE_POS;
	m.node = node;
	m.u.device_pos.z_10um = z_10um;
	m.u.device_pos.seq = seq;
	m.u.device_pos.status = SWELL_DEV_POWERED | SWELL_DEV_FORCE_ON;
	return m;
}

enum {
	K_SHORT,
	K_LONG,
	K_RANGE,
	K_UNKNOWN,
	K_EFF,
	K_RTR,
	K_FOREIGN,
	K_RANDOM,
	K_KINDS
};
static const char *const kind_name[K_KINDS] = { "short",  "long",   "out-of-range", "unknown-id",
						"29-bit", "remote", "foreign-node", "random" };

/* One bad frame of kind k on a classic CAN link. A spoofed sample of the controller's own node with
 * valid contents cannot be told from the device's on CAN, so "foreign" is another node's. */
static void bad_can(struct swell_frame *f, int k, uint8_t foreign, uint8_t seq)
{
	struct swell_msg m = device_pos(0, -25000, seq); /* z = -250 mm: a big force if it were taken */
	uint32_t id;
	uint8_t len;

	memset(f, 0, sizeof(*f));
	swell_can_encode(&m, &id, f->data, &len);
	f->id = id;
	f->len = len;
	switch (k) {
	case K_SHORT:
		f->len = (uint16_t)(rnd() % len);
		break;
	case K_LONG: /* DEVICE_VEL is 7 bytes: 8 is too long */
		m.type = SWELL_MSG_DEVICE_VEL;
		memset(&m.u, 0, sizeof(m.u));
		m.u.device_vel.vz_100ums = -30000;
		swell_can_encode(&m, &id, f->data, &len);
		f->id = id;
		f->len = 8;
		f->data[7] = 0xA5;
		break;
	case K_RANGE:
		f->data[4] = 0x00;
		f->data[5] = 0x80;
		break; /* z = -32768: below -30000 */
	case K_UNKNOWN:
		f->id = SWELL_CAN_ID(0x7E, 0);
		break;
	case K_EFF:
		f->id = id | 0x1000u;
		f->flags = SWELL_FRAME_EFF;
		break;
	case K_RTR:
		f->len = 0;
		f->id = id | CAN_RTR_FLAG;
		break; /* CAN_RTR_FLAG, DLC 0 (QEMU: see hil-vm.md) */
	case K_FOREIGN:
		m = device_pos(foreign, -25000, seq);
		swell_can_encode(&m, &id, f->data, &len);
		f->id = id;
		break;
	default: {
		int b;

		f->id = SWELL_CAN_ID(rnd() % 0x7F + 1, 0);
		if (f->id == SWELL_CAN_ID(SWELL_MSG_DEVICE_POS, 0) || f->id == SWELL_CAN_ID(SWELL_MSG_DEVICE_VEL, 0))
			f->id |= 1; /* random bytes may decode validly: never as the device's own sample */
		f->len = (uint16_t)(rnd() % 9);
		for (b = 0; b < 8; b++)
			f->data[b] = (uint8_t)rnd();
	}
	}
}

/* One bad packet of kind k (UDP, USB). */
static void bad_pkt(struct swell_frame *f, int k, uint8_t foreign, uint8_t seq)
{
	struct swell_msg m = device_pos(0, -25000, seq);
	size_t used;

	memset(f, 0, sizeof(*f));
	if (k == K_FOREIGN)
		m = device_pos(foreign, -25000, seq);
	swell_link_encode(SWELL_CARRIER_PKT, m.node, seq, &m, 1, f, &used);
	switch (k) {
	case K_SHORT:
		f->len = (uint16_t)(rnd() % (f->len - 1) + 1);
		break;
	case K_LONG:
		f->data[f->len - 1] ^= 0x01;
		break; /* bad CRC */
	case K_RANGE:
		f->data[0] = 0x58;
		break; /* bad magic */
	case K_UNKNOWN:
		f->data[1] = 2;
		break; /* another protocol version */
	case K_EFF:
		f->data[4] = 0;
		break; /* record count 0 */
	case K_RTR:
		f->data[5] = 0x7E;
		break; /* unknown record type */
	case K_FOREIGN:
		break;
	default: {
		int b;

		f->len = (uint16_t)(rnd() % 64 + 1);
		for (b = 0; b < f->len; b++)
			f->data[b] = (uint8_t)rnd();
	}
	}
}

static int cmd_garbage(struct swell_link *l, long count, double rate, uint8_t foreign)
{
	long sent[K_KINDS] = { 0 }, errors = 0, n;
	int can = swell_link_carrier(l) != SWELL_CARRIER_PKT, k;
	double t0 = now_s(), t;

	for (n = 0; n < count; n++) {
		struct swell_frame f;

		k = (int)(n % K_KINDS);
		if (can)
			bad_can(&f, k, foreign, (uint8_t)n);
		else
			bad_pkt(&f, k, foreign, (uint8_t)n);
		if (rate > 0)
			sleep_until(t0 + (double)n / rate);
		if (send_raw(l, &f) < 0)
			errors++;
		else
			sent[k]++;
	}
	t = now_s() - t0;
	printf("swell-inject garbage %s: %ld frames in %.3f s (%.0f frames/s), %ld send errors:", swell_link_name(l),
	       count - errors, t, (double)(count - errors) / (t > 0 ? t : 1e-9), errors);
	for (k = 0; k < K_KINDS; k++)
		printf(" %s %ld%s", kind_name[k], sent[k], k + 1 < K_KINDS ? "," : "\n");
	printf("  invalid frames  %ld (must be counted bad)\n", count - errors - sent[K_FOREIGN]);
	printf("  foreign frames  %ld (node %u: must be ignored)\n", sent[K_FOREIGN], foreign);
	return errors == count ? 1 : 0;
}

static int cmd_flood(struct swell_link *l, double seconds, uint32_t id)
{
	long sent = 0, errors = 0;
	double t0 = now_s(), t;
	struct swell_frame f;

	memset(&f, 0, sizeof(f));
	f.id = id;
	f.len = 8;
	while ((t = now_s() - t0) < seconds) {
		int b;

		for (b = 0; b < 8; b++)
			f.data[b] = (uint8_t)rnd();
		if (swell_link_carrier(l) == SWELL_CARRIER_PKT) {
			struct swell_msg m = device_pos(5, 0, (uint8_t)sent);
			size_t used;

			swell_link_encode(SWELL_CARRIER_PKT, 5, (uint8_t)sent, &m, 1, &f, &used);
		}
		if (send_raw(l, &f) < 0)
			errors++;
		else
			sent++;
	}
	printf("swell-inject flood %s: id 0x%03x, %ld frames in %.3f s (%.0f frames/s), %ld send errors\n",
	       swell_link_name(l), id, sent, t, sent / t, errors);
	return sent > 0 ? 0 : 1;
}

/* ---- params ---- */

struct pset {
	uint16_t id;
	int32_t value;
	const char *why;
};

static const struct pset bad_sets[] = {
	{ SWELL_PARAM_WAVE_E, 600000000, "wave e 0.56: above the stability limit 1/2" },
	{ SWELL_PARAM_WAVE_E, -1, "wave e negative" },
	{ SWELL_PARAM_WAVE_DAMPING, -5, "wave damping negative" },
	{ SWELL_PARAM_WAVE_STENCIL, 7, "stencil 7: neither paper nor calibrated" },
	{ SWELL_PARAM_BODY_MASS_G, 0, "mass 0 g" },
	{ SWELL_PARAM_BODY_MASS_G, -100, "mass -100 g" },
	{ SWELL_PARAM_BODY_A_UM, 0, "footprint a 0 um" },
	{ SWELL_PARAM_BODY_H_UM, -1, "height negative" },
	{ SWELL_PARAM_FORCE_MAX_UN, -1, "force limit negative" },
	{ SWELL_PARAM_FORCE_MAX_UN, 2000000000, "force limit 2000 N: above what FORCE_CMD carries" },
	{ SWELL_PARAM_FORCE_RATE, -1, "force rate negative" },
	{ SWELL_PARAM_SILENT_TICKS, 0, "silent ticks 0" },
	{ SWELL_PARAM_SILENT_TICKS, 20000, "silent ticks 20000" },
	{ SWELL_PARAM_AUTORUN, 2, "autorun 2" },
	{ SWELL_PARAM_COMMAND, 9, "command 9" },
	{ 999, 1, "unknown parameter id" },
};

static int send_msg(struct swell_link *l, const struct swell_msg *m, uint8_t seq)
{
	struct swell_frame f;
	size_t used;

	if (swell_link_encode(swell_link_carrier(l), m->node, seq, m, 1, &f, &used) != SWELL_OK)
		return -1;
	return swell_link_send(l, &f);
}

/* Waits for the answer to request seq on id: 1 ACK (*value set), 0 NACK (*err set), -1 none. */
static int wait_answer(struct swell_link *l, uint16_t id, uint8_t seq, int timeout_ms, int32_t *value, int *err,
		       struct swell_proto_stats *st)
{
	double until = now_s() + timeout_ms / 1e3;

	while (now_s() < until) {
		struct swell_frame f;
		struct swell_msg m[SWELL_CANFD_MSGS_MAX];
		size_t n = 0, k;

		if (swell_link_recv(l, &f, 10) < 0)
			continue;
		if (swell_link_decode(swell_link_carrier(l), &f, m, SWELL_CANFD_MSGS_MAX, &n, NULL, st) != SWELL_OK)
			continue;
		for (k = 0; k < n; k++) {
			enum swell_err why = SWELL_OK;
			const int answer = swell_param_answer(&m[k], id, seq, value, &why);

			if (answer >= 0) {
				*err = (int)why;
				return answer;
			}
		}
	}
	return -1;
}

/* PARAM_SET (set 1) or PARAM_GET of id, asked up to three times: an answer can be lost on the way back (in
 * lockstep over UDP the telemetry comes several times faster than real time and can overflow our receive
 * buffer), so the same request goes again, as a host would send it. As wait_answer; *resent (may be NULL)
 * counts the requests that went unanswered. */
static int request(struct swell_link *l, uint8_t node, int set, uint16_t id, int32_t value, uint8_t seq, int timeout_ms,
		   int32_t *v, int *err, struct swell_proto_stats *st, int *resent)
{
	const struct swell_msg m = swell_param_request(node, set, id, value, seq);
	int tries, r = -1;

	for (tries = 0; tries < 3 && r < 0; tries++) {
		send_msg(l, &m, seq);
		r = wait_answer(l, id, seq, timeout_ms, v, err, st);
		if (resent)
			*resent += r < 0;
	}
	return r;
}

static int cmd_params(struct swell_link *l, uint8_t node, int timeout_ms)
{
	struct swell_proto_stats st;
	size_t k, nsets = sizeof(bad_sets) / sizeof(bad_sets[0]);
	int failed = 0, nacked = 0, unchanged = 0, resent = 0;
	uint8_t seq = 1;

	memset(&st, 0, sizeof(st));
	/* over UDP the controller must first send something, so that we know where it listens */
	if (swell_link_carrier(l) == SWELL_CARRIER_PKT) {
		struct swell_frame f;
		double until = now_s() + timeout_ms / 1e3 * 10;

		while (now_s() < until && swell_link_recv(l, &f, 50) < 0)
			;
	}
	for (k = 0; k < nsets; k++) {
		const struct pset *p = &bad_sets[k];
		int32_t before = 0, after = 0, v = 0;
		int err = 0, get_err = 0, r, have_before = p->id != SWELL_PARAM_COMMAND && p->id != 999;

		if (have_before &&
		    request(l, node, 0, p->id, 0, seq++, timeout_ms, &before, &get_err, &st, NULL) != 1) {
			printf("  FAIL %-48s PARAM_GET %u before: no ACK\n", p->why, p->id);
			failed++;
			continue;
		}
		/* the read-back below shows whether anything was set, answered or not */
		r = request(l, node, 1, p->id, p->value, seq++, timeout_ms, &v, &err, &st, &resent);
		if (have_before && request(l, node, 0, p->id, 0, seq++, timeout_ms, &after, &get_err, &st, NULL) != 1) {
			printf("  FAIL %-48s PARAM_GET %u after: no ACK\n", p->why, p->id);
			failed++;
			continue;
		}
		nacked += r == 0;
		unchanged += !have_before || after == before;
		if (r != 0 || (have_before && after != before)) {
			failed++;
			printf("  FAIL %-48s id %u value %d: %s, value %d -> %d\n", p->why, p->id, p->value,
			       r < 0            ? "no answer"
				       : r == 1 ? "ACCEPTED"
						: "NACK",
			       before, after);
		} else {
			printf("  ok   %-48s id %u value %d: NACK %s, value %d unchanged\n", p->why, p->id, p->value,
			       swell_err_str((enum swell_err)err), before);
		}
	}
	printf("swell-inject params %s: %s: %d of %zu refused with a NACK, %d unchanged, %u bad frames received, "
	       "%d PARAM_SETs sent again for a lost answer\n",
	       swell_link_name(l), failed ? "FAILED" : "OK", nacked, nsets, unchanged, swell_proto_rejected_total(&st),
	       resent);
	return failed ? 1 : 0;
}

int main(int argc, char **argv)
{
	const char *cmd, *spec;
	long count = 2000;
	double rate = 1000, seconds = -1;
	uint32_t id = SWELL_CAN_ID(SWELL_MSG_HEIGHT_QUAD, 5) | 0x400u;
	unsigned node = 0, foreign = 5;
	int restart_frame = 1;
	int timeout_ms = 500, rc;
	long iface = 0;
	struct swell_link_spec ls;
	struct swell_link *l;
	char why[200];

	if (argc >= 2 && (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help"))) {
		fputs(usage, stdout);
		return 0;
	}
	if (argc < 3)
		die("give a command and a LINK (see --help)", NULL);
	cmd = argv[1];
	spec = argv[2];
	if (strcmp(cmd, "garbage") && strcmp(cmd, "flood") && strcmp(cmd, "params") && strcmp(cmd, "can-errors"))
		die("unknown command ", cmd);
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_WHOLE("--count", count, 1, 100000000, ""),
		SWELL_CLI_NUM("--rate", rate, 0, 1e6, "Hz"),
		SWELL_CLI_WHOLE("--seed", rng_state, 0, 4294967295.0, ""),
		SWELL_CLI_NUM_ABOVE("--seconds", seconds, 0, 3600, "s"),
		SWELL_CLI_HEX("--id", id, 0, 0x7FF),
		SWELL_CLI_WHOLE("--iface", iface, 0, 255, ""),
		SWELL_CLI_WHOLE("--node", node, 0, SWELL_NODE_MAX, ""),
		SWELL_CLI_WHOLE("--foreign-node", foreign, 1, SWELL_NODE_MAX, ""),
		SWELL_CLI_CHOICE("--restart", restart_frame, "none|frame"),
		SWELL_CLI_WHOLE("--timeout-ms", timeout_ms, 1, 60000, "ms"),
	};
	struct swell_cli cli = { .prog = "swell-inject", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts) };

	swell_cli_parse(&cli, argc - 2, argv + 2); /* the options after COMMAND LINK */
	rng_state |= 1u;
	if (swell_link_spec_parse(spec, SWELL_LINK_ACCEPT_HOST_SIDE,
				  !strcmp(cmd, "params") ? SWELL_UDP_PORT_VIEWER : SWELL_UDP_PORT_DEVICE, &ls, why,
				  sizeof(why)))
		die(why, NULL);
	ls.iface = (uint8_t)iface;
	if (!strcmp(cmd, "can-errors")) {
		if (ls.kind != SWELL_LINK_CAN)
			die("can-errors needs a CAN link, can:IFACE, not ", spec);
		if (seconds < 0)
			seconds = 0.5;
		if (seconds > 60)
			die("can-errors: --seconds must be at most 60", NULL);
		open_raw_can(ls.name);
		return cmd_can_errors(seconds, restart_frame);
	}
	open_link(&l, &ls, spec, !strcmp(cmd, "params"));
	if (strcmp(cmd, "params") && ls.kind == SWELL_LINK_CAN)
		open_raw_can(ls.name);
	if (seconds < 0)
		seconds = 2;
	if (!strcmp(cmd, "garbage"))
		rc = cmd_garbage(l, count, rate, (uint8_t)foreign);
	else if (!strcmp(cmd, "flood"))
		rc = cmd_flood(l, seconds, id);
	else
		rc = cmd_params(l, (uint8_t)node, timeout_ms);
	swell_link_close(l);
	return rc;
}
