/* swell-ctl's command line and scene file; see ctl_main.h. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ctl_main.h"
#include "swell/cli.h"
#include "swell/pool.h"

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
	"                      is late by milliseconds); in effect mode at least two update periods\n"
	"  --autorun           run whenever the device is there; leave a link-loss fault by itself\n"
	"  --full-force        hm: keep the force limits of the scene (or the built-in ones) from the start;\n"
	"                      without it a HapticMaster starts with the first-run limits force.max 2 N and\n"
	"                      force.rate 20 N/s (lower ones are kept), which only a PARAM_SET raises\n"
	"                      (swell-tool set force.max 10N): docs/first-contact.md\n"
	"  --host-budget N     host messages a tick (default 16)\n"
	"  --node N            node id on the bus, 0..15 (default 0)\n"
	"  --scene FILE        start with a scene file (*.scene: pool size, cell size, depth, solver rate,\n"
	"                      object, damping, force limits; docs/tool.md); options after it override\n"
	"                      its pool and rates, its parameters override the options; a bad line or a\n"
	"                      refused value: exit 2 naming the line\n"
	"  --pool-max N        the arena holds an N x N pool (default 256, and at least the pool started\n"
	"                      with): outside RUNNING, PARAM_SETs of pool.nx, pool.ny, pool.dx and\n"
	"                      pool.depth on the host link restart the core with that pool (swell-tool\n"
	"                      scene load), the water at rest; a pool that does not fit is refused\n"
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

/* A bad argument: one line on stderr, exit 2. */
#define die(...) swell_cli_die("swell-ctl", __VA_ARGS__)

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

/* The two links must not be one: the host link's telemetry sent into the device port, or one
 * FunctionFS mount for both. Compared as spelled (udp: the port, the default 47800 / 47801). */
static void check_links(const struct opts *o)
{
	const char *dp = !strcmp(o->device, "udp") ? "47800" : !strncmp(o->device, "udp:", 4) ? o->device + 4 : NULL;
	const char *hp = !strcmp(o->host, "udp") ? "47801" : !strncmp(o->host, "udp:", 4) ? o->host + 4 : NULL;

	if (dp && hp && strtol(dp, NULL, 10) == strtol(hp, NULL, 10) && strtol(dp, NULL, 10) > 0)
		die("--device %s and --host %s: the telemetry would go to the device link's own port", o->device,
		    o->host);
	if (!strncmp(o->device, "usb:", 4) && !strcmp(o->device, o->host))
		die("--device and --host are one FunctionFS mount (%s): give each its own", o->device);
}

/* ---- scene files (start-up only, before the loop: parsing uses double, the loop never does) ---- */

/* The scene's start-up parameters (pool and solver rate) into the configuration. */
static void scene_start(struct opts *o, const char *path)
{
	const struct swell_scene_value *v;
	char err[300];

	if (swell_scene_load(path, &o->scene, err, sizeof(err)) < 0)
		die("--scene %s", err);
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
	if (o->cfg.solver_hz == 0 || 1000000u % o->cfg.solver_hz != 0)
		die("--scene %s: solver rate %u Hz is not a whole number of us a step: give wave.e", o->scene_path,
		    o->cfg.solver_hz);
	e = swell_wave_e_from_physical(o->cfg.body.g_mm_s2, 1000000u / o->cfg.solver_hz, o->cfg.depth_um, o->cfg.dx_um,
				       &o->cfg.wave.e);
	if (e != SWELL_OK)
		die("--scene %s: e = g dt^2 d / dx^2 from the pool: %s", o->scene_path, swell_err_str(e));
}

/* The scene's parameters through the core's own validated path (PARAM_SET on the host link, before
 * the link exists): the first refusal stops the start with its line. */
int scene_params(struct swell_ctl *c, const struct opts *o)
{
	size_t k;

	for (k = 0; k < o->scene.n; k++) {
		const struct swell_scene_value *v = &o->scene.v[k];
		const struct swell_msg m = swell_param_request(o->cfg.node, 1, v->d->id, v->raw, (uint8_t)k);
		struct swell_msg a;

		if (swell_scene_key(v->d->id))
			continue; /* start-up: already in the configuration */
		memset(&a, 0, sizeof(a));
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

/* One parameter through the core's own path: get (set 0) or set; 0 with *v the value in force. */
static int core_param(struct swell_ctl *c, const struct opts *o, int set, uint16_t id, int32_t *v)
{
	const struct swell_msg m = swell_param_request(o->cfg.node, set, id, *v, 0);
	struct swell_msg a;

	memset(&a, 0, sizeof(a));
	swell_ctl_rx(c, SWELL_LINK_HOST, &m);
	if (swell_ctl_tx(c, SWELL_LINK_HOST, &a, 1) != 1 || a.type != SWELL_MSG_PARAM_ACK)
		return -1;
	*v = a.u.param_ack.value;
	return 0;
}

int first_run_limits(struct swell_ctl *c, const struct opts *o)
{
	static const struct {
		uint16_t id;
		int32_t first;
	} lim[] = { { SWELL_PARAM_FORCE_MAX_UN, CTL_FIRST_FORCE_MAX_UN },
		    { SWELL_PARAM_FORCE_RATE, CTL_FIRST_FORCE_RATE } };
	int32_t v[2];
	size_t k;

	if (o->full_force || strncmp(o->device, "hm:", 3) != 0)
		return 0;
	for (k = 0; k < 2; k++) {
		v[k] = 0;
		if (core_param(c, o, 0, lim[k].id, &v[k]) < 0)
			return -1;
		if (v[k] > lim[k].first) {
			v[k] = lim[k].first;
			if (core_param(c, o, 1, lim[k].id, &v[k]) < 0)
				return -1;
		}
	}
	fprintf(stderr,
		"swell-ctl: first run on a HapticMaster: force.max %.3g N, force.rate %.3g N/s (raise them on purpose: "
		"swell-tool set force.max 10N; or --full-force)\n",
		v[0] * 1e-6, v[1] * 1e-6);
	return 0;
}

static int scene_opt(struct swell_cli *c, const char *opt, const char *v)
{
	(void)opt;
	scene_start(c->ctx, v);
	return 0;
}

static int version_opt(struct swell_cli *c, const char *opt, const char *v)
{
	if (parse_version(v, ((struct opts *)c->ctx)->cfg.fw_version))
		return swell_cli_refuse(c, "%s must be X.Y.Z with each part 0..255, not %s", opt, v);
	return 0;
}

void parse(int argc, char **argv, struct opts *o)
{
	enum swell_err e;

	memset(o, 0, sizeof(*o));
	o->device = "udp";
	o->host = "udp";
	o->rt = 1;
	o->pool_max = 256;
	swell_ctl_default_config(&o->cfg);
	if (parse_version(SWELL_CTL_FW_VERSION, o->cfg.fw_version))
		die("build version is not X.Y.Z: %s", SWELL_CTL_FW_VERSION);
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_FLAG("--autorun", o->cfg.autorun),
		SWELL_CLI_FLAG("--full-force", o->full_force),
		SWELL_CLI_SET("--no-rt", o->rt, 0),
		SWELL_CLI_FLAG("--quiet", o->quiet),
		SWELL_CLI_STR("--device", o->device),
		SWELL_CLI_STR("--host", o->host),
		SWELL_CLI_HOOK("--scene", scene_opt, 1),
		SWELL_CLI_CHOICE("--clock", o->device_clock, "internal|device"),
		SWELL_CLI_WHOLE("--tick-hz", o->cfg.tick_hz, SWELL_TICK_HZ_MIN, SWELL_TICK_HZ_MAX, ""),
		SWELL_CLI_WHOLE("--solver-hz", o->cfg.solver_hz, 1, SWELL_TICK_HZ_MAX, ""),
		SWELL_CLI_WHOLE("--silent-ticks", o->cfg.silent_ticks, 1, 10000, ""),
		SWELL_CLI_WHOLE("--host-budget", o->cfg.host_budget, 1, SWELL_CTL_QUEUE / 2.0, ""),
		SWELL_CLI_WHOLE("--pool-max", o->pool_max, SWELL_WAVE_MIN_SIDE, SWELL_WAVE_MAX_SIDE, ""),
		SWELL_CLI_WHOLE("--node", o->cfg.node, 0, SWELL_NODE_MAX, ""),
		SWELL_CLI_HOOK("--fw-version", version_opt, 1),
		SWELL_CLI_NUM_ABOVE("--seconds", o->seconds, 0, 1e7, "s"),
	};
	struct swell_cli cli = {
		.prog = "swell-ctl", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts), .ctx = o
	};
	const uint16_t silent0 = o->cfg.silent_ticks;

	o->cfg.silent_ticks = 0; /* not given: --silent-ticks takes 1 and up */
	swell_cli_parse(&cli, argc, argv);
	o->silent_given = o->cfg.silent_ticks != 0;
	if (!o->silent_given)
		o->cfg.silent_ticks = silent0;
	check_links(o);
	/* the HapticMaster's TCP link sends its request when the tick's FORCE_CMD comes: one every tick */
	o->cfg.cmd_every_tick = !strncmp(o->device, "hm:", 3);
	o->cfg.energy_water = 1; /* the energy account keeps the water's share here (docs/energy.md) */
	o->cfg.recover_ticks = (uint16_t)(o->cfg.tick_hz / 10 > 0 ? o->cfg.tick_hz / 10 : 1);
	if (o->scene_path)
		scene_e(o);
	e = swell_ctl_check(&o->cfg);
	if (e != SWELL_OK)
		die("configuration refused: %s (tick %u Hz, solver %u Hz)", swell_err_str(e), o->cfg.tick_hz,
		    o->cfg.solver_hz);
}
