/* swell-hm's command line; see hm_main.h. */
#include <arpa/inet.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hm_main.h"
#include "hm_serve.h"
#include "swell/cli.h"
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

/* Object and pool from a scene file: the defaults of the reference scene where it says nothing. */
static void scene_object(struct opts *o, const char *path)
{
	struct swell_scene sc;
	const struct swell_scene_value *v;
	double dx = SWELL_POOL_DX_UM / 1000.0, nx = SWELL_POOL_N, ny = SWELL_POOL_N;
	char err[300];
	int k;

	if (swell_scene_load(path, &sc, err, sizeof(err)) < 0)
		swell_cli_die("swell-hm", "--scene %s", err);
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
			swell_cli_die("swell-hm", "--scene %s: frame.axes is not three different device axes 1..3",
				      path);
		for (k = 0; k < 3; k++)
			o->frame_axis[k] = a[k];
	}
	if ((v = swell_scene_get(&sc, SWELL_PARAM_FRAME_FLIP)))
		for (k = 0; k < 3; k++)
			o->frame_sign[k] = (v->raw >> k & 1) ? -1 : 1;
	o->pool_mm[0] = nx * dx;
	o->pool_mm[1] = ny * dx;
}

/* The options that need their own code: o is c->ctx. */
static int link_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	char why[160];

	if (swell_link_spec_parse(v, SWELL_LINK_ACCEPT_HOST_SIDE, (uint16_t)o->port, &o->ls, why, sizeof(why)))
		return swell_cli_refuse(c, "%s %s", opt, why);
	o->link = v;
	o->port = o->ls.port;
	return 0;
}

/* --serve [ADDR:]PORT, the value optional */
static int serve_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct sockaddr_in sa;
	char why[160];

	if (v && hm_serve_parse(v, &sa, why, sizeof(why)) < 0)
		return swell_cli_refuse(c, "%s: %s", opt, why);
	((struct opts *)c->ctx)->serve = v ? v : "127.0.0.1:7654";
	return 0;
}

static int inject_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	struct inject j = { 0 };
	char kind[16];
	int used = 0;

	if (o->n_inj >= 8)
		return swell_cli_refuse(c, "%s: at most 8 injections", opt);
	j.at_s = -1;
	if (sscanf(v, "delay:at=%lf,for=%lf,ms=%lf%n", &j.at_s, &j.for_s, &j.ms, &used) == 3 && !v[used] &&
	    j.for_s > 0 && j.ms > 0 && j.ms <= 10000)
		j.kind = 'd';
	else if (sscanf(v, "%15[a-z]:at=%lf%n", kind, &j.at_s, &used) == 2 && !v[used] &&
		 (!strcmp(kind, "garbage") || !strcmp(kind, "reset") || !strcmp(kind, "stop")))
		j.kind = kind[0];
	if (!j.kind || !(j.at_s >= 0))
		return swell_cli_refuse(
			c,
			"%s '%s' is not delay:at=S,for=S,ms=N (0 < N <= 10000), garbage:at=S, reset:at=S "
			"or stop:at=S",
			opt, v);
	o->inj[o->n_inj++] = j;
	return 0;
}

/* --limit: the same half-range on every axis, in metres */
static int limit_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	double mm;

	if (swell_cli_number(c, opt, v, 1, 300, "mm", &mm) < 0)
		return -1;
	o->p.limit_m[0] = o->p.limit_m[1] = o->p.limit_m[2] = mm * 1e-3;
	return 0;
}

static int start_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;

	if (swell_cli_numbers(c, opt, v, 3, 3, -300, 300, "mm", o->start_mm) < 0)
		return -1;
	o->have_start = 1;
	return 0;
}

static int estop_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	double ab[2];

	if (swell_cli_numbers(c, opt, v, 2, 2, 0, 1e6, "s", ab) < 0)
		return -1;
	if (ab[1] <= ab[0])
		return swell_cli_refuse(c, "%s A,B needs A < B, not '%s'", opt, v);
	memcpy(o->estop_s, ab, sizeof(ab));
	return 0;
}

static int hand_opt(struct swell_cli *c, const char *opt, const char *v)
{
	char why[160];

	if (hm_hand_parse(v, &((struct opts *)c->ctx)->hand, why, sizeof(why)) != SWELL_OK)
		return swell_cli_refuse(c, "%s: %s", opt, why);
	return 0;
}

static int object_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	double ob[3];

	if (swell_cli_numbers(c, opt, v, 3, 3, 1e-3, 1e6, "g, mm, mm", ob) < 0)
		return -1;
	o->obj_mass_g = ob[0];
	o->obj_a_mm = ob[1];
	o->obj_b_mm = ob[2];
	return 0;
}

static int scene_opt(struct swell_cli *c, const char *opt, const char *v)
{
	(void)opt;
	scene_object(c->ctx, v);
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
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_FLAG("--lockstep", o->lockstep),
		SWELL_CLI_FLAG("--quiet", o->quiet),
		SWELL_CLI_FLAG("--uncalibrated", o->uncalibrated),
		SWELL_CLI_FLAG("--rt", o->rt),
		SWELL_CLI_HOOK("--serve", serve_opt, 2),
		SWELL_CLI_HOOK("--link", link_opt, 1),
		SWELL_CLI_IPV4("--host", o->host),
		SWELL_CLI_WHOLE("--port", o->port, 1, 65535, ""),
		SWELL_CLI_HOOK("--inject", inject_opt, 1),
		SWELL_CLI_NUM("--effect-fresh", o->effect_fresh_ms, 0.1, 1000, "ms"),
		SWELL_CLI_NUM("--link-delay", o->link_delay_ms, 0, 1000, "ms"),
		SWELL_CLI_WHOLE("--sample-every", o->sample_every, 1, 255, "ticks"),
		SWELL_CLI_WHOLE("--bias-watchdog", o->bias_watchdog_ms, 0, 60000, "ms"),
		SWELL_CLI_WHOLE("--bind-port", o->bind_port, 0, 65535, ""),
		SWELL_CLI_WHOLE("--node", o->node, 0, SWELL_NODE_MAX, ""),
		SWELL_CLI_WHOLE("--iface", o->iface, 0, 255, ""),
		SWELL_CLI_NUM("--rate", o->p.rate_hz, 100, 100000, "Hz"),
		SWELL_CLI_WHOLE("--timeout-ms", o->timeout_ms, 1, 10000, "ms"),
		SWELL_CLI_NUM("--seconds", o->seconds, 1e-3, 1e6, "s"),
		SWELL_CLI_NUM("--mass", o->p.mass_kg, 0.01, 1000, "kg"),
		SWELL_CLI_NUM("--damping", o->p.damping_Ns_m, 0, 10000, "N s/m"),
		SWELL_CLI_HOOK("--limit", limit_opt, 1),
		SWELL_CLI_NUM("--fmax", o->p.f_max_N, 1e-3, 250, "N"),
		SWELL_CLI_WHOLE("--watchdog", o->p.watchdog_ticks, 1, 100000, "ticks"),
		SWELL_CLI_HOOK("--start", start_opt, 1),
		SWELL_CLI_HOOK("--estop", estop_opt, 1),
		SWELL_CLI_HOOK("--hand", hand_opt, 1),
		SWELL_CLI_HOOK("--object", object_opt, 1),
		SWELL_CLI_LIST("--pool", o->pool_mm, 2, 1, 1e5, "mm"),
		SWELL_CLI_HOOK("--scene", scene_opt, 1),
		SWELL_CLI_STR("--log", o->log),
	};
	struct swell_cli cli = {
		.prog = "swell-hm", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts), .ctx = o
	};
	const uint32_t watchdog0 = o->p.watchdog_ticks;

	o->p.watchdog_ticks = 0; /* not given: --watchdog takes 1 and up */
	swell_cli_parse(&cli, argc, argv);
	o->watchdog_given = o->p.watchdog_ticks != 0;
	if (!o->watchdog_given)
		o->p.watchdog_ticks = watchdog0;
	if (o->pool_mm[0] <= o->obj_a_mm || o->pool_mm[1] <= o->obj_b_mm)
		swell_cli_die("swell-hm", "--pool %g,%g mm is not larger than the object's footprint %g x %g mm",
			      o->pool_mm[0], o->pool_mm[1], o->obj_a_mm, o->obj_b_mm);
	e = hm_params_check(&o->p, o->hand.k_N_m, o->hand.b_Ns_m, why, sizeof(why));
	if (e != SWELL_OK)
		swell_cli_die("swell-hm", "device parameters refused (%s): %s", swell_err_str(e), why);
	if (o->have_start)
		for (k = 0; k < 3; k++)
			if (fabs(o->start_mm[k]) > o->p.limit_m[k] * 1e3)
				swell_cli_die("swell-hm", "--start %.3f mm is outside the workspace (+-%.3f mm)",
					      o->start_mm[k], o->p.limit_m[k] * 1e3);
}
