/* swell-tool: the operator's console for a running controller (status, parameters, commands, live
 * telemetry, CSV logs and plots), over the controller's host link. */
#define _GNU_SOURCE
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "swell/cli.h"
#include "swell/link.h"
#include "swell/param.h"
#include "swell/scene.h"
#include "swell/transport.h"
#include "tool_check.h"
#include "tool_scene.h"
#include "tool_session.h"
#include "swell/param_text.h"

static const char usage[] =
	"usage: swell-tool [--link SPEC] [--node N] [--timeout-ms MS] COMMAND [ARGS]\n"
	"The operator's console for a running controller (swell-ctl or the STM32F405 image), over its\n"
	"host link, as one of its clients (a viewer may run beside it).\n"
	"  --link SPEC      udp[:PORT] (default udp:47802, the clients' port of swell-ctl's host\n"
	"                   link, its listen=; kept alive with a heartbeat every second),\n"
	"                   can:IFACE, usb[:VID:PID]\n"
	"  --node N         the controller's node, 0..15 (default: the one controller heard)\n"
	"  --timeout-ms MS  how long to wait for the controller and for each answer, and the silence\n"
	"                   that means it is gone (default 1000; 600 at least)\n"
	"Commands:\n"
	"  status [--json]          state, last error, protocol and firmware version, counters, scene,\n"
	"                           object (size, mass, height, submersion, force)\n"
	"  get NAME                 one parameter, with its unit\n"
	"  set NAME VALUE[UNIT]     e.g. set body.mass 80g, set wave.damping 0.02, set body.h 4cm;\n"
	"                           prints the value now in force, or the controller's reason\n"
	"  params                   every parameter: value, unit, range, default, changeable now\n"
	"  arm                      force law off, device held (STOP; from a fault: CLEAR)\n"
	"  run | stop | clear       the commands RUN, STOP, CLEAR; each prints the answer and the\n"
	"                           state after it\n"
	"  estop                    software stop: autorun off and STOP at once (zero force within a\n"
	"                           tick); not the device's own e-stop\n"
	"  watch [--seconds S]      a live line at 10 Hz: state, object z and submersion, force,\n"
	"                           largest wave, energy created in the run (+ while the passivity\n"
	"                           controller acts), link load (until SIGINT, or S seconds)\n"
	"  log FILE.csv [--seconds S]  S seconds (default 10) of telemetry at 100 Hz to a CSV file,\n"
	"                           with a progress line\n"
	"  scene load FILE.scene    a scene file as one change: another pool first (outside RUNNING, the\n"
	"                           controller restarts with it), then the parameters; a refused\n"
	"                           value puts back what was set and names the line\n"
	"  scene save FILE.scene    the scene in force, every parameter, to a file\n"
	"  check [--hm HOST[:PORT]] [--max-force N] [--max-rate N/S] [--max-rtt-ms MS]\n"
	"                           walk the chain before holding the handle, one line each with the fix:\n"
	"                           link, controller (version, state), device (heard, rate, status),\n"
	"                           round trip, frame (the handle over the pool), force limits (at most\n"
	"                           the first-run 2 N and 20 N/s unless given), e-stop, and with --hm the\n"
	"                           HapticMaster's own interface (read only): its e-stop and swell's\n"
	"                           effects left on it; exit 0 only when none fails\n"
	"  plot FILE.csv [--out FILE.png]  gnuplot PNG of a log: force, object bottom against the water\n"
	"                           under it, submersion (default FILE.png beside the CSV)\n"
	"Exit status: 0 done; 1 runtime failure (link, file); 2 bad arguments; 3 no controller heard;\n"
	"4 wrong node (another node heard, or several and no --node); 5 timeout (no answer, or the\n"
	"controller went silent); 6 refused (the controller's reason is printed; nothing changed); 7 check:\n"
	"a link of the chain failed.\n";

struct opts {
	struct swell_client_spec spec;
	int timeout_ms;
	int json;
	double seconds;
	const char *out;
	const char *hm; /* check --hm */
	double max_force, max_rate, max_rtt_ms; /* check: 0 = the defaults */
	int argc;
	char *argv[16]; /* the command and its arguments, options taken out */
};

static volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
	(void)sig;
	stop_flag = 1;
}

static int bad(const char *fmt, const char *arg)
{
	fprintf(stderr, "swell-tool: ");
	fprintf(stderr, fmt, arg);
	fprintf(stderr, " (swell-tool --help)\n");
	return TOOL_USAGE;
}

static int link_opt(struct swell_cli *c, const char *opt, const char *v)
{
	char why[160];

	(void)opt;
	if (swell_link_spec_parse(v, SWELL_LINK_ACCEPT_HOST_SIDE, SWELL_UDP_PORT_CLIENTS,
				  &((struct opts *)c->ctx)->spec.link, why, sizeof(why)) < 0)
		return swell_cli_refuse(c, "%s", why);
	return 0;
}

/* The command and its words (a negative number among them is a word, not an option). */
static int word(struct swell_cli *c, const char *w)
{
	struct opts *o = c->ctx;

	if (o->argc == (int)(sizeof(o->argv) / sizeof(o->argv[0])))
		return swell_cli_refuse(c, "too many words (swell-tool --help)");
	o->argv[o->argc++] = (char *)w;
	return 0;
}

static int parse_args(int argc, char **argv, struct opts *o)
{
	char err[160];

	memset(o, 0, sizeof(o[0]));
	o->timeout_ms = 1000;
	o->seconds = -1;
	o->spec.node = -1;
	if (swell_link_spec_parse("udp", SWELL_LINK_ACCEPT_HOST_SIDE, SWELL_UDP_PORT_CLIENTS, &o->spec.link, err,
				  sizeof(err)) < 0)
		return bad("%s", err);
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_FLAG("--json", o->json),
		SWELL_CLI_HOOK("--link", link_opt, 1),
		SWELL_CLI_WHOLE("--node", o->spec.node, 0, SWELL_NODE_MAX, ""),
		SWELL_CLI_WHOLE("--timeout-ms", o->timeout_ms, 1, 600000, "ms"),
		SWELL_CLI_NUM_ABOVE("--seconds", o->seconds, 0, 86400, "s"),
		SWELL_CLI_STR("--out", o->out),
		SWELL_CLI_STR("--hm", o->hm),
		SWELL_CLI_NUM_ABOVE("--max-force", o->max_force, 0, 1e6, "N"),
		SWELL_CLI_NUM_ABOVE("--max-rate", o->max_rate, 0, 1e6, "N/s"),
		SWELL_CLI_NUM_ABOVE("--max-rtt-ms", o->max_rtt_ms, 0, 1e6, "ms"),
	};
	struct swell_cli cli = {
		.prog = "swell-tool", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts), .ctx = o, .operand = word
	};

	swell_cli_parse(&cli, argc, argv);
	if (o->argc == 0)
		return bad("%s", "no command given");
	return TOOL_OK;
}

/* ---- commands ---- */

static const struct swell_param_desc *param_named(const char *name)
{
	const struct swell_param_desc *d = swell_scene_desc_by_name(name);
	size_t n, k;
	uint16_t id;

	if (!d) {
		const struct swell_param_desc *t = swell_param_table(&n);

		fprintf(stderr, "swell-tool: no parameter '%s'; there are:", name);
		for (k = 0; k < n; k++)
			fprintf(stderr, " %s", t[k].name);
		for (id = SWELL_SCENE_NX; id <= SWELL_SCENE_DEPTH_UM; id++)
			fprintf(stderr, " %s", swell_scene_key(id)->name);
		fprintf(stderr, " (the pool's: outside RUNNING, on a controller that takes them)\n");
	}
	return d;
}

static int cmd_get(struct tool_session *s, const struct opts *o)
{
	const struct swell_param_desc *d;
	char buf[64];
	int32_t v = 0;
	enum tool_rc rc;

	d = param_named(o->argv[1]);
	if (!d)
		return TOOL_USAGE;
	rc = tool_get(s, d, o->timeout_ms, &v, NULL);
	if (rc != TOOL_OK)
		return rc;
	swell_param_format(d, v, buf, sizeof(buf));
	printf("%s = %s (raw %ld)\n", d->name, buf, (long)v);
	return TOOL_OK;
}

/* set's words: the parameter and the value in its units (TOOL_OK), or the reason on one line. */
static int set_words(const struct opts *o, const struct swell_param_desc **d, int32_t *raw)
{
	char text[64] = "", err[200];
	int k;

	if (o->argc < 3)
		return bad("%s", "set takes a parameter name and a value, e.g. set body.mass 80g");
	*d = param_named(o->argv[1]);
	if (!*d)
		return TOOL_USAGE;
	if ((*d)->access == SWELL_PACCESS_RO)
		return bad("%s is read only: the controller measures it (swell-tool get)", (*d)->name);
	for (k = 2; k < o->argc; k++) /* "80 g" as two words, too */
		if (strlen(text) + strlen(o->argv[k]) + 1 < sizeof(text))
			strcat(text, o->argv[k]);
	if (swell_param_parse(*d, text, raw, err, sizeof(err)) < 0)
		return bad("%s", err);
	return TOOL_OK;
}

static int cmd_set(struct tool_session *s, const struct opts *o)
{
	const struct swell_param_desc *d = NULL;
	enum swell_err why = SWELL_OK;
	char err[200], was[64], now[64];
	int32_t raw = 0, before = 0, v = 0;
	int rc = set_words(o, &d, &raw);

	if (rc == TOOL_OK)
		rc = tool_get(s, d, o->timeout_ms, &before, NULL);
	if (rc != TOOL_OK)
		return rc;
	swell_param_format(d, before, was, sizeof(was));
	rc = tool_request(s, 1, d->id, raw, o->timeout_ms, &v, &why, err, sizeof(err));
	if (rc == TOOL_REFUSED) {
		fprintf(stderr, "swell-tool: set %s refused by the controller: %s (state %s); %s stays %s\n", d->name,
			swell_err_str(why), swell_state_name(s->t.hb.state), d->name, was);
		return rc;
	}
	if (rc != TOOL_OK) {
		fprintf(stderr, "swell-tool: set %s: %s\n", d->name, err);
		return rc;
	}
	swell_param_format(d, v, now, sizeof(now));
	printf("%s = %s (was %s)\n", d->name, now, was);
	return TOOL_OK;
}

/* One row of params: the value in force, the range and default in units, and whether it may change now. */
static void param_row(const struct swell_param_desc *d, int32_t raw, const char *changeable)
{
	char v[48], lo[48], hi[48], def[48], range[100];

	swell_param_format(d, raw, v, sizeof(v));
	swell_param_format(d, d->min, lo, sizeof(lo));
	swell_param_format(d, d->max, hi, sizeof(hi));
	swell_param_format(d, d->def, def, sizeof(def));
	snprintf(range, sizeof(range), "%s .. %s", lo, hi);
	printf("%-18s %-16s %-30s %-14s %s\n", d->name, v, range, def, changeable);
}

static int cmd_params(struct tool_session *s, const struct opts *o)
{
	const struct swell_param_desc *t;
	size_t n, k;
	uint16_t id;
	int worst = TOOL_OK;

	tool_pump(s, 50);
	t = swell_param_table(&n);
	printf("%-18s %-16s %-30s %-14s %s\n", "parameter", "value", "range", "default", "changeable now");
	for (k = 0; k < n; k++) {
		int32_t raw = 0;
		int rc = tool_get(s, &t[k], o->timeout_ms, &raw, NULL);

		if (rc != TOOL_OK) {
			worst = rc;
			if (rc == TOOL_TIMEOUT)
				return rc;
			continue;
		}
		param_row(&t[k], raw,
			  t[k].access == SWELL_PACCESS_RO ? "no: read only (measured)"
				  : t[k].when == SWELL_PWHEN_DRY && tool_object_wet(s)
				  ? "no: the object displaces water"
				  : t[k].when == SWELL_PWHEN_IDLE && s->t.hb.state == SWELL_CTL_RUNNING
				  ? "no: while running"
				  : "yes");
	}
	printf("%-18s %-16s %-30s %-14s %s\n", SWELL_PARAM_COMMAND_NAME, "(write only)", "stop, run, clear", "-",
	       "yes (clear: in fault)");
	if (worst != TOOL_OK)
		return worst;
	/* the pool's rows, on a controller that answers them (a port that takes a pool at start-up) */
	for (id = SWELL_SCENE_NX; id <= SWELL_SCENE_DEPTH_UM; id++) {
		const struct swell_param_desc *d = swell_scene_key(id);
		enum swell_err why = SWELL_OK;
		char err[200];
		int32_t raw = 0;
		enum tool_rc rc = tool_request(s, 0, id, 0, o->timeout_ms, &raw, &why, err, sizeof(err));

		if (rc == TOOL_REFUSED)
			return TOOL_OK; /* this controller takes no pool on the wire */
		if (rc != TOOL_OK) {
			fprintf(stderr, "swell-tool: get %s: %s\n", d->name, err);
			return rc;
		}
		param_row(d, raw,
			  s->t.hb.state == SWELL_CTL_RUNNING ? "no: running" : "yes: restarts, the water at rest");
	}
	return TOOL_OK;
}

/* Send a command, print its answer and the state it leads to (waited for up to the timeout). */
static int command(struct tool_session *s, const struct opts *o, int32_t cmd, unsigned want_mask)
{
	enum swell_err why = SWELL_OK;
	char err[200];
	int32_t v = 0;
	const char *name = swell_command_name(cmd);
	const unsigned before = s->t.hb.state;
	const uint64_t t0 = swell_link_now_ns(), until = t0 + (uint64_t)o->timeout_ms * 1000000u;
	enum tool_rc rc = tool_request(s, 1, SWELL_PARAM_COMMAND, cmd, o->timeout_ms, &v, &why, err, sizeof(err));
	const uint32_t seq0 = s->t.hb.seq; /* the heartbeat after the answer (10 Hz) tells the state after it */

	if (rc == TOOL_REFUSED) {
		fprintf(stderr, "swell-tool: %s refused by the controller: %s (state %s)\n", name, swell_err_str(why),
			swell_state_name(s->t.hb.state));
		return rc;
	}
	if (rc != TOOL_OK) {
		fprintf(stderr, "swell-tool: %s: %s\n", name, err);
		return rc;
	}
	while (swell_link_now_ns() < until) {
		tool_pump(s, 20);
		if (s->t.hb.seq != seq0 && (want_mask >> s->t.hb.state & 1u))
			break;
		if (tool_silent(s)) {
			fprintf(stderr, "swell-tool: %s acknowledged, then the controller went silent\n", name);
			return TOOL_TIMEOUT;
		}
	}
	printf("%s: acknowledged; state %s -> %s (%.0f ms)%s%s\n", name, swell_state_name(before),
	       swell_state_name(s->t.hb.state), (double)(swell_link_now_ns() - t0) / 1e6,
	       s->t.hb.err ? ", last error: " : "", s->t.hb.err ? swell_err_str((enum swell_err)s->t.hb.err) : "");
	if (!(want_mask >> s->t.hb.state & 1u)) {
		fprintf(stderr, "swell-tool: %s: the state did not follow (still %s)%s\n", name,
			swell_state_name(s->t.hb.state),
			cmd == SWELL_CMD_RUN ? ": the device must be there, powered and its e-stop released" : "");
		return TOOL_REFUSED;
	}
	return TOOL_OK;
}

#define STATE_BIT(st) (1u << (st))

static int cmd_estop(struct tool_session *s, const struct opts *o)
{
	struct swell_msg m[2];
	struct swell_frame f;
	size_t used, k;

	/* both requests at once, no waiting in between: the force is zero within a tick of the second */
	m[0] = swell_param_request((uint8_t)s->node, 1, SWELL_PARAM_AUTORUN, 0, ++s->seq);
	m[1] = swell_param_request((uint8_t)s->node, 1, SWELL_PARAM_COMMAND, SWELL_CMD_STOP, ++s->seq);
	for (k = 0; k < 2; k++)
		if (swell_link_encode(swell_link_carrier(s->l), m[k].node, s->pkt_seq++, &m[k], 1, &f, &used) ==
		    SWELL_OK)
			(void)swell_link_send(s->l, &f);
	/* then the same through the acknowledged path: a lost frame is sent again */
	return command(s, o, SWELL_CMD_STOP, ~STATE_BIT(SWELL_CTL_RUNNING) & 0x1fu);
}

static int cmd_arm(struct tool_session *s, const struct opts *o)
{
	const int fault = s->t.hb.state == SWELL_CTL_FAULT;

	return command(s, o, fault ? SWELL_CMD_CLEAR : SWELL_CMD_STOP,
		       STATE_BIT(SWELL_CTL_ARMED) | (fault ? STATE_BIT(SWELL_CTL_IDLE) : 0));
}

static int cmd_scene(struct tool_session *s, const struct opts *o)
{
	return !strcmp(o->argv[1], "load") ? tool_scene_load(s, o->argv[2], o->timeout_ms)
					   : tool_scene_save(s, o->argv[2], o->timeout_ms);
}

static void json_str(const char *k, const char *v)
{
	printf("  \"%s\": \"%s\",\n", k, v);
}

static int cmd_status(struct tool_session *s, const struct opts *o)
{
	const struct tool_telemetry *t = &s->t;
	int32_t mode = 0;
	const int wait_ms = 11 * o->timeout_ms / 10 + 1200; /* scene and info come at 1 Hz */
	int32_t mass = 0;
	char fw[16] = "?";
	enum tool_rc rc;

	/* the heartbeat is the controller's status; a scene or info that is late (a controller running
	 * below real time) is reported as not heard, not as a failure */
	tool_wait_full(s, wait_ms);
	if (tool_silent(s)) {
		fprintf(stderr, "swell-tool: status: the controller went silent\n");
		return TOOL_TIMEOUT;
	}
	rc = tool_get(s, swell_param_by_id(SWELL_PARAM_BODY_MASS_G), o->timeout_ms, &mass, NULL);
	if (rc == TOOL_OK)
		rc = tool_get(s, swell_param_by_id(SWELL_PARAM_FORCE_MODE), o->timeout_ms, &mode, NULL);
	if (rc != TOOL_OK)
		return rc;
	tool_pump(s, 30); /* a pose and a force (100 Hz) */
	if (t->have_info)
		snprintf(fw, sizeof(fw), "%u.%u.%u", t->info.fw_major, t->info.fw_minor, t->info.fw_patch);
	if (o->json) {
		printf("{\n");
		json_str("link", s->name);
		printf("  \"node\": %d,\n", s->node);
		json_str("state", swell_state_name(t->hb.state));
		json_str("last_error", swell_err_str((enum swell_err)t->hb.err));
		printf("  \"protocol_version\": %u,\n", t->hb.version);
		if (t->have_info)
			json_str("firmware_version", fw);
		else
			printf("  \"firmware_version\": null,\n");
		printf("  \"bad_frames\": %u,\n  \"overruns\": %u,\n", t->hb.bad_frames, t->hb.overruns);
		json_str("force_mode", mode ? "effect" : "stream");
		if (t->have_scene)
			printf("  \"scene\": {\"id\": %u, \"nx\": %u, \"ny\": %u, \"dx_mm\": %.3f, \"depth_mm\": "
			       "%.2f},\n",
			       t->scene.scene_id, t->scene.nx, t->scene.ny, t->scene.dx_um / 1000.0,
			       t->scene.depth_10um / 100.0);
		else
			printf("  \"scene\": null,\n");
		printf("  \"object\": {");
		if (t->have_info)
			printf("\"a_mm\": %.1f, \"b_mm\": %.1f, \"h_mm\": %.1f, ", t->info.obj_a_100um / 10.0,
			       t->info.obj_b_100um / 10.0, t->info.obj_h_100um / 10.0);
		printf("\"mass_g\": %ld", (long)mass);
		if (t->have_pose && t->have_force)
			printf(", \"x_mm\": %.2f, \"y_mm\": %.2f, \"z_mm\": %.2f, \"submersion_pct\": %.1f, "
			       "\"force_N\": [%.2f, %.2f, %.2f], \"limits\": %u",
			       t->pose.x_10um / 100.0, t->pose.y_10um / 100.0, t->pose.z_10um / 100.0,
			       t->pose.submersion_halfpct / 2.0, t->force.fx_cN / 100.0, t->force.fy_cN / 100.0,
			       t->force.fz_cN / 100.0, t->force.limits);
		printf("},\n");
		if (t->have_energy)
			printf("  \"energy\": {\"created_mJ\": %.3f, \"balance_mJ\": %.2f, \"passivity\": %u, "
			       "\"acting\": %u}\n}\n",
			       t->energy.created_uJ / 1000.0, t->energy.balance_10uJ / 100.0, t->energy.passivity,
			       t->energy.acting);
		else
			printf("  \"energy\": null\n}\n");
		return TOOL_OK;
	}
	printf("controller   node %d on %s, state %s, last error: %s\n", s->node, s->name,
	       swell_state_name(t->hb.state), swell_err_str((enum swell_err)t->hb.err));
	printf("versions     protocol %u, firmware %s\n", t->hb.version, t->have_info ? fw : "not heard yet");
	printf("counters     %u bad frames, %u tick overruns (saturating at 65535)\n", t->hb.bad_frames,
	       t->hb.overruns);
	if (t->have_scene)
		printf("scene        %u x %u cells of %.3f mm (%.1f x %.1f mm), depth %.2f mm, id %u\n", t->scene.nx,
		       t->scene.ny, t->scene.dx_um / 1000.0, t->scene.nx * t->scene.dx_um / 1000.0,
		       t->scene.ny * t->scene.dx_um / 1000.0, t->scene.depth_10um / 100.0, t->scene.scene_id);
	else
		printf("scene        not heard within %.1f s (sent once a second of the controller's time)\n",
		       wait_ms / 1000.0);
	if (t->have_info)
		printf("object       %.1f x %.1f x %.1f mm, %ld g", t->info.obj_a_100um / 10.0,
		       t->info.obj_b_100um / 10.0, t->info.obj_h_100um / 10.0, (long)mass);
	else
		printf("object       %ld g (size not heard yet)", (long)mass);
	if (t->have_pose)
		printf("; bottom at %.2f mm, %.1f %% submerged", t->pose.z_10um / 100.0,
		       t->pose.submersion_halfpct / 2.0);
	printf("\nforce mode   %s\n",
	       mode ? "effect (springs, damper and gravity rendered by the device, updated every "
		      "solver step)"
		    : "stream (a force every device tick)");
	if (t->have_force)
		printf("force        %.2f %.2f %.2f N%s%s\n", t->force.fx_cN / 100.0, t->force.fy_cN / 100.0,
		       t->force.fz_cN / 100.0, t->force.limits & 1u ? ", clamped to the limit" : "",
		       t->force.limits & 2u ? ", rate limited" : "");
	if (t->have_energy)
		printf("energy       created %.3f mJ, D %.2f mJ in the run (docs/energy.md); passivity controller "
		       "%s%s\n",
		       t->energy.created_uJ / 1000.0, t->energy.balance_10uJ / 100.0,
		       t->energy.passivity ? "on" : "off", t->energy.acting ? ", acting" : "");
	return TOOL_OK;
}

/* Link load since the last call: frames/s, kB/s and (CAN) the share of a 1 Mbit/s bus. */
struct load {
	uint64_t frames, bytes, bits, t_ns;
};

static void load_line(struct tool_session *s, struct load *l, char *buf, size_t len)
{
	const uint64_t now = swell_link_now_ns();
	const double dt = (double)(now - l->t_ns) / 1e9;

	if (swell_link_carrier(s->l) == SWELL_CARRIER_PKT)
		snprintf(buf, len, "%.0f packets/s %.1f kB/s", (double)(s->t.frames - l->frames) / dt,
			 (double)(s->t.bytes - l->bytes) / dt / 1e3);
	else
		snprintf(buf, len, "%.0f frames/s, bus %.1f %% of 1 Mbit/s", (double)(s->t.frames - l->frames) / dt,
			 (double)(s->t.can_bits - l->bits) / dt / 1e4);
	l->frames = s->t.frames;
	l->bytes = s->t.bytes;
	l->bits = s->t.can_bits;
	l->t_ns = now;
}

static int cmd_watch(struct tool_session *s, const struct opts *o)
{
	const double seconds = o->seconds > 0 ? o->seconds : 1e9;
	const int tty = isatty(fileno(stdout));
	struct load l = { s->t.frames, s->t.bytes, s->t.can_bits, swell_link_now_ns() };
	char lb[80];

	while (!stop_flag && tool_elapsed_s(s) < seconds) {
		tool_pump(s, 100);
		if (tool_silent(s)) {
			fprintf(stderr, "%sswell-tool: watch: the controller went silent (no heartbeat for %d ms)\n",
				tty ? "\n" : "", s->silent_ms);
			return TOOL_TIMEOUT;
		}
		load_line(s, &l, lb, sizeof(lb));
		printf("%s%7.1f s  %-7s  z %7.2f mm  sub %5.1f %%  F %6.2f %6.2f %6.2f N  wave %5.2f mm  "
		       "created %7.3f mJ%s  %s%s",
		       tty ? "\r" : "", tool_elapsed_s(s), swell_state_name(s->t.hb.state), s->t.pose.z_10um / 100.0,
		       s->t.pose.submersion_halfpct / 2.0, s->t.force.fx_cN / 100.0, s->t.force.fy_cN / 100.0,
		       s->t.force.fz_cN / 100.0, tool_wave_max_mm(s), s->t.energy.created_uJ / 1000.0,
		       s->t.energy.acting ? "+" : " ", lb, tty ? "   " : "\n");
		fflush(stdout);
	}
	if (tty)
		printf("\n");
	return TOOL_OK;
}

struct log_state {
	FILE *f;
	uint32_t rows;
	double t0;
};

/* One row per OBJECT_FORCE (100 Hz), which follows its OBJECT_POSE (same seq). */
static void log_row(struct tool_session *s, const struct swell_msg *m, void *user)
{
	struct log_state *lg = user;

	if (m->type != SWELL_MSG_OBJECT_FORCE || !s->t.have_pose || s->t.pose.seq != m->u.object_force.seq)
		return;
	fprintf(lg->f, "%.4f,%s,%.2f,%.2f,%.2f,%.1f,%.2f,%.2f,%.2f,%.4f,%.4f\n",
		(double)(s->t.force_ns - s->t0_ns) / 1e9 - lg->t0, swell_state_name(s->t.hb.state),
		s->t.pose.x_10um / 100.0, s->t.pose.y_10um / 100.0, s->t.pose.z_10um / 100.0,
		s->t.pose.submersion_halfpct / 2.0, s->t.force.fx_cN / 100.0, s->t.force.fy_cN / 100.0,
		s->t.force.fz_cN / 100.0, tool_water_under_mm(s), tool_wave_max_mm(s));
	lg->rows++;
}

static int cmd_log(struct tool_session *s, const struct opts *o)
{
	const double seconds = o->seconds > 0 ? o->seconds : 10;
	const int tty = isatty(fileno(stderr));
	static struct log_state lg; /* reached from the session's callback */
	double next_progress = 0, t;

	lg.f = fopen(o->argv[1], "w");
	if (!lg.f) {
		fprintf(stderr, "swell-tool: log: cannot write %s: %s\n", o->argv[1], strerror(errno));
		return TOOL_FAIL;
	}
	lg.rows = 0;
	tool_wait_full(s, 11 * o->timeout_ms / 10 + 1200); /* scene and info, for the water under the object */
	lg.t0 = tool_elapsed_s(s);
	fprintf(lg.f, "t_s,state,x_mm,y_mm,z_mm,submersion_pct,fx_N,fy_N,fz_N,water_mm,wave_max_mm\n");
	s->on_msg = log_row;
	s->user = &lg;
	while (!stop_flag && (t = tool_elapsed_s(s) - lg.t0) < seconds) {
		tool_pump(s, 20);
		if (tool_silent(s)) {
			s->on_msg = NULL;
			fclose(lg.f);
			fprintf(stderr,
				"%sswell-tool: log: the controller went silent after %.1f s; %u rows kept in %s\n",
				tty ? "\n" : "", t, lg.rows, o->argv[1]);
			return TOOL_TIMEOUT;
		}
		if (t >= next_progress) { /* a line a second, in place on a terminal */
			fprintf(stderr, "%slog: %5.1f of %.1f s, %u rows to %s%s", tty ? "\r" : "", t, seconds, lg.rows,
				o->argv[1], tty ? "" : "\n");
			next_progress += 1;
		}
	}
	s->on_msg = NULL;
	if (fclose(lg.f) != 0) {
		fprintf(stderr, "\nswell-tool: log: writing %s failed: %s\n", o->argv[1], strerror(errno));
		return TOOL_FAIL;
	}
	fprintf(stderr, "%slog: %.1f s, %u rows (%.0f a second) to %s\n", tty ? "\r" : "", tool_elapsed_s(s) - lg.t0,
		lg.rows, lg.rows / (tool_elapsed_s(s) - lg.t0), o->argv[1]);
	return TOOL_OK;
}

static int cmd_plot(const struct opts *o)
{
	char png[4096], line[256];
	FILE *f, *g;
	int rows = 0, rc;

	f = fopen(o->argv[1], "r");
	if (!f) {
		fprintf(stderr, "swell-tool: plot: cannot read %s: %s\n", o->argv[1], strerror(errno));
		return TOOL_FAIL;
	}
	if (!fgets(line, sizeof(line), f) || strncmp(line, "t_s,state,x_mm", 14) != 0) {
		fclose(f);
		fprintf(stderr, "swell-tool: plot: %s is not a swell-tool log (header t_s,state,x_mm,...)\n",
			o->argv[1]);
		return TOOL_FAIL;
	}
	while (fgets(line, sizeof(line), f))
		rows++;
	fclose(f);
	if (rows < 2) {
		fprintf(stderr, "swell-tool: plot: %s has %d rows, nothing to plot\n", o->argv[1], rows);
		return TOOL_FAIL;
	}
	if (o->out)
		snprintf(png, sizeof(png), "%s", o->out);
	else {
		size_t n = strlen(o->argv[1]);

		snprintf(png, sizeof(png), "%.*s.png", (int)(n > 4 && !strcmp(o->argv[1] + n - 4, ".csv") ? n - 4 : n),
			 o->argv[1]);
	}
	if (strpbrk(png, "\"\\") || strpbrk(o->argv[1], "\"\\"))
		return bad("%s", "file names with quotes or backslashes cannot be handed to gnuplot");
	g = popen("gnuplot", "w");
	if (!g) {
		fprintf(stderr, "swell-tool: plot: cannot run gnuplot (tools/setup installs gnuplot-nox)\n");
		return TOOL_FAIL;
	}
	fprintf(g,
		"set terminal pngcairo size 1000,900 font 'sans,10'\nset output \"%s\"\n"
		"set datafile separator ','\nset key autotitle columnhead top right\nset grid\n"
		"set multiplot layout 3,1 title \"swell-tool log %s (%d rows)\"\n"
		"set ylabel 'force (N)'\nplot \"%s\" using 1:9 with lines lw 2 title 'Fz', '' using 1:7 with lines "
		"title 'Fx', '' using 1:8 with lines title 'Fy'\n"
		"set ylabel 'height (mm)'\nplot \"%s\" using 1:5 with lines lw 2 title 'object bottom z', '' using "
		"1:10 with lines lw 2 title 'water under the object', '' using 1:11 with lines title 'largest wave'\n"
		"set ylabel 'submersion (%%)'\nset xlabel 'time (s)'\nset yrange [0:105]\nplot \"%s\" using 1:6 with "
		"lines lw 2 title 'submerged'\nunset multiplot\n",
		png, o->argv[1], rows, o->argv[1], o->argv[1], o->argv[1]);
	rc = pclose(g);
	if (rc != 0) {
		fprintf(stderr, "swell-tool: plot: gnuplot failed (status %d)\n", rc);
		return TOOL_FAIL;
	}
	printf("plot: %s (%d rows of %s)\n", png, rows, o->argv[1]);
	return TOOL_OK;
}

/* The commands: the words each takes after its name (-1: set counts its own), what it says when they
 * are not so, the options it takes, and what carries it out: run, or else the command cmd with the
 * states it leads to (check and plot are not a session's commands: main runs them). */
#define OPT_JSON 1u
#define OPT_SECONDS 2u
#define OPT_OUT 4u
#define OPT_CHECK 8u

static const struct tool_command {
	const char *name;
	int words;
	const char *words_wrong; /* NULL: "takes no words after it" */
	unsigned opts;
	int (*run)(struct tool_session *s, const struct opts *o);
	int32_t cmd;
	unsigned want_mask;
} commands[] = {
	{ "status", 0, NULL, OPT_JSON, cmd_status, 0, 0 },
	{ "get", 1, "get takes one parameter name", 0, cmd_get, 0, 0 },
	{ "set", -1, NULL, 0, cmd_set, 0, 0 },
	{ "params", 0, NULL, 0, cmd_params, 0, 0 },
	{ "arm", 0, NULL, 0, cmd_arm, 0, 0 },
	{ "run", 0, NULL, 0, NULL, SWELL_CMD_RUN, STATE_BIT(SWELL_CTL_RUNNING) },
	{ "stop", 0, NULL, 0, NULL, SWELL_CMD_STOP, ~STATE_BIT(SWELL_CTL_RUNNING) & 0x1fu },
	{ "clear", 0, NULL, 0, NULL, SWELL_CMD_CLEAR, ~STATE_BIT(SWELL_CTL_FAULT) & 0x1fu },
	{ "estop", 0, NULL, 0, cmd_estop, 0, 0 },
	{ "watch", 0, NULL, OPT_SECONDS, cmd_watch, 0, 0 },
	{ "log", 1, "log takes one file name, e.g. log run.csv --seconds 10", OPT_SECONDS, cmd_log, 0, 0 },
	{ "scene", 2, "scene takes load FILE or save FILE", 0, cmd_scene, 0, 0 },
	{ "check", 0, NULL, OPT_CHECK, NULL, 0, 0 },
	{ "plot", 1, "plot takes one CSV file written by log", OPT_OUT, NULL, 0, 0 },
};

/* A command's words and options, checked before the link is opened: bad arguments are told at once,
 * not after waiting for a controller. */
static int check_words(const struct opts *o, const struct tool_command *c)
{
	const char *cmd = c->name;
	const struct swell_param_desc *d = NULL;
	int32_t raw = 0;

	if (o->json && !(c->opts & OPT_JSON))
		return bad("--json is an option of status, not of %s", cmd);
	if (o->seconds > 0 && !(c->opts & OPT_SECONDS))
		return bad("--seconds is an option of watch and log, not of %s", cmd);
	if (o->out && !(c->opts & OPT_OUT))
		return bad("--out is an option of plot, not of %s", cmd);
	if ((o->hm || o->max_force > 0 || o->max_rate > 0 || o->max_rtt_ms > 0) && !(c->opts & OPT_CHECK))
		return bad("--hm, --max-force, --max-rate and --max-rtt-ms are options of check, not of %s", cmd);
	if (c->words < 0)
		return set_words(o, &d, &raw);
	if (!strcmp(cmd, "get") && o->argc == 2 && !param_named(o->argv[1]))
		return TOOL_USAGE;
	if (o->argc != 1 + c->words ||
	    (c->run == cmd_scene && strcmp(o->argv[1], "load") && strcmp(o->argv[1], "save")))
		return c->words_wrong ? bad("%s", c->words_wrong) : bad("%s takes no words after it", cmd);
	return TOOL_OK;
}

int main(int argc, char **argv)
{
	static struct tool_session s; /* the height grid: 256 KB, not on the stack */
	struct opts o;
	char err[256];
	const struct tool_command *c;
	size_t k;
	int rc;

	rc = parse_args(argc, argv, &o);
	if (rc != TOOL_OK)
		return rc;
	for (k = 0; k < sizeof(commands) / sizeof(commands[0]) && strcmp(o.argv[0], commands[k].name); k++)
		;
	if (k == sizeof(commands) / sizeof(commands[0]))
		return bad("unknown command '%s'", o.argv[0]);
	c = &commands[k];
	rc = check_words(&o, c);
	if (rc != TOOL_OK)
		return rc;
	if (c->opts & OPT_OUT)
		return cmd_plot(&o);
	signal(SIGINT, on_signal);
	signal(SIGTERM, on_signal);
	rc = tool_open(&s, &o.spec, o.timeout_ms, err, sizeof(err));
	if (c->opts & OPT_CHECK) {
		const struct tool_check_opts co = { s.name,
						    o.hm,
						    o.max_force > 0 ? o.max_force : TOOL_CHECK_FORCE_N,
						    o.max_rate > 0 ? o.max_rate : TOOL_CHECK_RATE_N_S,
						    o.max_rtt_ms > 0 ? o.max_rtt_ms : TOOL_CHECK_RTT_MS,
						    o.timeout_ms };

		rc = tool_check(&s, (enum tool_rc)rc, err, &co);
		tool_close(&s);
		return rc;
	}
	if (rc != TOOL_OK) {
		fprintf(stderr, "swell-tool: %s\n", err);
		return rc;
	}
	rc = c->run ? c->run(&s, &o) : command(&s, &o, c->cmd, c->want_mask);
	tool_close(&s);
	return rc;
}
