/* swell-hm's command line; see hm_main.h. */
#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hm_main.h"
#include "hm_serve.h"
#include "swell/link.h"
#include "swell/pool.h"
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
	"  --bias-watchdog MS  --serve: a client silent this long loses its bias forces, and the springs and\n"
	"                      dampers it set are disabled (default 100; 0: off)\n"
	"  --inject SPEC       --serve fault injection (repeatable, up to 8): delay:at=S,for=S,ms=N (replies\n"
	"                      held N ms), garbage:at=S (16 unframed bytes to every client), reset:at=S\n"
	"                      (every connection reset), stop:at=S (the device put in stop, as by a client)\n"
	"  --uncalibrated      --serve fault injection: 'set state init' leaves the device uncalibrated\n"
	"                      (position_calibrated and force_calibrated stay false)\n"
	"Device model (m_v a = F_user + F_cmd - b_v v, per axis; see docs/hm.md):\n"
	"  --mass KG           virtual mass m_v (default 2)\n"
	"  --damping NS_M      virtual damping b_v in N s/m (default 2)\n"
	"  --limit MM          workspace half-range per axis (default 200; a stiff wall beyond)\n"
	"  --fmax N            largest commanded force applied per axis (default 250)\n"
	"  --effect-fresh MS   effect mode (EFFECT_* messages): a set is rendered for at most this long\n"
	"                      after it came (default 10; the controller sends one every solver step)\n"
	"  --sample-every N    while effect sets come, DEVICE_POS and DEVICE_VEL every N ticks (the\n"
	"                      controller's ticks per update, 10 at 2500/250 Hz, keeps classic CAN light;\n"
	"                      default: every tick in real time; in lockstep the sets' spacing once three\n"
	"                      in a row agree, a fallback for a loop without timeouts); their seq counts\n"
	"                      device ticks either way\n"
	"  --link-delay MS     act on what comes from the controller MS later (rounded to whole device\n"
	"                      ticks, 0 to 1000; default 0): extra latency on the device link\n"
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
	double dx = SWELL_POOL_DX_UM / 1000.0, nx = SWELL_POOL_N, ny = SWELL_POOL_N;
	char err[300];
	int k;

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
	/* the frame, as the controller takes it from the same file */
	for (k = 0; k < 3; k++)
		if ((v = swell_scene_get(&sc, (uint16_t)(SWELL_PARAM_FRAME_X0 + k))))
			o->frame_off_mm[k] = v->raw / 1000.0;
	if ((v = swell_scene_get(&sc, SWELL_PARAM_FRAME_SCALE)))
		o->frame_scale = v->raw / 65536.0;
	if ((v = swell_scene_get(&sc, SWELL_PARAM_FRAME_AXES))) {
		const int a[3] = { v->raw / 100 - 1, v->raw / 10 % 10 - 1, v->raw % 10 - 1 };

		if (a[0] < 0 || a[0] > 2 || a[1] < 0 || a[1] > 2 || a[2] < 0 || a[2] > 2 || a[0] == a[1] ||
		    a[0] == a[2] || a[1] == a[2])
			die("--scene %s: frame.axes is not three different device axes 1..3%s", path, "");
		for (k = 0; k < 3; k++)
			o->frame_axis[k] = a[k];
	}
	if ((v = swell_scene_get(&sc, SWELL_PARAM_FRAME_FLIP)))
		for (k = 0; k < 3; k++)
			o->frame_sign[k] = (v->raw >> k & 1) ? -1 : 1;
	o->pool_mm[0] = nx * dx;
	o->pool_mm[1] = ny * dx;
}

/* 1 for an option of this program that takes a value. */
static int takes_value(const char *a)
{
	static const char *const with_value[] = { "--bias-watchdog", "--bind-port",  "--damping",     "--effect-fresh",
						  "--estop",         "--fmax",       "--hand",        "--host",
						  "--iface",         "--inject",     "--limit",       "--link",
						  "--log",           "--mass",       "--node",        "--object",
						  "--pool",          "--port",       "--rate",        "--scene",
						  "--seconds",       "--serve",      "--start",       "--timeout-ms",
						  "--watchdog",      "--link-delay", "--sample-every" };
	size_t k;

	for (k = 0; k < sizeof(with_value) / sizeof(with_value[0]); k++)
		if (!strcmp(a, with_value[k]))
			return 1;
	return 0;
}

void parse(int argc, char **argv, struct opts *o)
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
	o->obj_a_mm = o->obj_b_mm = o->obj_h_mm = SWELL_POOL_BOX_UM / 1000.0;
	o->depth_mm = SWELL_POOL_DEPTH_UM / 1000.0;
	o->pool_mm[0] = o->pool_mm[1] = SWELL_POOL_SIDE_UM / 1000.0;
	o->estop_s[0] = o->estop_s[1] = -1.0;
	hm_params_default(&o->p);
	hm_hand_parse("idle", &o->hand, NULL, 0);
	o->frame_off_mm[0] = SWELL_PARAM_DEF_FRAME_X0 / 1000.0;
	o->frame_off_mm[1] = SWELL_PARAM_DEF_FRAME_Y0 / 1000.0;
	o->frame_off_mm[2] = SWELL_PARAM_DEF_FRAME_Z0 / 1000.0;
	o->frame_scale = SWELL_PARAM_DEF_FRAME_SCALE / 65536.0;
	for (k = 0; k < 3; k++) {
		o->frame_axis[k] = k;
		o->frame_sign[k] = 1;
	}
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
		} else if (!strcmp(a, "--uncalibrated")) {
			o->uncalibrated = 1;
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
		else if (!strcmp(a, "--link-delay"))
			o->link_delay_ms = number(a, v, 0, 1000, "ms");
		else if (!strcmp(a, "--sample-every"))
			o->sample_every = whole(a, v, 1, 255, "ticks");
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
