#define _GNU_SOURCE
#include "tool_check.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "swell/hm_frame.h"
#include "swell/link.h"
#include "swell/num.h"
#include "swell/param.h"

#define HM_PORT 7654
#define HM_TEXT_MAX 1024

struct tally {
	int ok, failed, skipped;
};

/* One line: "ok    NAME  what", "FAIL  NAME  what: fix: how", "skip  NAME  why". */
static void line(struct tally *t, const char *verdict, const char *name, const char *fmt, ...)
	__attribute__((format(printf, 4, 5)));

static void line(struct tally *t, const char *verdict, const char *name, const char *fmt, ...)
{
	va_list ap;

	printf("%-5s %-11s ", verdict, name);
	va_start(ap, fmt);
	vprintf(fmt, ap);
	va_end(ap);
	putchar('\n');
	if (!strcmp(verdict, "ok"))
		t->ok++;
	else if (!strcmp(verdict, "FAIL"))
		t->failed++;
	else
		t->skipped++;
}

/* "HOST[:PORT]" -> one request on the HapticMaster's TCP interface and its answer text. 0, or -1 with a
 * one-line reason in err. */
static int tool_hm_ask(const char *spec, const char *request, char *answer, size_t cap, int timeout_ms, char *err,
		       size_t errlen)
{
	char host[64];
	const char *colon = strrchr(spec, ':');
	size_t hl = colon ? (size_t)(colon - spec) : strlen(spec), used = 0;
	long port = HM_PORT;
	struct sockaddr_in a;
	uint8_t out[SWELL_HM_FRAME_HDR + HM_TEXT_MAX], in[SWELL_HM_FRAME_HDR + HM_TEXT_MAX];
	size_t out_len = 0, sent = 0;
	uint64_t end = swell_link_now_ns() + (uint64_t)timeout_ms * 1000000u;
	int fd, one = 1;

	if (hl == 0 || hl >= sizeof(host) || (colon && swell_parse_long(colon + 1, 10, 1, 65535, &port) < 0)) {
		snprintf(err, errlen, "--hm %s: want HOST[:PORT]", spec);
		return -1;
	}
	memcpy(host, spec, hl);
	host[hl] = '\0';
	memset(&a, 0, sizeof(a));
	a.sin_family = AF_INET;
	a.sin_port = htons((uint16_t)port);
	if (inet_pton(AF_INET, host, &a.sin_addr) != 1) {
		struct addrinfo hints, *res = NULL;

		memset(&hints, 0, sizeof(hints));
		hints.ai_family = AF_INET;
		hints.ai_socktype = SOCK_STREAM;
		if (getaddrinfo(host, NULL, &hints, &res) != 0 || !res) {
			snprintf(err, errlen, "cannot resolve '%s'", host);
			return -1;
		}
		a.sin_addr = ((const struct sockaddr_in *)(const void *)res->ai_addr)->sin_addr;
		freeaddrinfo(res);
	}
	if (swell_hm_frame_put(out, sizeof(out), &out_len, request, strlen(request)) < 0) {
		snprintf(err, errlen, "request too long");
		return -1;
	}
	fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
	if (fd < 0) {
		snprintf(err, errlen, "no socket");
		return -1;
	}
	setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
	if (connect(fd, (const struct sockaddr *)&a, sizeof(a)) < 0) {
		snprintf(err, errlen, "no answer on tcp %s:%ld (connection refused)", host, port);
		close(fd);
		return -1;
	}
	while (out_len && swell_link_now_ns() < end)
		if (swell_hm_frame_flush(fd, out, &out_len, out_len, &sent) < 0)
			break;
	for (;;) {
		struct pollfd p = { fd, POLLIN, 0 };
		uint32_t len = 0;
		int64_t left = (int64_t)(end - swell_link_now_ns());
		ssize_t r;
		int whole = used >= SWELL_HM_FRAME_HDR ? swell_hm_frame_next(in, used, HM_TEXT_MAX, &len, NULL) : 0;

		if (whole < 0) {
			snprintf(err, errlen, "tcp %s:%ld: an answer that is not the HapticMaster's framing", host,
				 port);
			break;
		}
		if (whole > 0) {
			size_t n = len < cap ? len : cap - 1;

			memcpy(answer, in + SWELL_HM_FRAME_HDR, n);
			answer[n] = '\0';
			close(fd);
			return 0;
		}
		if (left <= 0 || poll(&p, 1, (int)(left / 1000000) + 1) <= 0) {
			snprintf(err, errlen, "tcp %s:%ld: no answer within %d ms", host, port, timeout_ms);
			break;
		}
		r = recv(fd, in + used, sizeof(in) - used, 0);
		if (r <= 0) {
			snprintf(err, errlen, "tcp %s:%ld: the connection closed", host, port);
			break;
		}
		used += (size_t)r;
	}
	close(fd);
	return -1;
}

/* Part i of a ';'-separated answer, copied (spaces and quotes trimmed); "" when there is none. */
static void answer_part(const char *text, int i, char *out, size_t cap)
{
	const char *p = text;
	size_t n;

	for (; i > 0 && p; i--) {
		p = strchr(p, ';');
		if (p)
			p++;
	}
	out[0] = '\0';
	if (!p)
		return;
	while (*p == ' ' || *p == '"')
		p++;
	n = strcspn(p, ";");
	while (n && (p[n - 1] == ' ' || p[n - 1] == '"'))
		n--;
	if (n >= cap)
		n = cap - 1;
	memcpy(out, p, n);
	out[n] = '\0';
}

/* A parameter by name: 0 with its raw value; 1 when the controller does not know it (an older one);
 * -1 when the request failed (why in err). */
static int param(struct tool_session *s, const char *name, const struct tool_check_opts *co, int32_t *v, char *err,
		 size_t errlen)
{
	const struct swell_param_desc *d = swell_param_by_name(name);
	enum swell_err why = SWELL_OK;
	enum tool_rc rc;

	if (!d) {
		snprintf(err, errlen, "this swell-tool has no parameter %s", name);
		return 1;
	}
	rc = tool_request(s, 0, d->id, 0, co->timeout_ms, v, &why, err, errlen);
	if (rc == TOOL_REFUSED && why == SWELL_EUNKNOWN)
		return 1;
	if (rc == TOOL_REFUSED)
		snprintf(err, errlen, "refused: %s", swell_err_str(why));
	return rc == TOOL_OK ? 0 : -1;
}

static const char *const fx_names[] = { "swell_bias", "swell_pull", "swell_push", "swell_damp", "swell_weight" };
#define FX_N (sizeof(fx_names) / sizeof(fx_names[0]))

static void check_effects(struct tally *t, const struct tool_check_opts *co, unsigned state)
{
	char req[400] = "", ans[HM_TEXT_MAX], part[64], err[160], left[200] = "";
	size_t k;

	for (k = 0; k < FX_N; k++)
		snprintf(req + strlen(req), sizeof(req) - strlen(req), "%sget %s enabled", k ? ";" : "", fx_names[k]);
	if (tool_hm_ask(co->hm, req, ans, sizeof(ans), co->timeout_ms, err, sizeof(err)) < 0) {
		line(t, "FAIL", "effects",
		     "cannot ask the device (%s): fix: check --hm HOST[:PORT], the "
		     "device's own interface (port 7654)",
		     err);
		return;
	}
	for (k = 0; k < FX_N; k++) {
		answer_part(ans, (int)k, part, sizeof(part));
		if (!strcmp(part, "true"))
			snprintf(left + strlen(left), sizeof(left) - strlen(left), "%s%s", left[0] ? ", " : "",
				 fx_names[k]);
	}
	if (state == SWELL_CTL_RUNNING)
		line(t, "ok", "effects", "swell's effects on the device while the force law runs: %s",
		     left[0] ? left : "none");
	else if (!left[0])
		line(t, "ok", "effects", "none of swell's effects enabled on the device");
	else if (!strcmp(left, "swell_bias")) {
		/* the stream mode's bias stays enabled between runs; only a force in it is left over */
		char f[64];

		if (tool_hm_ask(co->hm, "get swell_bias force", ans, sizeof(ans), co->timeout_ms, err, sizeof(err)) ==
			    0 &&
		    (answer_part(ans, 0, f, sizeof(f)), !strcmp(f, "[0,0,0]")))
			line(t, "ok", "effects",
			     "swell_bias enabled with zero force (the stream mode's, between runs)");
		else
			line(t, "FAIL", "effects",
			     "swell_bias left with a force (%s) while the force law is off: fix: restart swell-ctl "
			     "(its start-up and exit remove swell's effects) or 'remove swell_bias' on the device",
			     f);
	} else
		line(t, "FAIL", "effects",
		     "left enabled on the device while the force law is off: %s (the effect mode's springs stay "
		     "on after a lost connection): fix: restart swell-ctl or swell-hmbridge (their start-up and "
		     "exit remove them), or 'remove all' on the device, before holding the handle",
		     left);
}

int tool_check(struct tool_session *s, enum tool_rc open_rc, const char *open_err, const struct tool_check_opts *co)
{
	static const char *const names[] = {
		"controller", "device", "round trip", "frame", "force", "e-stop", "effects"
	};
	struct tally t = { 0, 0, 0 };
	char err[200], fw[24] = "?";
	int32_t v = 0, st = 0, rate = 0, tick = 0, fmax = 0, frate = 0, mode = 0;
	int have_status = 0, heard, k, r;
	unsigned state;

	if (open_rc != TOOL_OK) {
		line(&t, "FAIL", "link",
		     "%s: fix: start swell-ctl (or power the board); CAN: ip link set can0 up type can bitrate "
		     "1000000, 120 ohm at each end; USB: the cable",
		     open_err);
		for (k = 0; k < (int)(sizeof(names) / sizeof(names[0])); k++)
			line(&t, "skip", names[k], "no controller to ask");
		printf("check: %d passed, %d failed, %d skipped\n", t.ok, t.failed, t.skipped);
		return TOOL_CHECK_FAILED;
	}
	line(&t, "ok", "link", "controller node %d heard on %s", s->node, co->link);
	tool_wait_full(s, 11 * co->timeout_ms / 10 + 1200); /* scene and info come at 1 Hz */
	tool_pump(s, 60); /* a pose (100 Hz) */
	state = s->t.hb.state;
	if (s->t.have_info)
		snprintf(fw, sizeof(fw), "%u.%u.%u", s->t.info.fw_major, s->t.info.fw_minor, s->t.info.fw_patch);

	/* controller: the protocol this tool speaks, its firmware, its state */
	if (s->t.hb.version != SWELL_PROTO_VERSION)
		line(&t, "FAIL", "controller",
		     "protocol version %u, this swell-tool speaks %u: fix: the same swell release on both sides "
		     "(swell-flash the image, or this tool's build)",
		     s->t.hb.version, SWELL_PROTO_VERSION);
	else if (state == SWELL_CTL_FAULT)
		line(&t, "FAIL", "controller",
		     "firmware %s, state fault (last error: %s): fix: remove the cause (below), then swell-tool "
		     "clear",
		     fw, swell_err_str((enum swell_err)s->t.hb.err));
	else if (state == SWELL_CTL_BOOT)
		line(&t, "FAIL", "controller", "firmware %s, still booting: fix: wait a second and check again", fw);
	else
		line(&t, "ok", "controller", "protocol %u, firmware %s, state %s", s->t.hb.version, fw,
		     swell_state_name(state));

	/* device: heard (the controller leaves IDLE once it is; in FAULT its rate tells), its rate and
	 * status bits */
	r = param(s, "dev.status", co, &st, err, sizeof(err));
	have_status = r == 0;
	if (r == 0)
		r = param(s, "dev.rate", co, &rate, err, sizeof(err));
	if (r == 0)
		r = param(s, "ctl.tick_hz", co, &tick, err, sizeof(err));
	if (r == 0)
		r = param(s, "force.mode", co, &mode, err, sizeof(err));
	heard = state == SWELL_CTL_ARMED || state == SWELL_CTL_RUNNING ||
		(state == SWELL_CTL_FAULT && r == 0 && rate > 0);
	if (r < 0) {
		line(&t, "FAIL", "device", "cannot read its status: %s", err);
		have_status = 0;
	} else if (!heard)
		line(&t, "FAIL", "device",
		     "not heard (state %s): fix: the device link: swell-ctl --device (hm:HOST for a HapticMaster, "
		     "its address and port 7654), CAN wiring and termination (about 60 ohm from CANH to CANL, "
		     "power off), swell-hmbridge running, the device powered",
		     swell_state_name(state));
	else if (r == 1)
		line(&t, "ok", "device", "heard (state %s); rate and status not reported by this controller",
		     swell_state_name(state));
	else if (rate * (mode ? 20 : 2) < tick) /* stream: every tick; effect: once an update, 1/10 of them */
		line(&t, "FAIL", "device",
		     "heard at %ld Hz, the controller ticks at %ld Hz: fix: a slow or lossy device link (swell-ctl's "
		     "report counts lost samples; hm: round trips above a tick)",
		     (long)rate, (long)tick);
	else if (!(st & SWELL_DEV_POWERED) || (st & SWELL_DEV_FAULT))
		line(&t, "FAIL", "device",
		     "heard at %ld Hz but not ready (status 0x%lx: not powered, not in its force state or in "
		     "fault): fix: power the device; hm: swell-ctl's log says why its start-up stopped",
		     (long)rate, (long)st);
	else
		line(&t, "ok", "device", "heard at %ld Hz (tick %ld Hz), status 0x%lx (powered%s)", (long)rate,
		     (long)tick, (long)st, st & SWELL_DEV_FORCE_ON ? ", force on" : "");

	/* round trip: the fastest of five parameter reads */
	{
		const struct swell_param_desc *d = swell_param_by_id(SWELL_PARAM_FORCE_MAX_UN);
		double best = 1e9, worst = 0;
		int n = 0;

		for (k = 0; k < 5; k++) {
			enum swell_err why = SWELL_OK;
			const uint64_t t0 = swell_link_now_ns();

			double ms;

			if (tool_request(s, 0, d->id, 0, co->timeout_ms, &v, &why, err, sizeof(err)) != TOOL_OK)
				continue;
			ms = (double)(swell_link_now_ns() - t0) / 1e6;
			best = ms < best ? ms : best;
			worst = ms > worst ? ms : worst;
			n++;
		}
		if (n == 0)
			line(&t, "FAIL", "round trip", "no answer to a parameter read: %s", err);
		else if (best > co->max_rtt_ms)
			line(&t, "FAIL", "round trip",
			     "%.2f ms at best (%.2f ms worst), above %.2f ms: fix: a busy or slow host link (another "
			     "client flooding it, a CAN bus near full: swell-tool watch shows the load)",
			     best, worst, co->max_rtt_ms);
		else
			line(&t, "ok", "round trip", "%.2f ms at best, %.2f ms worst of %d", best, worst, n);
	}

	/* frame: the handle's place in the pool, from the device's position through the controller's frame
	 * (the pose's wire field stops at 300 mm: not enough for a pool's far side) */
	{
		static const char *const fp[] = { "frame.x0",   "frame.y0", "frame.z0", "frame.scale", "frame.axes",
						  "frame.flip", "dev.x",    "dev.y",    "dev.z" };
		int32_t f[9];
		int bad = 0;

		for (k = 0; k < 9 && !bad; k++)
			bad = param(s, fp[k], co, &f[k], err, sizeof(err)) != 0;
		if (!heard || bad || !s->t.have_scene)
			line(&t, "skip", "frame", "%s",
			     !heard        ? "no device heard"
				     : bad ? "no frame from this controller"
					   : "no scene heard yet");
		else {
			const int axis[3] = { f[4] / 100 - 1, f[4] / 10 % 10 - 1, f[4] % 10 - 1 };
			double pool[3];
			const double lx = s->t.scene.nx * s->t.scene.dx_um * 1e-3,
				     ly = s->t.scene.ny * s->t.scene.dx_um * 1e-3;

			for (k = 0; k < 3; k++)
				pool[k] = f[k] * 1e-3 +
					((f[5] >> k & 1) ? -1.0 : 1.0) * (f[3] / 65536.0) *
						(axis[k] >= 0 && axis[k] < 3 ? f[6 + axis[k]] * 1e-3 : 0.0);
			if (pool[0] < 0 || pool[0] > lx || pool[1] < 0 || pool[1] > ly)
				line(&t, "FAIL", "frame",
				     "the handle (device %.1f, %.1f, %.1f mm) is at pool x %.1f, y %.1f mm, "
				     "outside the pool's 0..%.0f x 0..%.0f mm: fix: move the handle over the "
				     "water, or place the pool in the device's workspace with frame.x0 / "
				     "frame.y0 / frame.axes (docs/frame.md)",
				     f[6] * 1e-3, f[7] * 1e-3, f[8] * 1e-3, pool[0], pool[1], lx, ly);
			else
				line(&t, "ok", "frame",
				     "the handle (device %.1f, %.1f, %.1f mm) is at pool x %.1f, y %.1f, z %+.1f "
				     "mm (pool 0..%.0f x 0..%.0f mm, z 0 the rest level)",
				     f[6] * 1e-3, f[7] * 1e-3, f[8] * 1e-3, pool[0], pool[1], pool[2], lx, ly);
		}
	}

	/* force limits: at most the first-run ones unless told otherwise */
	if (param(s, "force.max", co, &fmax, err, sizeof(err)) != 0 ||
	    param(s, "force.rate", co, &frate, err, sizeof(err)) != 0)
		line(&t, "FAIL", "force", "cannot read the limits: %s", err);
	else if (fmax * 1e-6 > co->max_force_N + 1e-9 || frate * 1e-6 > co->max_rate_N_s + 1e-9)
		line(&t, "FAIL", "force",
		     "force.max %.3g N, force.rate %.3g N/s, above %.3g N, %.3g N/s: fix: for a first contact "
		     "swell-tool set force.max %gN and set force.rate %gN/s; to accept more on purpose, "
		     "check --max-force N --max-rate N/s",
		     fmax * 1e-6, frate * 1e-6, co->max_force_N, co->max_rate_N_s, co->max_force_N, co->max_rate_N_s);
	else
		line(&t, "ok", "force", "force.max %.3g N, force.rate %.3g N/s (at most %.3g N, %.3g N/s)", fmax * 1e-6,
		     frate * 1e-6, co->max_force_N, co->max_rate_N_s);

	/* e-stop: the device's own (--hm), else its status bit, else the controller's fault */
	{
		char ans[HM_TEXT_MAX], part[32];
		int pushed = -1;

		if (co->hm &&
		    tool_hm_ask(co->hm, "get emergencybuttonpushed;get position_calibrated;get force_calibrated", ans,
				sizeof(ans), co->timeout_ms, err, sizeof(err)) == 0) {
			char pc[32], fc[32];

			answer_part(ans, 0, part, sizeof(part));
			answer_part(ans, 1, pc, sizeof(pc));
			answer_part(ans, 2, fc, sizeof(fc));
			pushed = !strcmp(part, "true");
			if (strcmp(pc, "true") || strcmp(fc, "true"))
				line(&t, "FAIL", "calibration",
				     "the device reports position calibrated '%s', force sensor calibrated '%s': "
				     "fix: calibrate it with the vendor's tools (handle free); swell's start-up "
				     "inits it and gives no force until both are true",
				     pc, fc);
			else
				line(&t, "ok", "calibration",
				     "position and force sensor calibrated (asked the device)");
		} else if (!co->hm && have_status && heard) {
			pushed = (st & SWELL_DEV_ESTOP) != 0;
		}
		if (pushed < 0 && state == SWELL_CTL_FAULT && s->t.hb.err == SWELL_ESTOP)
			pushed = 1;
		if (pushed > 0)
			line(&t, "FAIL", "e-stop",
			     "%s: fix: release the device's e-stop (then swell-tool clear if the controller faulted)",
			     co->hm ? "the device says its emergency button is pushed"
				    : "the device reports an e-stop (or that it is not rendering)");
		else if (pushed == 0)
			line(&t, "ok", "e-stop", "released%s", co->hm ? " (asked the device)" : "");
		else if (co->hm)
			line(&t, "FAIL", "e-stop", "cannot ask the device: %s: fix: check --hm HOST[:PORT]", err);
		else
			line(&t, "skip", "e-stop", "no device status heard; --hm HOST asks a HapticMaster itself");
	}

	if (co->hm)
		check_effects(&t, co, state);
	else
		line(&t, "skip", "effects", "needs --hm HOST[:PORT] (the HapticMaster's own interface, read only)");
	printf("check: %d passed, %d failed, %d skipped\n", t.ok, t.failed, t.skipped);
	return t.failed ? TOOL_CHECK_FAILED : TOOL_OK;
}
