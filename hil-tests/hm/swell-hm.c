/* swell-hm: the HapticMaster model for the bench and the demo. It speaks the device side of the
 * swell protocol (DEVICE_POS + DEVICE_VEL every tick, FORCE_CMD and HEARTBEAT back) over UDP,
 * SocketCAN or USB (host links), integrates the admittance model of hm_model.h with a scripted
 * hand (hm_hand.h), logs every tick to CSV and prints a summary.
 *
 * Pacing: real time (absolute-deadline clock_nanosleep on CLOCK_MONOTONIC at --rate), or lockstep:
 * after sending sample n wait for the controller's answer (the first FORCE_CMD that arrives after
 * it; swell-ctl --clock device ticks once per DEVICE_POS), with a timeout, then integrate. Lockstep
 * runs as fast as the two processes go and is deterministic. */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

#include "hm_cmd.h"
#include "hm_hand.h"
#include "hm_model.h"
#include "hm_serve.h"
#include "swell/effect.h"
#include "swell/force_safety.h"
#include "swell/link.h"
#include "swell/proto.h"
#include "swell/scene.h"
#include "swell/transport.h"

static const char usage[] =
	"usage: swell-hm [options]\n"
	"The HapticMaster model: an admittance-controlled device (virtual mass and damping, workspace\n"
	"walls, device-side watchdog) moved by a scripted hand, speaking the device side of the swell\n"
	"protocol to a controller (swell-ctl).\n"
	"\n"
	"Link and pacing:\n"
	"  --link udp[:PORT]|can:IFACE|usb[:VID:PID]   carrier (default udp: packets to --host:--port)\n"
	"  --iface N           usb: the controller's interface number (default 0, the device link;\n"
	"                      bulk endpoints are read from its descriptor)\n"
	"  --host ADDR         controller's IPv4 address for udp (default 127.0.0.1)\n"
	"  --port N            controller's UDP port (default 47800)\n"
	"  --bind-port N       own UDP port (default 0: any free port)\n"
	"  --node N            node id, 0..15 (default 0)\n"
	"  --rate HZ           device tick rate (default 2500, the HapticMaster servo rate)\n"
	"  --lockstep          after each sample wait for the controller's FORCE_CMD (deterministic,\n"
	"                      as fast as both go); default: real time at --rate\n"
	"  --timeout-ms MS     lockstep: longest wait for an answer (default 50; counted as a timeout)\n"
	"  --rt                SCHED_FIFO (priority 70, below swell-ctl's 80) and mlockall where permitted\n"
	"  --seconds S         simulated seconds to run (default 10); SIGINT/SIGTERM stop early\n"
	"  --serve [ADDR:]PORT serve the HapticMaster's own TCP command interface instead of the swell\n"
	"                      protocol (default 127.0.0.1:7654; any other address must be spelled out);\n"
	"                      forces come from the effects clients create (docs/hapticmaster.md)\n"
	"  --bias-watchdog MS  --serve: a client silent this long loses its bias forces (default 100;\n"
	"                      0: off)\n"
	"  --inject SPEC       --serve fault injection (repeatable, up to 8): delay:at=S,for=S,ms=N (replies\n"
	"                      held N ms), garbage:at=S (16 unframed bytes to every client), reset:at=S\n"
	"                      (every connection reset), stop:at=S (the device put in stop, as by a client)\n"
	"Device model (m_v a = F_user + F_cmd - b_v v, per axis; see docs/hm.md):\n"
	"  --mass KG           virtual mass m_v (default 2)\n"
	"  --damping NS_M      virtual damping b_v in N s/m (default 2)\n"
	"  --limit MM          workspace half-range per axis (default 200; a stiff wall beyond)\n"
	"  --fmax N            largest commanded force applied per axis (default 250)\n"
	"  --effect-fresh MS   effect mode (EFFECT_* messages): a set is rendered for at most this long\n"
	"                      after it came (default 10; the controller sends one every solver step)\n"
	"  --watchdog TICKS    controller silent this many ticks -> no commanded force (default 2 in\n"
	"                      lockstep or with --rt granted; else 20 ms of ticks, said at start: a\n"
	"                      process that is not real time is late by milliseconds)\n"
	"  --start X,Y,Z       start position in mm (default 0,0,0; drop: 0,0,its height)\n"
	"  --estop A,B         fault injection: e-stop pressed from A to B seconds\n"
	"User:\n"
	"  --hand SPEC         idle (default), drop[:z=20,hold=1], release[:at=0.5],\n"
	"                      press[:at=3,depth=45,ramp=0.5,hold=2], shake[:at=3,axis=z,f=1,amp=10,for=3];\n"
	"                      all take k=N/m (default 2000) and b=N s/m (default 60) of the hand\n"
	"Report:\n"
	"  --object G,A,B      the floating object, for the expected equilibrium: mass in g and footprint\n"
	"                      in mm (default 100,50,50: -m g/k = -40 mm)\n"
	"  --pool LX,LY        pool size in mm, for the level rise (default 400,400)\n"
	"  --scene FILE        the controller's scene file (*.scene): object and pool from it, as swell-ctl\n"
	"                      --scene FILE has them; an object heavier than the water it can displace is\n"
	"                      expected on the floor\n"
	"  --log FILE.csv      one row a tick: time, position, velocity, commanded and hand force, state\n"
	"  --quiet             no progress line\n"
	"  -h, --help          this text\n"
	"\n"
	"On exit prints a summary: final position, equilibrium z over the last second against -m g/k,\n"
	"peak commanded force, ticks, timeouts, lost and bad packets, watchdog trips.\n"
	"Exit status: 0 done, 1 a runtime failure (the link, the log, or no controller ever answered),\n"
	"2 bad arguments (one line on stderr, nothing sent, no log written).\n";

#define RHO_KG_M3 1000.0

struct opts {
	const char *link, *host, *log, *serve;
	struct swell_link_spec ls; /* --link parsed */
	unsigned bias_watchdog_ms;
	double effect_fresh_ms; /* effect mode: a set older than this is not rendered */
	struct inject {
		char kind; /* 'd' delay, 'g' garbage, 'r' reset, 's' stop */
		double at_s, for_s, ms;
		int done;
	} inj[8];
	int n_inj;
	unsigned port, bind_port, node, iface;
	int lockstep, quiet, have_start, rt, watchdog_given;
	unsigned timeout_ms;
	double seconds, start_mm[3], estop_s[2];
	double obj_mass_g, obj_a_mm, obj_b_mm, pool_mm[2];
	double obj_h_mm, depth_mm; /* from --scene: the object sinks to the floor when m > rho a b H */
	struct hm_params p;
	struct hm_hand hand;
};

static void die(const char *fmt, const char *a, const char *b)
{
	fprintf(stderr, "swell-hm: ");
	fprintf(stderr, fmt, a, b);
	fputc('\n', stderr);
	exit(2);
}

static double number(const char *opt, const char *v, double lo, double hi, const char *unit)
{
	char *end;
	double x;

	errno = 0;
	x = strtod(v, &end);
	if (errno || end == v || *end || !(x >= lo && x <= hi)) {
		fprintf(stderr, "swell-hm: %s '%s' is not a number in [%g, %g]%s%s\n", opt, v, lo, hi, *unit ? " " : "",
			unit);
		exit(2);
	}
	return x;
}

static unsigned whole(const char *opt, const char *v, double lo, double hi, const char *unit)
{
	double x = number(opt, v, lo, hi, unit);

	if (x != floor(x)) {
		fprintf(stderr, "swell-hm: %s '%s' is not a whole number%s%s\n", opt, v, *unit ? " of " : "", unit);
		exit(2);
	}
	return (unsigned)x;
}

/* "a,b[,c]": exactly n numbers in [lo, hi]. */
static void numbers(const char *opt, const char *v, double *out, int n, double lo, double hi, const char *unit)
{
	const char *p = v;
	char *end;
	int k;

	for (k = 0; k < n; k++) {
		errno = 0;
		out[k] = strtod(p, &end);
		if (errno || end == p || !(out[k] >= lo && out[k] <= hi) || *end != (k + 1 < n ? ',' : '\0')) {
			fprintf(stderr, "swell-hm: %s '%s' must be %d comma-separated numbers in [%g, %g] %s\n", opt, v,
				n, lo, hi, unit);
			exit(2);
		}
		p = end + 1;
	}
}

/* Object and pool from a scene file: the defaults of the reference scene where it says nothing. */
static void scene_object(struct opts *o, const char *path)
{
	struct swell_scene sc;
	const struct swell_scene_value *v;
	double dx = 6.25, nx = 64, ny = 64;
	char err[300];

	if (swell_scene_load(path, &sc, err, sizeof(err)) < 0)
		die("--scene %s%s", err, "");
	if ((v = swell_scene_get(&sc, SWELL_PARAM_BODY_MASS_G)))
		o->obj_mass_g = v->raw;
	if ((v = swell_scene_get(&sc, SWELL_PARAM_BODY_A_UM)))
		o->obj_a_mm = v->raw / 1000.0;
	if ((v = swell_scene_get(&sc, SWELL_PARAM_BODY_B_UM)))
		o->obj_b_mm = v->raw / 1000.0;
	if ((v = swell_scene_get(&sc, SWELL_PARAM_BODY_H_UM)))
		o->obj_h_mm = v->raw / 1000.0;
	if ((v = swell_scene_get(&sc, SWELL_SCENE_DX_UM)))
		dx = v->raw / 1000.0;
	if ((v = swell_scene_get(&sc, SWELL_SCENE_NX)))
		nx = v->raw;
	if ((v = swell_scene_get(&sc, SWELL_SCENE_NY)))
		ny = v->raw;
	if ((v = swell_scene_get(&sc, SWELL_SCENE_DEPTH_UM)))
		o->depth_mm = v->raw / 1000.0;
	o->pool_mm[0] = nx * dx;
	o->pool_mm[1] = ny * dx;
}

/* 1 for an option of this program that takes a value. */
static int takes_value(const char *a)
{
	static const char *const with_value[] = {
		"--bias-watchdog", "--bind-port", "--damping",    "--effect-fresh", "--estop", "--fmax",  "--hand",
		"--host",          "--iface",     "--inject",     "--limit",        "--link",  "--log",   "--mass",
		"--node",          "--object",    "--pool",       "--port",         "--rate",  "--scene", "--seconds",
		"--serve",         "--start",     "--timeout-ms", "--watchdog"
	};
	size_t k;

	for (k = 0; k < sizeof(with_value) / sizeof(with_value[0]); k++)
		if (!strcmp(a, with_value[k]))
			return 1;
	return 0;
}

static void parse(int argc, char **argv, struct opts *o)
{
	char why[160];
	enum swell_err e;
	int k;

	memset(o, 0, sizeof(*o));
	o->link = "udp";
	o->host = SWELL_UDP_HOST;
	o->port = SWELL_UDP_PORT_DEVICE;
	o->timeout_ms = 50;
	o->bias_watchdog_ms = 100;
	o->effect_fresh_ms = 10.0;
	o->seconds = 10.0;
	o->obj_mass_g = 100.0;
	o->obj_a_mm = o->obj_b_mm = o->obj_h_mm = 50.0;
	o->depth_mm = 50.0;
	o->pool_mm[0] = o->pool_mm[1] = 400.0;
	o->estop_s[0] = o->estop_s[1] = -1.0;
	hm_params_default(&o->p);
	hm_hand_parse("idle", &o->hand, NULL, 0);
	for (k = 1; k < argc; k++) {
		const char *a = argv[k], *v = k + 1 < argc ? argv[k + 1] : NULL;

		if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
			fputs(usage, stdout);
			exit(0);
		} else if (!strcmp(a, "--lockstep")) {
			o->lockstep = 1;
			continue;
		} else if (!strcmp(a, "--quiet")) {
			o->quiet = 1;
			continue;
		} else if (!strcmp(a, "--rt")) {
			o->rt = 1;
			continue;
		} else if (!strcmp(a, "--serve") && (k + 1 >= argc || !strncmp(argv[k + 1], "--", 2))) {
			o->serve = "127.0.0.1:7654";
			continue;
		} else if (strncmp(a, "--", 2)) {
			die("unexpected argument %s%s", a, "");
		} else if (!v) {
			die(takes_value(a) ? "%s needs a value%s" : "unknown option %s%s (see --help)", a, "");
		}
		k++;
		if (!strcmp(a, "--link")) {
			if (swell_link_spec_parse(v, SWELL_LINK_ACCEPT_HOST_SIDE, (uint16_t)o->port, &o->ls, why,
						  sizeof(why)))
				die("--link %s%s", why, "");
			o->link = v;
			o->port = o->ls.port;
		} else if (!strcmp(a, "--host")) {
			struct in_addr ia;

			if (inet_pton(AF_INET, v, &ia) != 1)
				die("--host '%s' is not a dotted IPv4 address%s", v, "");
			o->host = v;
		} else if (!strcmp(a, "--port"))
			o->port = whole(a, v, 1, 65535, "");
		else if (!strcmp(a, "--serve")) {
			struct sockaddr_in sa;

			if (hm_serve_parse(v, &sa, why, sizeof(why)) < 0)
				die("--serve: %s%s", why, "");
			o->serve = v;
		} else if (!strcmp(a, "--inject")) {
			struct inject *j = &o->inj[o->n_inj];
			char kind[16];
			int used = 0;

			if (o->n_inj >= 8)
				die("--inject: at most 8 injections%s%s", "", "");
			memset(j, 0, sizeof(*j));
			j->at_s = -1;
			if (sscanf(v, "delay:at=%lf,for=%lf,ms=%lf%n", &j->at_s, &j->for_s, &j->ms, &used) == 3 &&
			    !v[used] && j->for_s > 0 && j->ms > 0 && j->ms <= 10000)
				j->kind = 'd';
			else if (sscanf(v, "%15[a-z]:at=%lf%n", kind, &j->at_s, &used) == 2 && !v[used] &&
				 (!strcmp(kind, "garbage") || !strcmp(kind, "reset") || !strcmp(kind, "stop")))
				j->kind = kind[0];
			if (!j->kind || !(j->at_s >= 0))
				die("--inject '%s' is not delay:at=S,for=S,ms=N (0 < N <= 10000), garbage:at=S, "
				    "reset:at=S "
				    "or stop:at=S%s",
				    v, "");
			o->n_inj++;
		} else if (!strcmp(a, "--effect-fresh"))
			o->effect_fresh_ms = number(a, v, 0.1, 1000, "ms");
		else if (!strcmp(a, "--bias-watchdog"))
			o->bias_watchdog_ms = whole(a, v, 0, 60000, "ms");
		else if (!strcmp(a, "--bind-port"))
			o->bind_port = whole(a, v, 0, 65535, "");
		else if (!strcmp(a, "--node"))
			o->node = whole(a, v, 0, SWELL_NODE_MAX, "");
		else if (!strcmp(a, "--iface"))
			o->iface = whole(a, v, 0, 255, "");
		else if (!strcmp(a, "--rate"))
			o->p.rate_hz = number(a, v, 100, 100000, "Hz");
		else if (!strcmp(a, "--timeout-ms"))
			o->timeout_ms = whole(a, v, 1, 10000, "ms");
		else if (!strcmp(a, "--seconds"))
			o->seconds = number(a, v, 1e-3, 1e6, "s");
		else if (!strcmp(a, "--mass"))
			o->p.mass_kg = number(a, v, 0.01, 1000, "kg");
		else if (!strcmp(a, "--damping"))
			o->p.damping_Ns_m = number(a, v, 0, 10000, "N s/m");
		else if (!strcmp(a, "--limit"))
			o->p.limit_m[0] = o->p.limit_m[1] = o->p.limit_m[2] = number(a, v, 1, 300, "mm") * 1e-3;
		else if (!strcmp(a, "--fmax"))
			o->p.f_max_N = number(a, v, 1e-3, 250, "N");
		else if (!strcmp(a, "--watchdog")) {
			o->p.watchdog_ticks = whole(a, v, 1, 100000, "ticks");
			o->watchdog_given = 1;
		} else if (!strcmp(a, "--start")) {
			numbers(a, v, o->start_mm, 3, -300, 300, "mm");
			o->have_start = 1;
		} else if (!strcmp(a, "--estop")) {
			numbers(a, v, o->estop_s, 2, 0, 1e6, "s");
			if (o->estop_s[1] <= o->estop_s[0])
				die("--estop A,B needs A < B, not '%s'%s", v, "");
		} else if (!strcmp(a, "--hand")) {
			e = hm_hand_parse(v, &o->hand, why, sizeof(why));
			if (e != SWELL_OK)
				die("--hand: %s%s", why, "");
		} else if (!strcmp(a, "--object")) {
			double ob[3];

			numbers(a, v, ob, 3, 1e-3, 1e6, "g, mm, mm");
			o->obj_mass_g = ob[0];
			o->obj_a_mm = ob[1];
			o->obj_b_mm = ob[2];
		} else if (!strcmp(a, "--pool")) {
			numbers(a, v, o->pool_mm, 2, 1, 1e5, "mm");
		} else if (!strcmp(a, "--scene")) {
			scene_object(o, v);
		} else if (!strcmp(a, "--log"))
			o->log = v;
		else
			die("unknown option %s%s", a, "");
	}
	if (o->pool_mm[0] <= o->obj_a_mm || o->pool_mm[1] <= o->obj_b_mm) {
		fprintf(stderr, "swell-hm: --pool %g,%g mm is not larger than the object's footprint %g x %g mm\n",
			o->pool_mm[0], o->pool_mm[1], o->obj_a_mm, o->obj_b_mm);
		exit(2);
	}
	e = hm_params_check(&o->p, o->hand.k_N_m, o->hand.b_Ns_m, why, sizeof(why));
	if (e != SWELL_OK)
		die("device parameters refused (%s): %s", swell_err_str(e), why);
	if (o->have_start)
		for (k = 0; k < 3; k++)
			if (fabs(o->start_mm[k]) > o->p.limit_m[k] * 1e3) {
				fprintf(stderr, "swell-hm: --start %.3f mm is outside the workspace (+-%.3f mm)\n",
					o->start_mm[k], o->p.limit_m[k] * 1e3);
				exit(2);
			}
}

/* ---- link ---- */

/* State -> force command latency at the device: wall time from sending a sample (DEVICE_POS) to the
 * first FORCE_CMD that arrives after it: both carriers, the controller's wake-up and its tick. 1 us bins
 * up to 50 ms, later in the last. */
#define LAT_US 50000
static struct latency {
	uint32_t hist[LAT_US + 1];
	uint64_t n;
	int64_t max_ns, sent_ns;
	int pending;
} lat;

static int64_t mono_ns(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

static void latency_answer(void)
{
	int64_t d;

	if (!lat.pending)
		return;
	lat.pending = 0;
	d = mono_ns() - lat.sent_ns;
	lat.hist[d / 1000 > LAT_US ? LAT_US : d / 1000]++;
	lat.n++;
	if (d > lat.max_ns)
		lat.max_ns = d;
}

static double latency_pct(double p)
{
	uint64_t want = (uint64_t)ceil(p * (double)lat.n), seen = 0;
	int k;

	for (k = 0; k <= LAT_US; k++) {
		seen += lat.hist[k];
		if (want > 0 && seen >= want)
			return k;
	}
	return 0;
}

struct dev {
	struct swell_link *l;
	enum swell_carrier carrier;
	uint8_t node;
	struct swell_proto_stats st;
	struct swell_seq force_seq;
	uint32_t commands, heartbeats, ignored, send_errors;
	int ctl_state; /* last HEARTBEAT state, -1 before the first */
	uint32_t ctl_faults; /* heartbeats that showed the controller entering FAULT */
	uint32_t fault_beats; /* heartbeats in FAULT */
	int ctl_err; /* the last error of the last heartbeat in FAULT */
	uint8_t force_seq_last;
	/* effect mode: the last complete set, its age in ticks, the limit stage on its force */
	struct swell_effect_rx erx;
	struct swell_effect eff;
	int have_eff;
	uint32_t eff_age, eff_fresh_ticks;
	uint32_t eff_sets, eff_ticks, eff_stale; /* sets taken, ticks rendered, times one went stale */
	struct swell_fsafety eff_safety;
};

static int dev_open(struct dev *d, const struct opts *o)
{
	const struct swell_link_open_opts uo = { .udp_host = o->host, .udp_bind_port = (uint16_t)o->bind_port };
	struct swell_link_spec ls;
	int rc;

	memset(d, 0, sizeof(*d));
	d->node = (uint8_t)o->node;
	d->ctl_state = -1;
	ls = o->ls;
	ls.port = (uint16_t)o->port;
	ls.iface = (uint8_t)o->iface;
	rc = swell_link_open_spec(&d->l, &ls, &uo);
	if (rc < 0) {
		fprintf(stderr, "swell-hm: cannot open link %s: %s\n", o->link, strerror(-rc));
		return -1;
	}
	d->carrier = swell_link_carrier(d->l);
	return 0;
}

static void dev_send(struct dev *d, const struct swell_msg *m, size_t n, uint8_t seq)
{
	struct swell_frame f;
	size_t used;

	while (n > 0) {
		if (swell_link_encode(d->carrier, d->node, seq, m, n, &f, &used) != SWELL_OK || used == 0) {
			d->send_errors++;
			return;
		}
		if (swell_link_send(d->l, &f) < 0)
			d->send_errors++;
		m += used;
		n -= used;
	}
}

/* Takes one frame if one comes within timeout_ms; returns the number of FORCE_CMD messages in it,
 * -1 when nothing came. */
static int dev_recv(struct dev *d, struct hm_state *s, int timeout_ms)
{
	struct swell_frame f;
	struct swell_msg m[SWELL_CANFD_MSGS_MAX];
	size_t n = 0, k;
	int cmds = 0, er;

	if (swell_link_recv(d->l, &f, timeout_ms) < 0)
		return -1;
	if (swell_link_decode(d->carrier, &f, m, SWELL_CANFD_MSGS_MAX, &n, NULL, &d->st) != SWELL_OK)
		return 0; /* counted in st, never acted on */
	for (k = 0; k < n; k++) {
		if (m[k].node != d->node) {
			d->ignored++;
		} else if (m[k].type == SWELL_MSG_FORCE_CMD) {
			const struct swell_msg_force_cmd *c = &m[k].u.force_cmd;
			double fN[3] = { c->fx_cN * 0.01, c->fy_cN * 0.01, c->fz_cN * 0.01 };

			latency_answer();
			swell_seq_track(&d->force_seq, c->seq);
			d->force_seq_last = c->seq;
			hm_command(s, fN, c->enable);
			if (!c->enable)
				d->have_eff = 0; /* not running (fault, stop, mode change): the effects go at once */
			d->commands++;
			cmds++;
		} else if ((er = swell_effect_recv(&d->erx, &m[k], &d->eff)) >= 0) {
			if (er == 1) { /* the three parts of one update are in */
				d->have_eff = 1;
				d->eff_age = 0;
				d->eff_sets++;
			}
		} else if (m[k].type == SWELL_MSG_HEARTBEAT) {
			if (m[k].u.heartbeat.state == 4) {
				d->ctl_faults += d->ctl_state != 4;
				d->fault_beats++;
				d->ctl_err = m[k].u.heartbeat.err;
			}
			d->ctl_state = m[k].u.heartbeat.state;
			d->heartbeats++;
		} else {
			d->ignored++;
		}
	}
	return cmds;
}

/* ---- the run ---- */

/* The watchdog without real-time scheduling: 20 ms of ticks (the default 2 trips on every late tick). */
#define SLOW_WATCHDOG_MS 20

/* SCHED_FIFO and mlockall when asked for. In real time without SCHED_FIFO the ticks are late by
 * milliseconds: unless --watchdog says otherwise the watchdog becomes SLOW_WATCHDOG_MS of ticks, said
 * on stderr. Lockstep needs neither. */
static void setup_rt(struct opts *o, int watchdog_given)
{
	struct sched_param sp = { .sched_priority = 70 };
	const char *why = "no --rt";
	char buf[96];
	uint32_t slow;

	if (o->rt) {
		if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
			fprintf(stderr, "swell-hm: warning: mlockall: %s; running without locked memory\n",
				strerror(errno));
		if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0)
			return;
		snprintf(buf, sizeof(buf), "SCHED_FIFO refused: %s", strerror(errno));
		why = buf;
	}
	if (o->lockstep)
		return;
	slow = (uint32_t)llround(o->p.rate_hz * SLOW_WATCHDOG_MS / 1000.0);
	if (!watchdog_given && slow > o->p.watchdog_ticks) {
		fprintf(stderr,
			"swell-hm: real time without real-time scheduling (%s): watchdog %u ticks (%.1f ms) "
			"instead of %u; --watchdog N to choose\n",
			why, slow, slow * 1e3 / o->p.rate_hz, o->p.watchdog_ticks);
		o->p.watchdog_ticks = slow;
	}
}

static volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
	(void)sig;
	stop_flag = 1;
}

static int64_t now_ns(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

static int16_t sat16(double v)
{
	double r = floor(v + 0.5);

	if (r != r)
		return 0; /* never a NaN on the wire (the checked parameters keep the model finite) */
	return (int16_t)(r > 30000.0 ? 30000 : r < -30000.0 ? -30000 : r);
}

static int16_t force_cN(double f_N)
{
	double r = floor(f_N * 100.0 + 0.5);

	if (r != r)
		return 0;
	return (int16_t)(r > 25000.0 ? 25000 : r < -25000.0 ? -25000 : r);
}

/* Effect mode, every tick before the model steps: the force the last effect set produces at the
 * position and velocity the device reports (0.01 mm, 0.1 mm/s, as on the wire), through the device's
 * own limit stage (the set's F_max and rate). Rendered only while the set is fresh (eff_age below
 * the freshness limit) and the controller's FORCE_CMD enables it; the model then applies it under the
 * command's watchdog and e-stop (hm_model.h). Otherwise the stage drops to zero at once. */
static void effect_tick(struct dev *d, struct hm_state *s, const struct hm_params *p)
{
	int32_t f_uN = 0;
	int on = d->have_eff && d->eff_age < d->eff_fresh_ticks && s->cmd_enable;

	if (d->have_eff && d->eff_age == d->eff_fresh_ticks)
		d->eff_stale++;
	if (on) {
		const struct swell_fsafety_params sp = { SWELL_Q16_ONE, d->eff.fmax_cN * 10000u,
							 d->eff.rate_100mN_s * 100000u, (uint32_t)p->rate_hz };

		if (swell_fsafety_set(&d->eff_safety, &sp) != SWELL_OK)
			on = 0;
		else
			f_uN = swell_effect_force_uN(&d->eff, sat16(s->x[2] * 1e5), sat16(s->v[2] * 1e4));
	}
	s->effect_N[0] = s->effect_N[1] = 0.0;
	s->effect_N[2] = swell_fsafety_apply(&d->eff_safety, f_uN, on) * 1e-6;
	d->eff_ticks += on != 0;
	if (d->have_eff && d->eff_age < UINT32_MAX)
		d->eff_age++;
}

#define HIST_US 10000

struct run {
	uint64_t ticks, timeouts, zeroed_ticks, late_ticks;
	uint64_t own_ticks; /* lockstep: controller ticks that no sample drove (its seq moved against ours) */
	int have_offset;
	uint8_t offset, offset0; /* FORCE_CMD seq - n: now, and at the first answer */
	double peak_f_N, z_sum, z_min, z_max;
	uint64_t z_n;
	int held_late; /* the hand held the handle in the last second: no free float to compare */
	uint32_t hist[HIST_US + 1];
	int64_t late_max_ns;
};

static double pct(const struct run *r, double p)
{
	uint64_t want = (uint64_t)ceil(p * (double)r->ticks), seen = 0;
	int k;

	for (k = 0; k <= HIST_US; k++) {
		seen += r->hist[k];
		if (want > 0 && seen >= want)
			return k;
	}
	return 0;
}

/* DEVICE_VEL, DEVICE_FORCE (the force sensor under the handle: what the hand pushes) and DEVICE_POS
 * every tick, POS last: swell-ctl --clock device ticks on POS, so the rest of the sample is in by
 * then. DEVICE_FORCE only where the carrier has room, i.e. not on classic CAN at 2500 Hz. */
static void sample(struct dev *d, const struct hm_state *s, const double f_hand_N[3], uint8_t seq)
{
	struct swell_msg m[3];
	uint8_t status = SWELL_DEV_POWERED;
	int with_force = d->carrier == SWELL_CARRIER_PKT;

	if (!s->estop)
		status |= SWELL_DEV_FORCE_ON;
	else
		status |= SWELL_DEV_ESTOP;
	memset(m, 0, sizeof(m));
	m[0].type = SWELL_MSG_DEVICE_VEL;
	m[0].node = d->node;
	m[0].u.device_vel.vx_100ums = sat16(s->v[0] * 1e4);
	m[0].u.device_vel.vy_100ums = sat16(s->v[1] * 1e4);
	m[0].u.device_vel.vz_100ums = sat16(s->v[2] * 1e4);
	m[0].u.device_vel.seq = seq;
	m[1].type = SWELL_MSG_DEVICE_FORCE;
	m[1].node = d->node;
	m[1].u.device_force.fx_cN = force_cN(f_hand_N[0]);
	m[1].u.device_force.fy_cN = force_cN(f_hand_N[1]);
	m[1].u.device_force.fz_cN = force_cN(f_hand_N[2]);
	m[1].u.device_force.seq = seq;
	m[2].type = SWELL_MSG_DEVICE_POS;
	m[2].node = d->node;
	m[2].u.device_pos.x_10um = sat16(s->x[0] * 1e5);
	m[2].u.device_pos.y_10um = sat16(s->x[1] * 1e5);
	m[2].u.device_pos.z_10um = sat16(s->x[2] * 1e5);
	m[2].u.device_pos.seq = seq;
	m[2].u.device_pos.status = status;
	if (!with_force)
		m[1] = m[2];
	lat.sent_ns = mono_ns();
	lat.pending = 1;
	dev_send(d, m, with_force ? 3 : 2, seq);
}

/* Lockstep: the answer to sample n is the first FORCE_CMD after it. Once the controller is lost (the
 * watchdog has dropped its force) wait only 1 ms a tick, so that simulated time goes on. */
static void wait_answer(struct dev *d, struct hm_state *s, const struct opts *o, struct run *r, uint64_t n)
{
	int lost = s->cmd_age > o->p.watchdog_ticks, got = 0;
	int64_t deadline = now_ns() + (int64_t)(lost ? 1 : o->timeout_ms) * 1000000;
	uint8_t off;

	while (!got && !stop_flag) {
		int64_t left = deadline - now_ns();

		if (left <= 0)
			break;
		got = dev_recv(d, s, (int)((left + 999999) / 1000000)) > 0;
	}
	if (!got) {
		r->timeouts++;
		return;
	}
	/* the controller's FORCE_CMD seq against ours moves only when it ticked without a sample */
	off = (uint8_t)(d->force_seq_last - (uint8_t)n);
	if (!r->have_offset)
		r->offset0 = off;
	else if (off != r->offset)
		r->own_ticks += (uint8_t)(off - r->offset);
	r->offset = off;
	r->have_offset = 1;
}

/* Real time: sleep to the next absolute deadline; the lateness of the wake-up goes into r. */
static void sleep_deadline(struct run *r, int64_t *next, int64_t period_ns)
{
	struct timespec dl;
	int64_t late;

	*next += period_ns;
	dl.tv_sec = (time_t)(*next / 1000000000);
	dl.tv_nsec = (long)(*next % 1000000000);
	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &dl, NULL) == EINTR && !stop_flag)
		;
	late = now_ns() - *next;
	r->hist[late < 0 ? 0 : late / 1000 > HIST_US ? HIST_US : late / 1000]++;
	if (late > r->late_max_ns)
		r->late_max_ns = late;
	if (late > period_ns) { /* a whole period lost: count it, start again from now */
		r->late_ticks++;
		*next = now_ns();
	}
}

/* Real time: sleep to the next absolute deadline, then take what arrived. */
static void wait_deadline(struct dev *d, struct hm_state *s, struct run *r, int64_t *next, int64_t period_ns)
{
	sleep_deadline(r, next, period_ns);
	while (dev_recv(d, s, 0) >= 0)
		;
}

/* After a tick: the figures of the summary. */
static void account(struct run *r, const struct hm_state *s, double t, double last_window, int holding)
{
	double fc = sqrt(s->f_cmd_N[0] * s->f_cmd_N[0] + s->f_cmd_N[1] * s->f_cmd_N[1] + s->f_cmd_N[2] * s->f_cmd_N[2]);
	double z = s->x[2] * 1e3;

	r->ticks++;
	r->zeroed_ticks += !s->applying && s->cmd_enable;
	r->peak_f_N = fc > r->peak_f_N ? fc : r->peak_f_N;
	if (t < last_window)
		return;
	r->z_sum += z;
	r->z_n++;
	r->z_min = z < r->z_min ? z : r->z_min;
	r->z_max = z > r->z_max ? z : r->z_max;
	r->held_late |= holding;
}

/* The summary's head: time run, final position, equilibrium against -m g/k and the level rise. */
/* d: the swell-protocol device (its controller faults are told), NULL with --serve. */
static void summary_head(const struct opts *o, const struct hm_state *s, const struct run *r, const struct dev *d,
			 double wall_s)
{
	double dt = 1.0 / o->p.rate_hz;
	/* at rest the object floats with k delta = m g, k = rho g a b: delta = m / (rho a b); the water
	 * it displaces raises the pool's mean level by m / (rho A_pool), and delta is measured from it */
	double z_rest = -(o->obj_mass_g * 1e-3) / (RHO_KG_M3 * o->obj_a_mm * o->obj_b_mm * 1e-6) * 1e3;
	double z_level = (o->obj_mass_g * 1e-3 / RHO_KG_M3) / (o->pool_mm[0] * o->pool_mm[1] * 1e-6) * 1e3;

	printf("swell-hm summary\n");
	printf("  ran             %.4f s simulated, %llu ticks at %g Hz, %s, %.3f s wall\n", (double)r->ticks * dt,
	       (unsigned long long)r->ticks, o->p.rate_hz, o->lockstep ? "lockstep" : "real time", wall_s);
	printf("  final position  %+.3f %+.3f %+.3f mm (x y z), velocity %+.2f %+.2f %+.2f mm/s\n", s->x[0] * 1e3,
	       s->x[1] * 1e3, s->x[2] * 1e3, s->v[0] * 1e3, s->v[1] * 1e3, s->v[2] * 1e3);
	if (r->z_n > 0) {
		double zm = r->z_sum / (double)r->z_n;

		printf("  equilibrium z   %+.3f mm mean over the last %.3f s (min %+.3f, max %+.3f mm)\n", zm,
		       (double)r->z_n * dt, r->z_min, r->z_max);
		if (r->held_late) {
			printf("  expected z      none: the hand held the handle in that second\n");
		} else if (o->obj_mass_g * 1e-3 > RHO_KG_M3 * o->obj_a_mm * o->obj_b_mm * o->obj_h_mm * 1e-9) {
			/* heavier than the water it can displace: it sinks until the floor carries it */
			printf("  expected z      %+.3f mm on the floor: m %.0f g > rho a b H %.0f g (sinks); error "
			       "%+.3f mm\n",
			       -o->depth_mm, o->obj_mass_g, RHO_KG_M3 * o->obj_a_mm * o->obj_b_mm * o->obj_h_mm * 1e-6,
			       zm + o->depth_mm);
		} else {
			if ((d && d->ctl_faults) || s->watchdog_trips)
				printf("  NOT A CLEAN RUN the controller faulted %u times and the watchdog tripped %u "
				       "times: the figures below include those times without force\n",
				       d ? d->ctl_faults : 0u, s->watchdog_trips);
			printf("  expected z      %+.3f mm = -m g/k; error %+.3f %%\n", z_rest,
			       (zm - z_rest) / -z_rest * 100.0);
			printf("  with level rise %+.3f mm (-m g/k + %.3f mm mean level rise); error %+.3f %%\n",
			       z_rest + z_level, z_level, (zm - z_rest - z_level) / -(z_rest + z_level) * 100.0);
		}
	}
}

static void summary(const struct opts *o, const struct dev *d, const struct hm_state *s, const struct run *r,
		    double wall_s)
{
	summary_head(o, s, r, d, wall_s);
	printf("  peak force      %.3f N (|F_cmd| applied)\n", r->peak_f_N);
	printf("  commands        %u received, %u lost, %u repeated, %u bad frames, %u send errors, %u other "
	       "messages ignored, %u resyncs\n",
	       d->commands, d->force_seq.lost, d->force_seq.repeated, swell_proto_rejected_total(&d->st),
	       d->send_errors, d->ignored, d->force_seq.resyncs);
	if (o->lockstep)
		printf("  timeouts        %llu (lockstep waits of %u ms without an answer); %llu controller ticks "
		       "between samples, %u before the first (mod 256)\n",
		       (unsigned long long)r->timeouts, o->timeout_ms, (unsigned long long)r->own_ticks, r->offset0);
	else
		printf("  tick lateness   p50 %.0f us, p99 %.0f us, max %.0f us; %llu periods lost\n", pct(r, 0.5),
		       pct(r, 0.99), r->late_max_ns / 1e3, (unsigned long long)r->late_ticks);
	printf("  latency         sample -> command p50 %.0f us, p99 %.0f us, max %.0f us (%llu answers: the first "
	       "FORCE_CMD after each DEVICE_POS, wall clock)\n",
	       latency_pct(0.5), latency_pct(0.99), lat.max_ns / 1e3, (unsigned long long)lat.n);
	printf("  watchdog        %u trips (%u ticks), %llu ticks with an enabled command not applied\n",
	       s->watchdog_trips, o->p.watchdog_ticks, (unsigned long long)r->zeroed_ticks);
	printf("  effects         %u sets, %u ticks rendered, %u went stale (freshness %u ticks)\n", d->eff_sets,
	       d->eff_ticks, d->eff_stale, d->eff_fresh_ticks);
	printf("  walls           %u ticks in a workspace wall\n", s->wall_ticks);
	printf("  controller      last state %d (0 boot, 1 idle, 2 armed, 3 running, 4 fault), %u heartbeats\n",
	       d->ctl_state, d->heartbeats);
	if (d->ctl_faults)
		printf("  FAULTED         the controller faulted %u times (%u heartbeats in FAULT, last error: %s)\n",
		       d->ctl_faults, d->fault_beats, swell_err_str((enum swell_err)d->ctl_err));
}

/* ---- --serve: the HapticMaster's own TCP interface ---- */

/* Lockstep with --serve: wait until some client's request has been run (or the timeout). */
static void serve_wait(struct hm_serve *srv, struct hm_dev *dev, const struct opts *o, struct run *r)
{
	uint32_t before = srv->st.requests;
	int64_t deadline = now_ns() + (int64_t)o->timeout_ms * 1000000;

	for (;;) {
		struct pollfd pf[HM_SERVE_CLIENTS + 1];
		int n = 0, k;
		int64_t left;

		hm_serve_poll(srv, dev, now_ns());
		if (srv->st.requests != before || stop_flag)
			return;
		left = deadline - now_ns();
		if (left <= 0)
			break;
		pf[n++] = (struct pollfd){ srv->lfd, POLLIN, 0 };
		for (k = 0; k < HM_SERVE_CLIENTS; k++)
			if (srv->c[k].fd >= 0)
				pf[n++] = (struct pollfd){ srv->c[k].fd, POLLIN, 0 };
		poll(pf, (nfds_t)n, (int)((left + 999999) / 1000000));
	}
	r->timeouts++;
}

static void serve_summary(const struct opts *o, const struct hm_serve *srv, const struct hm_dev *dev,
			  const struct hm_state *s, const struct run *r, double wall_s)
{
	const struct hm_serve_stats *st = &srv->st;

	summary_head(o, s, r, NULL, wall_s);
	printf("  peak force      %.3f N (|F| of the effects applied)\n", r->peak_f_N);
	printf("  server          %s: %u clients accepted, %u refused (table full), %u requests, %u commands, "
	       "%u error answers, %u replies\n",
	       srv->name, st->accepted, st->refused_full, st->requests, dev->commands, dev->errors, st->replies);
	printf("  bad clients     %u bad headers (closed), %u binary garbage (answered), %u stalled mid-request "
	       "(dropped), %u not reading (dropped), %u vanished, %u ticks with requests left for the next\n",
	       st->drop_header, st->garbage, st->drop_stalled, st->drop_not_reading, st->vanished, st->deferred_ticks);
	if (o->n_inj)
		printf("  injected        %u connection resets, %u garbage bursts, %u replies delayed\n",
		       st->injected_resets, st->injected_garbage, st->delayed_replies);
	printf("  bytes           %llu in, %llu out\n", (unsigned long long)st->bytes_in,
	       (unsigned long long)st->bytes_out);
	printf("  request age     p50 %.0f us, p99 %.0f us, max %.0f us at application (kernel arrival to the end "
	       "of the step that applies it; %llu ticks)\n",
	       hm_serve_age_pct(srv, 0.5), hm_serve_age_pct(srv, 0.99), st->age_max_ns / 1e3,
	       (unsigned long long)st->ages);
	if (o->lockstep)
		printf("  timeouts        %llu (lockstep waits of %u ms without a request)\n",
		       (unsigned long long)r->timeouts, o->timeout_ms);
	else
		printf("  tick lateness   p50 %.0f us, p99 %.0f us, max %.0f us; %llu periods lost\n", pct(r, 0.5),
		       pct(r, 0.99), r->late_max_ns / 1e3, (unsigned long long)r->late_ticks);
	printf("  device          state %s, %u bias forces zeroed by the watchdog (%u ticks), %u by a vanished "
	       "client, %u e-stops\n",
	       hm_dev_state_name(dev->state), dev->watchdog_trips, dev->watchdog_ticks, dev->vanished_zeroed,
	       dev->estop_stops);
	printf("  walls           %u ticks in a workspace wall\n", s->wall_ticks);
}

/* --inject: the bench's TCP faults at their simulated times, each announced on stderr. */
static void inject(struct opts *o, struct hm_serve *srv, struct hm_dev *dev, double t)
{
	int k;

	srv->reply_delay_ns = 0;
	for (k = 0; k < o->n_inj; k++) {
		struct inject *j = &o->inj[k];

		if (j->kind == 'd' && t >= j->at_s && t < j->at_s + j->for_s)
			srv->reply_delay_ns = (int64_t)(j->ms * 1e6);
		if (j->done || t < j->at_s)
			continue;
		j->done = 1;
		fprintf(stderr, "swell-hm: inject %s at %.4f s\n",
			j->kind == 'd'           ? "delay"
				: j->kind == 'g' ? "garbage"
				: j->kind == 'r' ? "reset"
						 : "stop",
			t);
		if (j->kind == 'g')
			hm_serve_inject_garbage(srv);
		else if (j->kind == 'r')
			hm_serve_inject_reset(srv, dev);
		else if (j->kind == 's') {
			char reply[64];

			hm_dev_request(dev, -1, "set state stop", 14, reply, sizeof(reply));
		}
	}
}

/* The device loop with the HapticMaster's TCP interface: each tick, run what the clients sent
 * (answers describe the state before this tick's step), then render the effects and integrate. */
static int serve_main(struct opts *o, FILE *log, const double x0[3])
{
	static struct hm_serve srv;
	static struct hm_dev dev;
	static struct run r;
	struct hm_state s;
	char err[160];
	double dt = 1.0 / o->p.rate_hz, last_window = o->seconds > 1.0 ? o->seconds - 1.0 : 0.0;
	int64_t start, next, period_ns = (int64_t)llround(1e9 / o->p.rate_hz), last_status;
	uint64_t n, total = (uint64_t)llround(o->seconds * o->p.rate_hz);
	uint32_t requests_seen = 0, req_age = 0;

	if (hm_serve_open(&srv, o->serve, err, sizeof(err)) < 0) {
		fprintf(stderr, "swell-hm: --serve: %s\n", err);
		return 1;
	}
	hm_dev_init(&dev, o->p.rate_hz, o->p.f_max_N);
	dev.inertia_kg = o->p.mass_kg;
	dev.watchdog_ticks = (uint32_t)llround(o->bias_watchdog_ms * 1e-3 * o->p.rate_hz);
	if (o->bias_watchdog_ms > 0 && dev.watchdog_ticks == 0)
		dev.watchdog_ticks = 1;
	hm_init(&s, x0);
	r.z_min = INFINITY;
	r.z_max = -INFINITY;
	fprintf(stderr,
		"swell-hm: serving the HapticMaster interface on %s, %s at %g Hz, hand %s, inertia %g kg, "
		"bias watchdog %u ms\n",
		srv.name, o->lockstep ? "lockstep" : "real time", o->p.rate_hz, hm_hand_name(o->hand.kind),
		dev.inertia_kg, o->bias_watchdog_ms);
	start = next = last_status = now_ns();
	for (n = 0; n < total && !stop_flag; n++) {
		double t = (double)n * dt, f_hand[3], f_fx[3], x[3], v[3];
		int holding, k;

		hm_dev_set_estop(&dev, t >= o->estop_s[0] && t < o->estop_s[1]);
		inject(o, &srv, &dev, t);
		memcpy(dev.x_m, s.x, sizeof(dev.x_m));
		memcpy(dev.v_m_s, s.v, sizeof(dev.v_m_s));
		holding = hm_hand_force(&o->hand, t, s.x, s.v, f_hand);
		for (k = 0; k < 3; k++)
			dev.fmeas_N[k] = f_hand[k];
		if (o->lockstep)
			serve_wait(&srv, &dev, o, &r);
		else {
			sleep_deadline(&r, &next, period_ns);
			hm_serve_poll(&srv, &dev, now_ns());
		}
		memcpy(x, s.x, sizeof(x));
		memcpy(v, s.v, sizeof(v));
		hm_dev_tick(&dev, s.x, s.v, f_fx);
		hm_command(&s, f_fx, 1);
		o->p.mass_kg = dev.inertia_kg;
		hm_step(&o->p, &s, f_hand);
		hm_serve_applied(&srv);
		/* ticks since a request was last run: a silent client shows in the log as a silent
		 * controller does in the swell protocol's command age */
		req_age = srv.st.requests != requests_seen ? 0 : req_age + 1;
		requests_seen = srv.st.requests;
		for (k = 0; k < 3; k++)
			dev.a_m_s2[k] = (s.v[k] - v[k]) / dt;
		account(&r, &s, t, last_window, holding);
		if (log)
			fprintf(log,
				"%.4f,%.3f,%.3f,%.3f,%.2f,%.2f,%.2f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%d,%d,%d,%d,%d\n", t,
				x[0] * 1e3, x[1] * 1e3, x[2] * 1e3, v[0] * 1e3, v[1] * 1e3, v[2] * 1e3, s.f_cmd_N[0],
				s.f_cmd_N[1], s.f_cmd_N[2], f_hand[0], f_hand[1], f_hand[2], (int)req_age,
				hm_serve_clients(&srv), s.applying, (int)dev.state, holding);
		if (!o->quiet && now_ns() - last_status > 1000000000) {
			last_status = now_ns();
			fprintf(stderr, "\rswell-hm: t %.1f s, z %+.2f mm, F %+.3f N, state %s, %d clients   ", t,
				s.x[2] * 1e3, s.f_cmd_N[2], hm_dev_state_name(dev.state), hm_serve_clients(&srv));
		}
	}
	if (!o->quiet && now_ns() - start > 1000000000)
		fputc('\n', stderr);
	if (log && fclose(log) != 0)
		fprintf(stderr, "swell-hm: writing %s failed\n", o->log);
	serve_summary(o, &srv, &dev, &s, &r, (now_ns() - start) / 1e9);
	hm_serve_close(&srv, &dev);
	return 0;
}

int main(int argc, char **argv)
{
	static struct run r;
	struct opts o;
	struct dev d;
	struct hm_state s;
	struct sigaction sa;
	FILE *log = NULL;
	int rc = 0;
	double x0[3], dt, last_window;
	int64_t start, next, period_ns, last_status;
	uint64_t n, total;
	int k;

	parse(argc, argv, &o);
	if (o.have_start)
		for (k = 0; k < 3; k++)
			x0[k] = o.start_mm[k] * 1e-3;
	else
		hm_hand_start(&o.hand, x0);
	if (o.log) {
		log = fopen(o.log, "w");
		if (!log) {
			fprintf(stderr, "swell-hm: cannot write %s: %s\n", o.log, strerror(errno));
			return 1;
		}
		fputs("t_s,x_mm,y_mm,z_mm,vx_mm_s,vy_mm_s,vz_mm_s,fcmd_x_N,fcmd_y_N,fcmd_z_N,"
		      "fhand_x_N,fhand_y_N,fhand_z_N,",
		      log);
		/* --serve: the effects' force; the ticks since a request was last run, the number of
		 * clients and the device state (0 off, 1 init, 2 home, 3 force, 4 position, 5 stop) instead
		 * of the swell protocol's command columns */
		fputs(o.serve ? "req_age,clients,applied,dev_state,holding\n"
			      : "enable,cmd_age,applied,ctl_state,holding\n",
		      log);
	}
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);
	setup_rt(&o, o.watchdog_given);
	if (o.serve)
		return serve_main(&o, log, x0);
	if (dev_open(&d, &o) < 0)
		return 1;
	d.eff_fresh_ticks = (uint32_t)lround(o.effect_fresh_ms * 1e-3 * o.p.rate_hz);
	if (d.eff_fresh_ticks < 1)
		d.eff_fresh_ticks = 1;

	hm_init(&s, x0);
	dt = 1.0 / o.p.rate_hz;
	period_ns = (int64_t)llround(1e9 / o.p.rate_hz);
	total = (uint64_t)llround(o.seconds * o.p.rate_hz);
	last_window = o.seconds > 1.0 ? o.seconds - 1.0 : 0.0;
	r.z_min = INFINITY;
	r.z_max = -INFINITY;
	fprintf(stderr, "swell-hm: %s, %s at %g Hz, hand %s, m_v %g kg, b_v %g N s/m, watchdog %u ticks\n",
		swell_link_name(d.l), o.lockstep ? "lockstep" : "real time", o.p.rate_hz, hm_hand_name(o.hand.kind),
		o.p.mass_kg, o.p.damping_Ns_m, o.p.watchdog_ticks);
	start = next = last_status = now_ns();
	for (n = 0; n < total && !stop_flag; n++) {
		double t = (double)n * dt, f_hand[3], x[3], v[3];
		uint32_t age;
		int holding;

		s.estop = t >= o.estop_s[0] && t < o.estop_s[1];
		/* commands that came in since the last tick (stale ones included: the latest wins) */
		while (dev_recv(&d, &s, 0) >= 0)
			;
		/* the hand acts on the state of this tick, which the wait below does not change */
		holding = hm_hand_force(&o.hand, t, s.x, s.v, f_hand);
		sample(&d, &s, f_hand, (uint8_t)n);
		if (o.lockstep)
			wait_answer(&d, &s, &o, &r, n);
		else
			wait_deadline(&d, &s, &r, &next, period_ns);
		age = s.cmd_age;
		memcpy(x, s.x, sizeof(x));
		memcpy(v, s.v, sizeof(v));
		effect_tick(&d, &s, &o.p);
		hm_step(&o.p, &s, f_hand);
		account(&r, &s, t, last_window, holding);
		if (log)
			fprintf(log,
				"%.4f,%.3f,%.3f,%.3f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%.3f,%.3f,%.3f,%d,%u,%d,%d,%d\n", t,
				x[0] * 1e3, x[1] * 1e3, x[2] * 1e3, v[0] * 1e3, v[1] * 1e3, v[2] * 1e3, s.f_cmd_N[0],
				s.f_cmd_N[1], s.f_cmd_N[2], f_hand[0], f_hand[1], f_hand[2], s.cmd_enable, age,
				s.applying, d.ctl_state, holding);
		if (!o.quiet && now_ns() - last_status > 1000000000) {
			last_status = now_ns();
			fprintf(stderr, "\rswell-hm: t %.1f s, z %+.2f mm, F_cmd %+.3f N, ctl %d   ", t, s.x[2] * 1e3,
				s.f_cmd_N[2], d.ctl_state);
		}
	}
	if (!o.quiet && now_ns() - start > 1000000000)
		fputc('\n', stderr);
	if (log && (ferror(log) | fclose(log)) != 0) {
		fprintf(stderr, "swell-hm: writing %s failed: %s\n", o.log, strerror(errno));
		rc = 1;
	}
	summary(&o, &d, &s, &r, (now_ns() - start) / 1e9);
	if (d.commands == 0 && d.heartbeats == 0) {
		fprintf(stderr, "swell-hm: no controller answered on %s in %.1f s (no FORCE_CMD, no HEARTBEAT)\n",
			swell_link_name(d.l), (now_ns() - start) / 1e9);
		rc = 1;
	}
	swell_link_close(d.l);
	return rc;
}
