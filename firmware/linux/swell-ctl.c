/* swell-ctl: the controller as a Linux real-time process. The core (firmware/core) does everything
 * that matters; this port gives it a clock, its two links and a report.
 *
 * Clock: absolute-deadline clock_nanosleep on CLOCK_MONOTONIC at the device rate, under SCHED_FIFO
 * and mlockall where permitted (a warning otherwise); or, with --clock device, one tick per
 * DEVICE_POS received (the device's servo clock drives the loop, as on a HapticMaster bus; in effect
 * mode, where the device reports once an update, as many ticks as the sample's seq step), with the
 * silence of the device still detected by a timeout of the silence limit (swell_ctl_silent_limit).
 * SIGINT/SIGTERM: zero force is sent first, then the report, then a clean exit.
 * ENTER_BOOTLOADER accepted by the core (outside RUNNING, with the key): the core has zeroed the force
 * and queued a last heartbeat; both go out, then the report, then exit status 3, so that a
 * supervisor can run the flasher and start the new image (the Linux port has no ROM bootloader). */
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
#include <unistd.h>

#include "ctl_link.h"
#include "swell/ctl.h"
#include "swell/scene.h"

static const char usage[] =
	"usage: swell-ctl [options]\n"
	"The swell controller as a Linux real-time process: wave solver, force law and safety on the\n"
	"device tick, telemetry to a viewer.\n"
	"\n"
	"  --device LINK       device (HapticMaster) link: udp[:PORT][,peer=[ADDR:]PORT] (default udp:47800,\n"
	"                      listen on 127.0.0.1; the device is the peer given, else the first sender of\n"
	"                      this node's DEVICE_POS, held until it is declared lost; every other sender\n"
	"                      is counted and ignored), can:IFACE, usb:FFS_DIR (FunctionFS mount: the\n"
	"                      controller is the USB device), hm:HOST[:PORT] (a HapticMaster's TCP command\n"
	"                      interface, port 7654 unless given: one pipelined request a tick,\n"
	"                      docs/hapticmaster.md)\n"
	"  --host LINK         viewer link: udp[:PORT][,listen=[ADDR:]PORT] (default udp:47801: telemetry\n"
	"                      to 127.0.0.1:47801; up to 4 more clients, each admitted by its first valid\n"
	"                      packet to the listen port (default 127.0.0.1:47802, where swell-tool and\n"
	"                      swell-flash look; any free port if that is taken, printed; listen=0: any\n"
	"                      free port) and dropped after 3 s of silence), can:IFACE, usb:FFS_DIR, none\n"
	"                      Both on USB: two FunctionFS mounts, interfaces 0 (device) and 1 (host) of\n"
	"                      one gadget. CAN: the driver's error frames are read; a device-link bus-off\n"
	"                      zeroes the force and faults the loop until the bus is restarted.\n"
	"  --clock internal|device   own absolute-deadline clock (default) or one tick per device sample\n"
	"                      (effect mode: the device ticks its seq step says; a silent device is still\n"
	"                      noticed: after the silence limit in wall time the loop ticks on its own)\n"
	"  --tick-hz N         device rate (default 2500; 1000 for classic CAN)\n"
	"  --solver-hz N       solver rate (default 250; must divide the tick rate)\n"
	"  --silent-ticks N    device silent this many ticks -> zero force and fault (default 2 with\n"
	"                      real-time scheduling; without it, as with --no-rt or when SCHED_FIFO is\n"
	"                      refused, 20 ms of ticks, said at start: a process that is not real time\n"
	"                      is late by milliseconds); effect mode counts update periods instead of ticks\n"
	"  --autorun           run whenever the device is there; leave a link-loss fault by itself\n"
	"  --host-budget N     host messages a tick (default 16)\n"
	"  --node N            node id on the bus, 0..15 (default 0)\n"
	"  --scene FILE        start with a scene file (*.scene: pool size, cell size, depth, solver rate,\n"
	"                      object, damping, force limits; docs/tool.md); options after it override\n"
	"                      its pool and rates, its parameters override the options; a bad line or a\n"
	"                      refused value: exit 2 naming the line\n"
	"  --seconds S         stop after S seconds of ticks (default: until SIGINT/SIGTERM)\n"
	"  --no-rt             do not ask for SCHED_FIFO and mlockall\n"
	"  --fw-version X.Y.Z  firmware version reported in CTL_INFO (default " SWELL_CTL_FW_VERSION ", the\n"
	"                      build's; a test can play \"the new image\" with it), each part 0..255\n"
	"  --quiet             no status line while running\n"
	"  -h, --help          this text\n"
	"\n"
	"On exit prints a report: ticks, solver steps, state, tick jitter (p50, p99, max), overruns, frames,\n"
	"the largest wave and the solver's saturations.\n"
	"Exit status: 0 clean stop, 1 a runtime failure (a link cannot be opened), 2 bad arguments (one\n"
	"line on stderr; a malformed link spec or two links on one port or mount included),\n"
	"3 a viewer or swell-flash asked for the bootloader (ENTER_BOOTLOADER accepted: force zeroed,\n"
	"last heartbeat sent; a supervisor starts the flasher, then the new image).\n";

static volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
	(void)sig;
	stop_flag = 1;
}

/* The device silence limit without real-time scheduling: 20 ms of ticks, at least the default. */
#define SLOW_SILENCE_MS 20

struct opts {
	const char *device, *host, *scene_path;
	int device_clock, rt, quiet, silent_given;
	double seconds;
	struct swell_ctl_config cfg;
	struct swell_scene scene;
};

static void die(const char *msg, const char *arg)
{
	fprintf(stderr, "swell-ctl: %s%s\n", msg, arg ? arg : "");
	exit(2);
}

static long num(const char *opt, const char *v, long lo, long hi)
{
	char *end;
	long x;

	errno = 0;
	x = strtol(v, &end, 10);
	if (errno || *v == '\0' || *end || x < lo || x > hi) {
		fprintf(stderr, "swell-ctl: %s '%s' is not a whole number in [%ld, %ld]\n", opt, v, lo, hi);
		exit(2);
	}
	return x;
}

/* "X.Y.Z", each part 0..255, into v[3]; 0 on success. */
static int parse_version(const char *s, uint8_t v[3])
{
	unsigned a, b, c;
	int n = 0;

	if (sscanf(s, "%3u.%3u.%3u%n", &a, &b, &c, &n) != 3 || s[n] || a > 255 || b > 255 || c > 255 ||
	    !strchr("0123456789", s[0]))
		return -1;
	v[0] = (uint8_t)a;
	v[1] = (uint8_t)b;
	v[2] = (uint8_t)c;
	return 0;
}

/* 1 for an option that takes a value. */
static int takes_value(const char *a)
{
	static const char *const with_value[] = { "--device",     "--host",         "--clock",       "--tick-hz",
						  "--solver-hz",  "--silent-ticks", "--host-budget", "--node",
						  "--fw-version", "--seconds",      "--scene" };
	size_t k;

	for (k = 0; k < sizeof(with_value) / sizeof(with_value[0]); k++)
		if (!strcmp(a, with_value[k]))
			return 1;
	return 0;
}

/* The two links must not be one: the host link's telemetry sent into the device port, or one
 * FunctionFS mount for both. Compared as spelled (udp: the port, the default 47800 / 47801). */
static void check_links(const struct opts *o)
{
	const char *dp = !strcmp(o->device, "udp") ? "47800" : !strncmp(o->device, "udp:", 4) ? o->device + 4 : NULL;
	const char *hp = !strcmp(o->host, "udp") ? "47801" : !strncmp(o->host, "udp:", 4) ? o->host + 4 : NULL;

	if (dp && hp && strtol(dp, NULL, 10) == strtol(hp, NULL, 10) && strtol(dp, NULL, 10) > 0) {
		fprintf(stderr,
			"swell-ctl: --device %s and --host %s: the telemetry would go to the device link's own "
			"port\n",
			o->device, o->host);
		exit(2);
	}
	if (!strncmp(o->device, "usb:", 4) && !strcmp(o->device, o->host)) {
		fprintf(stderr, "swell-ctl: --device and --host are one FunctionFS mount (%s): give each its own\n",
			o->device);
		exit(2);
	}
}

/* ---- scene files (start-up only, before the loop: parsing uses double, the loop never does) ---- */

/* The scene's start-up parameters (pool and solver rate) into the configuration. */
static void scene_start(struct opts *o, const char *path)
{
	const struct swell_scene_value *v;
	char err[300];

	if (swell_scene_load(path, &o->scene, err, sizeof(err)) < 0) {
		fprintf(stderr, "swell-ctl: --scene %s\n", err);
		exit(2);
	}
	o->scene_path = path;
	if ((v = swell_scene_get(&o->scene, SWELL_SCENE_NX)))
		o->cfg.nx = (uint16_t)v->raw;
	if ((v = swell_scene_get(&o->scene, SWELL_SCENE_NY)))
		o->cfg.ny = (uint16_t)v->raw;
	if ((v = swell_scene_get(&o->scene, SWELL_SCENE_DX_UM)))
		o->cfg.dx_um = (uint32_t)v->raw;
	if ((v = swell_scene_get(&o->scene, SWELL_SCENE_DEPTH_UM)))
		o->cfg.depth_um = (uint32_t)v->raw;
	if ((v = swell_scene_get(&o->scene, SWELL_SCENE_SOLVER_HZ)))
		o->cfg.solver_hz = (uint32_t)v->raw;
}

/* e from eq. 2 when the scene sets the pool or the rate and not e itself (then by its PARAM_SET). */
static void scene_e(struct opts *o)
{
	const struct swell_scene *sc = &o->scene;
	enum swell_err e;

	if (swell_scene_get(sc, SWELL_PARAM_WAVE_E) ||
	    !(swell_scene_get(sc, SWELL_SCENE_DX_UM) || swell_scene_get(sc, SWELL_SCENE_DEPTH_UM) ||
	      swell_scene_get(sc, SWELL_SCENE_SOLVER_HZ)))
		return;
	if (o->cfg.solver_hz == 0 || 1000000u % o->cfg.solver_hz != 0) {
		fprintf(stderr,
			"swell-ctl: --scene %s: solver rate %u Hz is not a whole number of us a step: give "
			"wave.e\n",
			o->scene_path, o->cfg.solver_hz);
		exit(2);
	}
	e = swell_wave_e_from_physical(o->cfg.body.g_mm_s2, 1000000u / o->cfg.solver_hz, o->cfg.depth_um, o->cfg.dx_um,
				       &o->cfg.wave.e);
	if (e != SWELL_OK) {
		fprintf(stderr, "swell-ctl: --scene %s: e = g dt^2 d / dx^2 from the pool: %s\n", o->scene_path,
			swell_err_str(e));
		exit(2);
	}
}

/* The scene's parameters through the core's own validated path (PARAM_SET on the host link, before
 * the link exists): the first refusal stops the start with its line. */
static int scene_params(struct swell_ctl *c, const struct opts *o)
{
	size_t k;

	for (k = 0; k < o->scene.n; k++) {
		const struct swell_scene_value *v = &o->scene.v[k];
		struct swell_msg m, a;

		if (swell_scene_key(v->d->id))
			continue; /* start-up: already in the configuration */
		memset(&m, 0, sizeof(m));
		memset(&a, 0, sizeof(a));
		m.type = SWELL_MSG_PARAM_SET;
		m.node = o->cfg.node;
		m.u.param_set.id = v->d->id;
		m.u.param_set.value = v->raw;
		m.u.param_set.seq = (uint8_t)k;
		swell_ctl_rx(c, SWELL_LINK_HOST, &m);
		if (swell_ctl_tx(c, SWELL_LINK_HOST, &a, 1) != 1 || a.type != SWELL_MSG_PARAM_ACK) {
			fprintf(stderr, "swell-ctl: --scene %s:%d: %s refused: %s\n", o->scene_path, v->line,
				v->d->name,
				a.type == SWELL_MSG_PARAM_NACK ? swell_err_str((enum swell_err)a.u.param_nack.err)
							       : "no answer");
			return -1;
		}
	}
	return 0;
}

static void parse(int argc, char **argv, struct opts *o)
{
	int k;

	memset(o, 0, sizeof(*o));
	o->device = "udp";
	o->host = "udp";
	o->rt = 1;
	swell_ctl_default_config(&o->cfg);
	if (parse_version(SWELL_CTL_FW_VERSION, o->cfg.fw_version))
		die("build version is not X.Y.Z: ", SWELL_CTL_FW_VERSION);
	for (k = 1; k < argc; k++) {
		const char *a = argv[k], *v = k + 1 < argc ? argv[k + 1] : NULL;

		if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
			fputs(usage, stdout);
			exit(0);
		} else if (!strcmp(a, "--autorun")) {
			o->cfg.autorun = 1;
		} else if (!strcmp(a, "--no-rt")) {
			o->rt = 0;
		} else if (!strcmp(a, "--quiet")) {
			o->quiet = 1;
		} else if (strncmp(a, "--", 2)) {
			die("unexpected argument (see --help): ", a);
		} else if (!takes_value(a)) {
			die("unknown option (see --help): ", a);
		} else if (!v) {
			die("this option needs a value: ", a);
		} else {
			k++;
			if (!strcmp(a, "--device"))
				o->device = v;
			else if (!strcmp(a, "--host"))
				o->host = v;
			else if (!strcmp(a, "--scene"))
				scene_start(o, v);
			else if (!strcmp(a, "--clock")) {
				if (strcmp(v, "internal") && strcmp(v, "device"))
					die("--clock must be internal or device, not ", v);
				o->device_clock = !strcmp(v, "device");
			} else if (!strcmp(a, "--tick-hz"))
				o->cfg.tick_hz = (uint32_t)num(a, v, 10, 100000);
			else if (!strcmp(a, "--solver-hz"))
				o->cfg.solver_hz = (uint32_t)num(a, v, 1, 100000);
			else if (!strcmp(a, "--silent-ticks")) {
				o->cfg.silent_ticks = (uint16_t)num(a, v, 1, 10000);
				o->silent_given = 1;
			} else if (!strcmp(a, "--host-budget"))
				o->cfg.host_budget = (uint16_t)num(a, v, 1, SWELL_CTL_QUEUE / 2);
			else if (!strcmp(a, "--node"))
				o->cfg.node = (uint8_t)num(a, v, 0, SWELL_NODE_MAX);
			else if (!strcmp(a, "--fw-version")) {
				if (parse_version(v, o->cfg.fw_version))
					die("--fw-version must be X.Y.Z with each part 0..255, not ", v);
			} else if (!strcmp(a, "--seconds")) {
				char *end;
				o->seconds = strtod(v, &end);
				if (*end || !(o->seconds > 0 && o->seconds < 1e7))
					die("--seconds must be a positive number, not ", v);
			} else
				die("unknown option ", a);
		}
	}
	check_links(o);
	/* the HapticMaster's TCP link sends its request when the tick's FORCE_CMD comes: one every tick */
	o->cfg.cmd_every_tick = !strncmp(o->device, "hm:", 3);
	o->cfg.recover_ticks = (uint16_t)(o->cfg.tick_hz / 10 > 0 ? o->cfg.tick_hz / 10 : 1);
	if (o->scene_path)
		scene_e(o);
	{
		enum swell_err e = swell_ctl_check(&o->cfg);

		if (e != SWELL_OK) {
			fprintf(stderr, "swell-ctl: configuration refused: %s (tick %u Hz, solver %u Hz)\n",
				swell_err_str(e), o->cfg.tick_hz, o->cfg.solver_hz);
			exit(2);
		}
	}
}

/* ---- timing statistics: lateness of each wake-up against its deadline ---- */

#define HIST_US 20000 /* 1 us bins up to 20 ms; later goes in the last bin */

struct jitter {
	uint32_t hist[HIST_US + 1];
	uint64_t n;
	int64_t max_ns;
};

static void jitter_add(struct jitter *j, int64_t late_ns)
{
	int64_t us = late_ns < 0 ? 0 : late_ns / 1000;

	j->hist[us > HIST_US ? HIST_US : us]++;
	j->n++;
	if (late_ns > j->max_ns)
		j->max_ns = late_ns;
}

static double jitter_pct(const struct jitter *j, double p)
{
	uint64_t want = (uint64_t)ceil(p * (double)j->n), seen = 0;
	int k;

	for (k = 0; k <= HIST_US; k++) {
		seen += j->hist[k];
		if (seen >= want && want > 0)
			return k;
	}
	return 0;
}

static int64_t ns_of(const struct timespec *t)
{
	return (int64_t)t->tv_sec * 1000000000 + t->tv_nsec;
}

static struct timespec ts_of(int64_t ns)
{
	struct timespec t = { (time_t)(ns / 1000000000), (long)(ns % 1000000000) };

	return t;
}

static int64_t now_ns(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return ns_of(&t);
}

/* ---- the loop ---- */

struct port {
	struct swell_ctl c;
	struct ctl_link dev, host;
	int have_host;
	uint32_t bad_seen;
	uint32_t bus_offs_seen[2], restarts_seen[2]; /* CAN: device, host link */
	uint32_t starved; /* times nothing reached the device for silent_ticks ticks in a row */
	int starving; /* the present run of unsent ticks has been reported */
	uint32_t releases; /* times the device was declared lost and a learned UDP device let go */
};

static uint32_t rejected(const struct port *p)
{
	return swell_proto_rejected_total(&p->dev.st) + (p->have_host ? swell_proto_rejected_total(&p->host.st) : 0);
}

/* Take everything waiting on both links into the core; returns 0 if no DEVICE_POS came in, else the
 * device ticks they stand for: 1, or in effect mode the sum of their seq steps (the device reports once
 * an update there; two samples in one take, the first late, stand for both periods), at most the
 * silence limit. */
static uint32_t take_input(struct port *p)
{
	struct swell_msg m[SWELL_PKT_MSGS_MAX + 1];
	size_t n, k;
	int pos = 0, rounds;
	uint32_t bad, steps = 0;

	/* Bounded, a flood cannot hold the tick; deep enough that a flood of datagrams from other senders,
	 * each dropped unread (no CRC), does not hide the device's samples behind it: 256 reads a tick
	 * drain 640 000 datagrams a second at 2500 Hz. */
	for (rounds = 0; rounds < 256; rounds++) {
		n = ctl_link_recv(&p->dev, m, sizeof(m) / sizeof(m[0]));
		if (n == 0 && p->dev.frames_rx == 0)
			break;
		for (k = 0; k < n; k++) {
			swell_ctl_rx(&p->c, SWELL_LINK_DEVICE, &m[k]);
			if (m[k].type == SWELL_MSG_DEVICE_POS) {
				pos = 1;
				steps += p->c.dev_step;
			}
		}
		if (n == 0) {
			struct pollfd pf = { ctl_link_fd(&p->dev), POLLIN, 0 };
			if (pf.fd < 0 || poll(&pf, 1, 0) <= 0)
				break;
		}
	}
	/* Read first, poll only when nothing came: on USB the fd is the AIO eventfd, and a write's reap
	 * (telemetry, flush_output) can take the event of a finished OUT transfer, whose packet would
	 * then wait for the next transfer to finish. ctl_link_recv never blocks. */
	for (rounds = 0; p->have_host && rounds < 16; rounds++) {
		n = ctl_link_recv(&p->host, m, sizeof(m) / sizeof(m[0]));
		for (k = 0; k < n; k++)
			swell_ctl_rx(&p->c, SWELL_LINK_HOST, &m[k]);
		if (n == 0) {
			struct pollfd pf = { ctl_link_fd(&p->host), POLLIN, 0 };

			if (pf.fd < 0 || poll(&pf, 1, 0) <= 0)
				break;
		}
	}
	bad = rejected(p);
	if (bad != p->bad_seen) {
		swell_ctl_bad_frames(&p->c, bad - p->bad_seen);
		p->bad_seen = bad;
	}
	if (!pos)
		return 0;
	if (p->c.cfg.force_mode != SWELL_FORCE_EFFECT || steps == 0 || steps > swell_ctl_silent_limit(&p->c))
		return 1;
	return steps;
}

static void flush_output(struct port *p);

/* Nothing reached the device (send refused, no destination) for silent_ticks ticks in a row while it
 * was there: it is starved even if it still talks, and the loop faults as for a silent device (zero
 * force, the zero goes out as soon as the carrier takes it). Returns 1 while starved. */
static int device_starved(struct port *p)
{
	if (p->dev.unsent_run < p->c.cfg.silent_ticks) { /* sends: in effect mode one an update */
		p->starving = 0;
		return 0;
	}
	if (p->c.state != SWELL_CTL_ARMED && p->c.state != SWELL_CTL_RUNNING)
		return 0;
	swell_ctl_link_down(&p->c, SWELL_LINK_DEVICE); /* this tick faults: zero force from the safety stage */
	if (!p->starving) {
		p->starving = 1;
		p->starved++;
		fprintf(stderr,
			"swell-ctl: device link %s: no command reached the device for %u ticks: force "
			"zeroed, loop faulted\n",
			p->dev.name, p->dev.unsent_run);
	}
	return 1;
}

static double mono_s(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + t.tv_nsec / 1e9;
}

/* CAN error frames (ctl_link.c keeps the bus state). A bus-off of the device link zeroes the force
 * at once and faults the loop like a silent device; while the bus is off the link drops whatever
 * comes in, and after the restart (restart-ms, a manual restart, down/up) the device is heard again
 * and autorun recovers. Returns 1 when the loop must tick now (to enter the fault). */
static int link_faults(struct port *p)
{
	struct ctl_link *l[2] = { &p->dev, &p->host };
	int k, tick = 0;

	for (k = 0; k < 2; k++) {
		const struct ctl_can_health *h = &l[k]->can;

		if (l[k]->kind != CTL_LINK_CAN || (k == 1 && !p->have_host))
			continue;
		if (h->bus_offs != p->bus_offs_seen[k]) {
			p->bus_offs_seen[k] = h->bus_offs;
			if (k == 0) {
				swell_ctl_zero_force(&p->c);
				swell_ctl_link_down(&p->c, SWELL_LINK_DEVICE);
				flush_output(p);
				tick = 1;
			}
			fprintf(stderr, "swell-ctl: %s link %s: bus-off %u (tx/rx error counters %u/%u)%s at %.6f s\n",
				k ? "host" : "device", l[k]->name, h->bus_offs, h->tx_err, h->rx_err,
				k ? "" : ": force zeroed, loop faulted", mono_s());
		}
		if (h->restarts != p->restarts_seen[k]) {
			p->restarts_seen[k] = h->restarts;
			fprintf(stderr, "swell-ctl: %s link %s: back on the bus (restart %u, %s) at %.6f s\n",
				k ? "host" : "device", l[k]->name, h->restarts, ctl_can_state_name(h->state), mono_s());
		}
	}
	return tick;
}

static void report_can(const char *what, const struct ctl_link *l)
{
	const struct ctl_can_health *h = &l->can;

	if (l->kind != CTL_LINK_CAN)
		return;
	printf("  %s CAN  %s: %s, %u error frames: %u bus-off, %u restarts, %u error-passive, %u warnings, "
	       "%u back to active; %u no-ACK, %u protocol, %u overflows, %u TX timeouts; counters tx %u rx %u; "
	       "%u frames dropped while bus-off, interface down %u times\n",
	       what, l->name, ctl_can_state_name(h->state), h->error_frames, h->bus_offs, h->restarts, h->passives,
	       h->warnings, h->actives, h->no_ack, h->prot, h->overflows, h->tx_timeouts, h->tx_err, h->rx_err,
	       h->dropped_off, h->downs);
}

static void report_usb(const char *what, const struct ctl_link *l)
{
	if (l->kind != CTL_LINK_USB)
		return;
	printf("  %s USB  %s: %u parameter answers held for a busy IN queue, %u dropped; %u IN writes "
	       "refused (all %d slots in flight)\n",
	       what, l->name, l->answers_held, l->answers_dropped, l->usb.tx_busy_drops, SWELL_USB_FFS_TX_SLOTS);
}

static void flush_output(struct port *p)
{
	struct swell_msg m[SWELL_CTL_QUEUE];
	size_t n;

	/* the force first: it is what the device waits for */
	n = swell_ctl_tx(&p->c, SWELL_LINK_DEVICE, m, SWELL_CTL_QUEUE);
	if (n)
		ctl_link_send(&p->dev, m, n);
	n = swell_ctl_tx(&p->c, SWELL_LINK_HOST, m, SWELL_CTL_QUEUE);
	if (n && p->have_host)
		ctl_link_send(&p->host, m, n);
}

/* "ADDR:PORT" of a, "(fixed)" after a configured one, or "none yet". */
static const char *addr_str(const struct sockaddr_in *a, int have, int fixed, char *buf, size_t len)
{
	char ip[INET_ADDRSTRLEN] = "?";

	if (!have)
		return "none yet";
	inet_ntop(AF_INET, &a->sin_addr, ip, sizeof(ip));
	snprintf(buf, len, "%s:%u%s", ip, ntohs(a->sin_port), fixed ? " (fixed)" : "");
	return buf;
}

/* SCHED_FIFO and mlockall where permitted. Without real-time scheduling the tick is late by
 * milliseconds on a loaded machine: unless --silent-ticks says otherwise, the device silence limit
 * becomes SLOW_SILENCE_MS of ticks, and the start line says so. Returns 1 with SCHED_FIFO. */
static int setup_rt(struct opts *o)
{
	struct sched_param sp = { .sched_priority = 80 };
	const char *why = "--no-rt";
	char buf[96];
	uint32_t slow;

	if (o->rt) {
		if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
			fprintf(stderr, "swell-ctl: warning: mlockall: %s; running without locked memory\n",
				strerror(errno));
		if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
			fprintf(stderr,
				"swell-ctl: real-time: SCHED_FIFO priority 80; device silence limit %u ticks "
				"(%.1f ms)\n",
				o->cfg.silent_ticks, o->cfg.silent_ticks * 1e3 / o->cfg.tick_hz);
			return 1;
		}
		snprintf(buf, sizeof(buf), "SCHED_FIFO refused: %s", strerror(errno));
		why = buf;
	}
	slow = o->cfg.tick_hz * SLOW_SILENCE_MS / 1000;
	if (!o->silent_given && slow > o->cfg.silent_ticks) {
		fprintf(stderr,
			"swell-ctl: no real-time scheduling (%s): device silence limit %u ticks (%.1f ms) "
			"instead of %u; --silent-ticks N to choose\n",
			why, slow, slow * 1e3 / o->cfg.tick_hz, o->cfg.silent_ticks);
		o->cfg.silent_ticks = (uint16_t)slow;
	} else {
		fprintf(stderr, "swell-ctl: no real-time scheduling (%s): device silence limit %u ticks (%.1f ms)\n",
			why, o->cfg.silent_ticks, o->cfg.silent_ticks * 1e3 / o->cfg.tick_hz);
	}
	return 0;
}

int main(int argc, char **argv)
{
	static struct port p;
	static struct jitter jit;
	struct opts o;
	struct sigaction sa;
	int32_t *arena;
	size_t words;
	char err[160], abuf[48];
	int rc;
	int64_t period, next, start, last_status;
	int32_t peak_h = 0;
	int64_t last_sample = 0; /* --clock device: when the last DEVICE_POS came */
	uint64_t max_ticks, ticks = 0; /* the core's count is 32 bits: it wraps after 19.9 days at 2500 Hz */
	enum swell_err e;

	parse(argc, argv, &o);
	setup_rt(&o); /* first: it may set the silence limit the core is configured with */
	words = swell_ctl_arena_words(o.cfg.nx, o.cfg.ny);
	arena = calloc(words, sizeof(*arena)); /* the only allocation, before the loop starts */
	if (!arena) {
		fprintf(stderr, "swell-ctl: out of memory\n");
		return 1;
	}
	e = swell_ctl_init(&p.c, &o.cfg, arena, words);
	if (e != SWELL_OK) {
		fprintf(stderr, "swell-ctl: controller refused its configuration: %s\n", swell_err_str(e));
		free(arena);
		return 2;
	}
	if (o.scene_path && scene_params(&p.c, &o) < 0) {
		free(arena);
		return 2;
	}
	rc = ctl_link_open(&p.dev, o.device, 1, o.cfg.node, err, sizeof(err));
	if (rc < 0) {
		fprintf(stderr, "swell-ctl: device link: %s\n", err);
		free(arena);
		return rc == -2 ? 2 : 1; /* a malformed spec is a bad argument */
	}
	if (strcmp(o.host, "none")) {
		rc = ctl_link_open(&p.host, o.host, 0, o.cfg.node, err, sizeof(err));
		if (rc < 0) {
			fprintf(stderr, "swell-ctl: host link: %s\n", err);
			ctl_link_close(&p.dev);
			free(arena);
			return rc == -2 ? 2 : 1;
		}
		p.have_host = 1;
	}
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	fprintf(stderr, "swell-ctl: %ux%u pool, tick %u Hz, solver %u Hz, device %s, host %s, clock %s\n", o.cfg.nx,
		o.cfg.ny, o.cfg.tick_hz, o.cfg.solver_hz, p.dev.name, p.have_host ? p.host.name : "none",
		o.device_clock ? "device" : "internal");
	if (p.have_host && p.host.kind == CTL_LINK_UDP)
		fprintf(stderr, "swell-ctl: host link clients: send to %s (up to %u, kept while they speak)%s\n",
			addr_str(&p.host.local, 1, 0, abuf, sizeof(abuf)), CTL_LINK_CLIENTS,
			p.host.clients_port_taken ? "; the default port 47802 is taken (another controller?): tools "
						    "need --link udp:PORT with this port"
						  : "");

	period = 1000000000 / o.cfg.tick_hz;
	max_ticks = o.seconds > 0 ? (uint64_t)(o.seconds * o.cfg.tick_hz + 0.5) : UINT64_MAX;
	start = next = now_ns();
	last_status = start;
	while (!stop_flag && ticks < max_ticks) {
		uint32_t burst = 1, b;

		if (o.device_clock) {
			/* One tick per device sample, so that a trace replays bit-identically whatever the
			 * machine's load. Nothing ticks before the first sample. Once the device has been
			 * silent for silent_ticks periods of wall time, the loop ticks on its own every period,
			 * so the core sees the silence (and faults silent_ticks ticks later). */
			struct pollfd pf = { ctl_link_fd(&p.dev), POLLIN, 0 };
			const struct timespec one = ts_of(period); /* not poll's whole ms: 2.5 periods at 2500 Hz */
			int r = ppoll(&pf, 1, &one, NULL);

			if (r < 0 && errno == EINTR)
				continue;
			burst = take_input(&p);
			if (burst)
				last_sample = now_ns();
			else if (link_faults(&p))
				burst = 1;
			else if (last_sample == 0 ||
				 now_ns() - last_sample < (int64_t)swell_ctl_silent_limit(&p.c) * period)
				continue;
			else
				burst = 1;
		} else {
			struct timespec dl;
			int64_t late;

			next += period;
			dl = ts_of(next);
			while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &dl, NULL) == EINTR && !stop_flag)
				;
			late = now_ns() - next;
			jitter_add(&jit, late);
			if (late > period) { /* a whole period lost: count it and start again from now */
				swell_ctl_overrun(&p.c);
				next = now_ns();
			}
			take_input(&p);
		}
		/* --clock device in effect mode: a sample every update stands for the device ticks since the
		 * last one (its seq step), and the core ticks that many times on it */
		for (b = 0; b < burst && ticks < max_ticks; b++) {
			link_faults(&p);
			device_starved(&p);
			swell_ctl_tick(&p.c);
			ticks++;
			flush_output(&p);
			/* the device declared lost (its zero force has just gone to it): a learned UDP device is
			 * let go, the next sender of this node's DEVICE_POS becomes the device (the old one still
			 * gets the zero force until then) */
			if (swell_ctl_device_lost(&p.c))
				p.releases += (uint32_t)ctl_link_release_peer(&p.dev);
			if (swell_ctl_bootloader_requested(&p.c)) /* zero force and the last heartbeat are out */
				break;
		}
		if (swell_ctl_bootloader_requested(&p.c))
			break;
		if (now_ns() - last_status > 1000000000) {
			int a;

			last_status = now_ns();
			/* once a second, outside the force path: the largest wave so far */
			for (a = 0; a < (int)o.cfg.nx * o.cfg.ny; a++) {
				int32_t h = p.c.wave.h[a] < 0 ? -p.c.wave.h[a] : p.c.wave.h[a];
				peak_h = h > peak_h ? h : peak_h;
			}
			if (!o.quiet)
				fprintf(stderr, "\rswell-ctl: %-7s tick %u, solver %u, force %+.2f N, overruns %u   ",
					swell_ctl_state_name(p.c.state), p.c.n.ticks, p.c.n.solver_steps,
					p.c.force_dev_uN[2] / 1e6, p.c.n.overruns);
		}
	}
	/* zero force first, then everything else. It is the last force the device gets: a full transmit
	 * queue (CAN TX queue, USB IN slots) must not drop it as it may drop a tick's, so it is tried
	 * again for up to 100 ms. */
	swell_ctl_zero_force(&p.c);
	{
		struct swell_msg m[SWELL_CTL_QUEUE];
		size_t n = swell_ctl_tx(&p.c, SWELL_LINK_DEVICE, m, SWELL_CTL_QUEUE);

		if (n && ctl_link_send_wait(&p.dev, m, n, 100) != 0)
			fprintf(stderr, "swell-ctl: warning: device link %s refused the zero force for 100 ms\n",
				p.dev.name);
	}
	flush_output(&p);
	if (!o.quiet)
		fputc('\n', stderr);
	if (swell_ctl_bootloader_requested(&p.c))
		fprintf(stderr,
			"swell-ctl: enter-bootloader accepted in state %s: force zeroed, last heartbeat "
			"sent; exiting with status 3 (no ROM bootloader on Linux: the supervisor flashes "
			"and starts the new image)\n",
			swell_ctl_state_name(p.c.state));

	printf("swell-ctl report\n");
	printf("  firmware        %u.%u.%u\n", o.cfg.fw_version[0], o.cfg.fw_version[1], o.cfg.fw_version[2]);
	printf("  ran             %.3f s, %llu ticks at %u Hz, %u solver steps at %u Hz\n", (now_ns() - start) / 1e9,
	       (unsigned long long)ticks, o.cfg.tick_hz, p.c.n.solver_steps, o.cfg.solver_hz);
	printf("  state           %s (last error: %s), faults %u\n", swell_ctl_state_name(p.c.state),
	       swell_err_str(p.c.last_err), p.c.n.faults);
	if (p.c.n.faults)
		printf("  FAULTED         %u times in this run (zero force while faulted; last error: %s; device "
		       "silence limit %u ticks = %.1f ms)\n",
		       p.c.n.faults, swell_err_str(p.c.last_err), swell_ctl_silent_limit(&p.c),
		       swell_ctl_silent_limit(&p.c) * 1e3 / o.cfg.tick_hz);
	if (!o.device_clock)
		printf("  tick jitter     p50 %.0f us, p99 %.0f us, max %.0f us (lateness of the wake-up)\n",
		       jitter_pct(&jit, 0.5), jitter_pct(&jit, 0.99), jit.max_ns / 1e3);
	printf("  overruns        %u\n", p.c.n.overruns);
	printf("  work            worst tick %u cell-operations (a whole step: %u)\n", p.c.n.work_max,
	       6u * o.cfg.nx * o.cfg.ny);
	printf("  device link     %s: %u frames in, %u out, %u bad, %u send errors, %u samples lost, %u resyncs, %u "
	       "of other nodes\n",
	       p.dev.name, p.dev.frames_rx, p.dev.frames_tx, swell_proto_rejected_total(&p.dev.st), p.dev.tx_errors,
	       p.c.n.dev_lost, p.c.dev_seq.resyncs, p.dev.foreign);
	if (p.dev.kind == CTL_LINK_UDP)
		printf("  device peer     %s; %u datagrams of other senders dropped; device taken %u times, "
		       "let go %u times (declared lost)\n",
		       addr_str(&p.dev.peer, p.dev.have_peer, p.dev.peer_fixed, abuf, sizeof(abuf)), p.dev.others,
		       p.dev.peers_taken, p.releases);
	printf("  device starved  %u times (nothing reached the device in %u sends in a row)\n", p.starved,
	       o.cfg.silent_ticks);
	if (p.have_host)
		printf("  host link       %s: %u frames in, %u out, %u bad, %u not sent (no reader or busy); "
		       "%u height quads (%u refreshes), %u dropped from the queue\n",
		       p.host.name, p.host.frames_rx, p.host.frames_tx, swell_proto_rejected_total(&p.host.st),
		       p.host.tx_errors, p.c.n.quads_sent, p.c.n.quads_refreshed, p.c.q[SWELL_LINK_HOST].dropped);
	if (p.have_host && p.host.kind == CTL_LINK_UDP)
		printf("  host clients    on %s: %u admitted, %u dropped after %u ms of silence, %u now (at most %u); "
		       "%u packets of senders refused (table full)\n",
		       addr_str(&p.host.local, 1, 0, abuf, sizeof(abuf)), p.host.clients_admitted,
		       p.host.clients_silent, CTL_LINK_CLIENT_SILENT_MS, ctl_link_clients(&p.host), CTL_LINK_CLIENTS,
		       p.host.clients_refused);
	if (p.dev.kind == CTL_LINK_HM)
		hm_client_report(&p.dev.hm, stdout);
	report_can("device", &p.dev);
	report_usb("device", &p.dev);
	if (p.have_host) {
		report_can("host  ", &p.host);
		report_usb("host  ", &p.host);
	}
	printf("  parameters      %u set, %u refused\n", p.c.n.params_set, p.c.n.params_refused);
	printf("  waves           largest |h| %.3f mm (sampled once a second), %u solver saturations "
	       "(row segments clamped)\n",
	       peak_h / (double)SWELL_H_ONE_MM, p.c.wave.saturations);
	printf("  final force     %+.3f N (zero sent on exit)\n", p.c.force_dev_uN[2] / 1e6);
	ctl_link_close(&p.dev);
	if (p.have_host)
		ctl_link_close(&p.host);
	free(arena);
	return swell_ctl_bootloader_requested(&p.c) ? 3 : 0;
}
