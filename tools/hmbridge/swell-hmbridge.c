/* swell-hmbridge: puts a HapticMaster (its TCP command interface) under a controller that speaks
 * swell's device protocol on CAN, USB or UDP (the MCU controller). To the controller it is the device
 * node; to the HapticMaster it is a client (hm_client.h).
 *
 * It ticks at the device rate on its own absolute-deadline clock. Each tick: the latest FORCE_CMD
 * that arrived is taken; the newest HapticMaster answer, if one came since the last tick, goes to the
 * controller as DEVICE_VEL + DEVICE_POS (none came: nothing goes, and the controller sees a silent
 * device); one request goes to the HapticMaster with the force, or zero when the command is disabled,
 * the controller has been silent for --watchdog ticks (the bridge's own watchdog, default 2), or the
 * HapticMaster has not answered for as long (a force from a position that old is not sent: late,
 * garbled or reset answers end with zero force on the device as on the direct hm: link). On exit the
 * zero force is confirmed by the device first.
 *
 * Effect mode (the controller sends EFFECT_SPRING, EFFECT_DAMPER, EFFECT_LIMIT): each complete set
 * becomes the HapticMaster's own springs, damper and bias force (hm_fx.h, shared with swell-ctl's hm:
 * link), rendered by the device every servo tick. The controller sends no FORCE_CMD while the sets
 * come: a complete set is the command (enabled, zero bias force) and --effect-fresh its watchdog. They
 * are removed on the tick the set is older than --effect-fresh, the command is disabled, or the
 * watchdog zeroes the force, and on exit. */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

#include "hm_client.h"
#include "hm_fx.h"
#include "swell/cli.h"
#include "swell/link.h"
#include "swell/param_table.h"
#include "swell/pool.h"
#include "swell/proto.h"
#include "swell/transport.h"

static const char usage[] =
	"usage: swell-hmbridge --hm HOST[:PORT] [options]\n"
	"A HapticMaster (TCP command interface, port 7654) as the device node of swell's protocol for a\n"
	"controller on CAN, USB or UDP. Each device tick: the newest sample to the controller, one request\n"
	"with its latest force to the HapticMaster (zero once the controller or the HapticMaster is silent\n"
	"for --watchdog ticks).\n"
	"\n"
	"  --hm HOST[:PORT]    the HapticMaster (required; an address or a host name)\n"
	"  --link udp[:PORT]|can:IFACE|usb[:VID:PID]   carrier to the controller (default udp: packets to "
	"--host:--port)\n"
	"  --host ADDR         controller's IPv4 address for udp (default 127.0.0.1)\n"
	"  --inertia KG        the HapticMaster's inertia, set at every start-up after its calibrations are\n"
	"                      read (default 2, what the force law's damper is tuned for; 0: left as it is)\n"
	"  --port N            controller's UDP port (default 47800)\n"
	"  --bind-port N       own UDP port (default 0: any free port)\n"
	"  --iface N           usb: the controller's interface number (default 0)\n"
	"  --node N            node id, 0..15 (default 0)\n"
	"  --rate HZ           device tick rate (default 2500; 1000 for classic CAN)\n"
	"  --watchdog TICKS    controller or HapticMaster silent this many ticks -> zero force on the\n"
	"                      HapticMaster (default 2; while effect sets come, the controller's silence\n"
	"                      is --effect-fresh instead)\n"
	"  --effect-fresh MS   effect mode: an effect set older than this is removed from the HapticMaster\n"
	"                      (default 10)\n"
	"  --seconds S         stop after S seconds (default: until SIGINT/SIGTERM)\n"
	"  --rt                SCHED_FIFO (priority 70) and mlockall where permitted\n"
	"  --quiet             no status line\n"
	"  -h, --help          this text\n"
	"\n"
	"On exit prints a summary: ticks, commands, samples forwarded, watchdog trips, the HapticMaster\n"
	"link's counters and round trip.\n"
	"Exit status: 0 done, 1 a link failed, 2 bad arguments.\n";

struct opts {
	const char *hm, *link, *host;
	struct swell_link_spec ls; /* --link parsed */
	unsigned port, bind_port, iface, node, watchdog;
	double rate_hz, seconds, fresh_ms;
	double inertia_kg; /* set on the HapticMaster at every start-up, 0: left as it is */
	int rt, quiet;
};

static int link_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	char why[200];

	if (swell_link_spec_parse(v, SWELL_LINK_ACCEPT_HOST_SIDE, (uint16_t)o->port, &o->ls, why, sizeof(why)))
		return swell_cli_refuse(c, "%s %s", opt, why);
	o->link = v;
	o->port = o->ls.port;
	return 0;
}

static void parse(int argc, char **argv, struct opts *o)
{
	memset(o, 0, sizeof(*o));
	o->link = "udp";
	o->host = SWELL_UDP_HOST;
	o->port = SWELL_UDP_PORT_DEVICE;
	o->rate_hz = SWELL_POOL_TICK_HZ;
	o->inertia_kg = SWELL_PARAM_DEF_HM_INERTIA / 1000.0;
	o->watchdog = 2;
	o->fresh_ms = 10.0;
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_FLAG("--rt", o->rt),
		SWELL_CLI_FLAG("--quiet", o->quiet),
		SWELL_CLI_STR("--hm", o->hm),
		SWELL_CLI_HOOK("--link", link_opt, 1),
		SWELL_CLI_IPV4("--host", o->host),
		SWELL_CLI_WHOLE("--port", o->port, 1, 65535, ""),
		SWELL_CLI_WHOLE("--bind-port", o->bind_port, 0, 65535, ""),
		SWELL_CLI_WHOLE("--iface", o->iface, 0, 255, ""),
		SWELL_CLI_WHOLE("--node", o->node, 0, SWELL_NODE_MAX, ""),
		SWELL_CLI_NUM("--inertia", o->inertia_kg, 0, 100, "kg"),
		SWELL_CLI_NUM("--rate", o->rate_hz, 100, 10000, "Hz"),
		SWELL_CLI_WHOLE("--watchdog", o->watchdog, 1, 1000, "ticks"),
		SWELL_CLI_NUM("--effect-fresh", o->fresh_ms, 0.1, 1000, "ms"),
		SWELL_CLI_NUM("--seconds", o->seconds, 1e-3, 1e7, "s"),
	};
	struct swell_cli cli = {
		.prog = "swell-hmbridge", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts), .ctx = o
	};

	swell_cli_parse(&cli, argc, argv);
	if (o->hm && !*o->hm)
		swell_cli_die("swell-hmbridge", "--hm needs HOST[:PORT], not an empty word");
	if (!o->hm)
		swell_cli_die("swell-hmbridge", "--hm HOST[:PORT] is required (the HapticMaster's address)");
}

static volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
	(void)sig;
	stop_flag = 1;
}

#define now_ns() ((int64_t)swell_link_now_ns())

struct bridge {
	struct swell_link *l;
	enum swell_carrier carrier;
	uint8_t node;
	struct swell_proto_stats st;
	struct hm_client hm;
	struct hm_fx fx;
	int16_t f_cN[3];
	int enable;
	uint32_t cmd_age; /* ticks since the last FORCE_CMD or complete effect set (saturating) */
	int by_sets; /* the last command was an effect set: its freshness is the watchdog */
	uint32_t ans_age; /* ticks since the last sample forwarded (saturating) */
	uint64_t ticks, commands, samples_fwd, samples_dropped, silent_ticks, trips, send_errors, ignored;
	uint64_t hm_trips; /* forces zeroed because the HapticMaster fell silent */
	int zeroed; /* the watchdog has zeroed the force since the last command */
	uint32_t refusal_seen; /* the HapticMaster start-up's refusal last printed (hm.refusal_seq) */
	int hm_zeroed; /* ... since the last answer */
};

/* Every FORCE_CMD and effect set waiting: the latest wins. In effect mode the controller sends no
 * FORCE_CMD while RUNNING: a complete set is then an enabled command with zero bias force, and its
 * freshness (--effect-fresh) the watchdog, as on swell-hm. */
static void take_commands(struct bridge *b)
{
	struct swell_frame f;
	struct swell_msg m[SWELL_CANFD_MSGS_MAX];
	size_t n, k;
	int rounds;

	for (rounds = 0; rounds < 64 && swell_link_recv(b->l, &f, 0) >= 0; rounds++) {
		n = 0;
		if (swell_link_decode(b->carrier, &f, m, SWELL_CANFD_MSGS_MAX, &n, NULL, &b->st) != SWELL_OK)
			continue; /* counted in st, never acted on */
		for (k = 0; k < n; k++) {
			const struct swell_msg_force_cmd *c = &m[k].u.force_cmd;
			const uint32_t sets = b->fx.st.sets;

			if (m[k].node == b->node && hm_fx_msg(&b->fx, &b->hm, &m[k])) {
				if (b->fx.st.sets == sets)
					continue; /* a part of a set */
				b->f_cN[0] = b->f_cN[1] = b->f_cN[2] = 0;
				b->enable = 1;
			} else if (m[k].node != b->node || m[k].type != SWELL_MSG_FORCE_CMD) {
				b->ignored += m[k].type != SWELL_MSG_HEARTBEAT;
				continue;
			} else {
				b->f_cN[0] = c->fx_cN;
				b->f_cN[1] = c->fy_cN;
				b->f_cN[2] = c->fz_cN;
				b->enable = c->enable;
				b->commands++;
			}
			b->by_sets = b->fx.st.sets != sets;
			b->cmd_age = 0;
			b->zeroed = 0;
		}
	}
}

static void tick(struct bridge *b, const struct opts *o)
{
	struct swell_msg in[2 * HMC_RING], *newest = NULL;
	size_t n, k;

	take_commands(b);
	/* the newest answer only: the controller gets one sample a tick */
	n = hm_client_poll(&b->hm, in, sizeof(in) / sizeof(in[0]), b->node);
	if (b->hm.refusal_seq != b->refusal_seen) { /* the start-up stopped before any force: once a reason */
		b->refusal_seen = b->hm.refusal_seq;
		fprintf(stderr,
			"swell-hmbridge: %s: start-up stopped before any force: %s (trying again every %d ms)\n",
			b->hm.name, b->hm.refusal, HMC_RETRY_MS);
	}
	for (k = 0; k + 1 < n; k += 2)
		newest = &in[k];
	if (newest) {
		b->samples_dropped += n / 2 - 1;
		b->samples_fwd++;
		b->send_errors += hm_node_send(b->l, b->node, newest[1].u.device_pos.seq, newest, 2);
		b->ans_age = 0;
		b->hm_zeroed = 0;
	} else {
		b->silent_ticks++;
	}
	if (b->cmd_age >= (b->by_sets ? b->fx.fresh_ticks : o->watchdog) && !b->zeroed) {
		b->zeroed = 1;
		b->trips += b->enable != 0;
	}
	if (b->ans_age >= o->watchdog && !b->hm_zeroed) {
		b->hm_zeroed = 1;
		b->hm_trips += b->enable && !b->zeroed;
	}
	hm_fx_tick(&b->fx, &b->hm, b->enable, !b->zeroed && !b->hm_zeroed);
	hm_client_force(&b->hm, b->f_cN, b->enable && !b->zeroed && !b->hm_zeroed); /* else zero force */
	if (b->cmd_age < UINT32_MAX)
		b->cmd_age++;
	if (b->ans_age < UINT32_MAX)
		b->ans_age++;
	b->ticks++;
}

int main(int argc, char **argv)
{
	static struct bridge b;
	struct opts o;
	const struct sigaction sa = { .sa_handler = on_signal };
	char err[160];
	int64_t period, next, start, last_status;
	uint64_t max_ticks;

	parse(argc, argv, &o);
	b.node = (uint8_t)o.node;
	b.cmd_age = UINT32_MAX;
	b.ans_age = UINT32_MAX;
	b.zeroed = 1;
	b.hm_zeroed = 1;
	if (hm_client_open(&b.hm, o.hm, 2, err, sizeof(err)) < 0) {
		fprintf(stderr, "swell-hmbridge: %s\n", err);
		return 2;
	}
	b.hm.inertia_g = (uint32_t)lround(o.inertia_kg * 1000.0);
	hm_fx_init(&b.fx, &b.hm, (uint32_t)fmax(1.0, round(o.fresh_ms * o.rate_hz / 1000.0)));
	b.l = hm_node_open(&o.ls, o.port, o.iface, o.host, o.bind_port, "swell-hmbridge", o.link);
	if (!b.l)
		return 1;
	b.carrier = swell_link_carrier(b.l);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);
	if (o.rt) {
		struct sched_param sp = { .sched_priority = 70 };

		if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
			fprintf(stderr, "swell-hmbridge: warning: mlockall: %s\n", strerror(errno));
		if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
			fprintf(stderr, "swell-hmbridge: warning: SCHED_FIFO: %s; normal priority\n", strerror(errno));
	}
	fprintf(stderr, "swell-hmbridge: %s <-> %s at %g Hz, watchdog %u ticks\n", swell_link_name(b.l), b.hm.name,
		o.rate_hz, o.watchdog);
	period = (int64_t)llround(1e9 / o.rate_hz);
	max_ticks = o.seconds > 0 ? (uint64_t)llround(o.seconds * o.rate_hz) : UINT64_MAX;
	start = next = last_status = now_ns();
	while (!stop_flag && b.ticks < max_ticks) {
		struct timespec dl;

		next += period;
		dl.tv_sec = (time_t)(next / 1000000000);
		dl.tv_nsec = (long)(next % 1000000000);
		while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &dl, NULL) == EINTR && !stop_flag)
			;
		if (now_ns() - next > period)
			next = now_ns(); /* a whole period lost: start again from now */
		tick(&b, &o);
		if (!o.quiet && now_ns() - last_status > 1000000000) {
			last_status = now_ns();
			fprintf(stderr, "\rswell-hmbridge: %s, %llu commands, %llu samples, %u in flight   ",
				hm_client_phase_name(b.hm.phase), (unsigned long long)b.commands,
				(unsigned long long)b.samples_fwd, b.hm.ring_n);
		}
	}
	hm_fx_tick(&b.fx, &b.hm, 0, 0); /* the effects go first, confirmed with the zero force */
	if (hm_client_zero_wait(&b.hm, 100) != 0)
		fprintf(stderr,
			"swell-hmbridge: warning: the HapticMaster did not confirm the zero force within 100 ms\n");
	if (!o.quiet)
		fputc('\n', stderr);
	printf("swell-hmbridge summary\n");
	printf("  ran             %.3f s, %llu ticks at %g Hz\n", (now_ns() - start) / 1e9, (unsigned long long)b.ticks,
	       o.rate_hz);
	printf("  controller      %s: %llu commands, %u bad frames, %llu other messages ignored, %llu send errors\n",
	       swell_link_name(b.l), (unsigned long long)b.commands, swell_proto_rejected_total(&b.st),
	       (unsigned long long)b.ignored, (unsigned long long)b.send_errors);
	printf("  samples         %llu forwarded, %llu older ones skipped, %llu ticks without an answer\n",
	       (unsigned long long)b.samples_fwd, (unsigned long long)b.samples_dropped,
	       (unsigned long long)b.silent_ticks);
	printf("  watchdog        %llu trips (%u ticks without a command -> zero force), %llu with the HapticMaster "
	       "silent as long\n",
	       (unsigned long long)b.trips, o.watchdog, (unsigned long long)b.hm_trips);
	hm_client_report(&b.hm, stdout);
	hm_fx_report(&b.fx, stdout);
	hm_client_close(&b.hm);
	swell_link_close(b.l);
	return 0;
}
