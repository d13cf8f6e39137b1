/* A HapticMaster client on its TCP command interface; see hm_client.h. */
#define _GNU_SOURCE
#include "hm_client.h"

#include "swell/hm_frame.h"
#include "swell/link.h"
#include "swell/num.h"
#include "swell/proto.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#define BIAS "swell_bias"
/* Every effect swell creates (the stream mode's bias, the effect mode's springs, damper and weight) */
#define REMOVE_ALL "remove " BIAS ";" HMC_FX_REMOVE
#define REMOVE_N 5

enum {
	KIND_TICK,
	KIND_START, /* 3: force state and the zero bias, every answer a success */
	KIND_ZERO, /* answers not looked at */
	KIND_CHECKED, /* every answer must be a success */
	KIND_PROBE, /* 1: e-stop and state, before anything is changed */
	KIND_INIT /* 2: swell's effects removed, init, then both calibrations read */
};

/* The start-up, three requests, each sent once the previous one's answers are understood and good:
 * nothing that can produce a force goes out before the e-stop is seen released and the device reports
 * itself calibrated after init; a refusal holds off HMC_RETRY_MS and starts again at the probe. */
static const char probe_text[] = "get emergencybuttonpushed;get state";
static const char init_text[] = REMOVE_ALL ";set state init;get position_calibrated;get force_calibrated";
static const char start_text[] =
	"set state force;create biasforce " BIAS ";set " BIAS " force [0,0,0];set " BIAS " enable";

#define now_ns() ((int64_t)swell_link_now_ns())

const char *hm_client_phase_name(enum hmc_phase p)
{
	static const char *const n[] = { "down", "connecting", "starting", "running", "holding off" };

	return (unsigned)p < sizeof(n) / sizeof(n[0]) ? n[p] : "?";
}

int hm_client_parse_fixed(const char **s, int scale, int32_t limit, int32_t *out)
{
	const char *p = *s;
	uint64_t mant = 0, q, r, pow = 1;
	int neg = 0, digits = 0, exp10 = 0, any = 0, dot = 0, e;

	if (*p == '-' || *p == '+')
		neg = *p++ == '-';
	for (;; p++) { /* the digits, one '.' among them */
		if (*p == '.' && !dot) {
			dot = 1;
			continue;
		}
		if (*p < '0' || *p > '9')
			break;
		any = 1;
		if (digits < 18) {
			mant = mant * 10u + (uint64_t)(*p - '0');
			digits += mant != 0;
			exp10 -= dot;
		} else {
			exp10 += !dot; /* digits past 18 only scale */
		}
	}
	if (!any)
		return -1;
	if ((*p == 'e' || *p == 'E') && (p[1] == '-' || p[1] == '+' || (p[1] >= '0' && p[1] <= '9'))) {
		const char *x = p + 1;
		int eneg = 0, ev = 0;

		if (*x == '-' || *x == '+')
			eneg = *x++ == '-';
		if (*x >= '0' && *x <= '9') {
			for (; *x >= '0' && *x <= '9'; x++)
				ev = ev < 1000 ? ev * 10 + (*x - '0') : ev;
			exp10 += eneg ? -ev : ev;
			p = x;
		}
	}
	e = exp10 + scale;
	if (mant == 0) {
		q = 0;
	} else if (e >= 0) {
		q = mant;
		for (; e > 0 && q <= (uint64_t)limit; e--)
			q *= 10u;
	} else if (e < -19) {
		q = 0;
	} else {
		for (; e < 0; e++)
			pow *= 10u;
		q = mant / pow;
		r = mant % pow;
		if (r >= pow - r) /* r >= pow / 2 without rounding pow: half away from zero */
			q++;
	}
	if (q > (uint64_t)limit)
		q = (uint64_t)limit;
	*out = neg ? -(int32_t)q : (int32_t)q;
	*s = p;
	return 0;
}

size_t hm_client_fmt_fixed(char *b, size_t cap, int64_t v, int decimals)
{
	static const uint64_t scale[] = { 1, 10, 100, 1000, 10000, 100000 };
	const uint64_t a = v < 0 ? (uint64_t)(-v) : (uint64_t)v, d = scale[decimals];
	const int n = snprintf(b, cap, "%s%llu.%0*llu", v < 0 ? "-" : "", (unsigned long long)(a / d), decimals,
			       (unsigned long long)(a % d));

	return n < 0 || (size_t)n >= cap ? cap : (size_t)n;
}

double hm_hist_pct(const uint32_t *hist, int last, uint64_t n, double p)
{
	const double x = p * (double)n;
	uint64_t want = (uint64_t)x, seen = 0;
	int k;

	want += (double)want < x; /* rounded up */
	for (k = 0; k <= last; k++) {
		seen += hist[k];
		if (want > 0 && seen >= want)
			return k;
	}
	return 0;
}

/* A device node's acceptance filter on classic CAN: the messages the controller sends the device, and
 * the controller's heartbeat. A device's CAN controller filters so too; without it the socket queued
 * the whole bus (the host link's telemetry on a shared bus, a third node's flood), and a device process
 * a loaded machine left unscheduled for 0.3 s lost commands when that queue overflowed. */
static size_t device_filters(struct swell_can_filter *f, size_t cap)
{
	size_t n = 0;

	for (unsigned i = 0; i < swell_msg_desc_count && n < cap; i++) {
		const struct swell_msg_desc *d = &swell_msg_descs[i];

		if (!strcmp(d->to, "DEV") || d->type == SWELL_MSG_HEARTBEAT)
			f[n++] = (struct swell_can_filter){ SWELL_CAN_ID(d->type, 0), 0x7F0u };
	}
	return n;
}

struct swell_link *hm_node_open(const struct swell_link_spec *spec, unsigned port, unsigned iface, const char *host,
				unsigned bind_port, const char *prog, const char *what)
{
	struct swell_can_filter flt[16];
	const size_t nflt = device_filters(flt, sizeof(flt) / sizeof(flt[0]));
	const struct swell_link_open_opts uo = {
		.udp_host = host, .udp_bind_port = (uint16_t)bind_port, .can_filters = flt, .can_nfilters = nflt
	};
	struct swell_link_spec ls = *spec;
	struct swell_link *l = NULL;
	int rc;

	ls.port = (uint16_t)port;
	ls.iface = (uint8_t)iface;
	rc = swell_link_open_spec(&l, &ls, &uo);
	if (rc < 0)
		fprintf(stderr, "%s: cannot open link %s: %s\n", prog, what, strerror(-rc));
	return rc < 0 ? NULL : l;
}

uint32_t hm_node_send(struct swell_link *l, uint8_t node, uint8_t seq, const struct swell_msg *m, size_t n)
{
	struct swell_frame f;
	uint32_t errors = 0;
	size_t used;

	while (n > 0) {
		if (swell_link_encode(swell_link_carrier(l), node, seq, m, n, &f, &used) != SWELL_OK || used == 0)
			return errors + 1;
		errors += swell_link_send(l, &f) < 0;
		m += used;
		n -= used;
	}
	return errors;
}

/* "[a,b,c]" into three fixed-point integers; *s moves past it. */
static int parse_vec3(const char **s, int scale, int32_t limit, int32_t v[3])
{
	const char *p = *s;
	int k;

	while (*p == ' ' || *p == '"')
		p++;
	if (*p++ != '[')
		return -1;
	for (k = 0; k < 3; k++) {
		while (*p == ' ')
			p++;
		if (hm_client_parse_fixed(&p, scale, limit, &v[k]) < 0)
			return -1;
		while (*p == ' ')
			p++;
		if (*p++ != (k < 2 ? ',' : ']'))
			return -1;
	}
	while (*p == ' ' || *p == '"')
		p++;
	*s = p;
	return 0;
}

/* The phase p until HMC_RETRY_MS from now. */
static void hold(struct hm_client *c, enum hmc_phase p)
{
	c->phase = p;
	c->retry_at_ns = now_ns() + (int64_t)HMC_RETRY_MS * 1000000;
}

static void disconnect(struct hm_client *c, int counted_reset)
{
	if (c->fd >= 0)
		close(c->fd);
	c->fd = -1;
	c->st.lost += c->ring_n;
	c->ring_n = 0;
	c->in_len = c->out_len = 0;
	c->st.resets += counted_reset != 0;
	hold(c, HMC_DOWN);
	c->status = 0;
}

static void start_connect(struct hm_client *c)
{
	int one = 1;

	c->fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (c->fd < 0) {
		hold(c, HMC_DOWN);
		return;
	}
	setsockopt(c->fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
	if (connect(c->fd, (const struct sockaddr *)&c->addr, sizeof(c->addr)) == 0 || errno == EINPROGRESS) {
		c->phase = HMC_CONNECTING;
		return;
	}
	disconnect(c, 0);
}

int hm_client_open(struct hm_client *c, const char *spec, uint32_t max_age_ticks, char *err, size_t errlen)
{
	char host[64];
	const char *colon = strrchr(spec, ':');
	long port = HMC_PORT;
	size_t hl = colon ? (size_t)(colon - spec) : strlen(spec);

	memset(c, 0, sizeof(*c));
	c->fd = -1;
	c->max_age_ticks = max_age_ticks ? max_age_ticks : 1;
	if (hl == 0 || hl >= sizeof(host)) {
		snprintf(err, errlen, "hm:%s: want hm:HOST[:PORT]", spec);
		return -1;
	}
	memcpy(host, spec, hl);
	host[hl] = '\0';
	if (colon && swell_parse_long(colon + 1, 10, 1, 65535, &port) < 0) {
		snprintf(err, errlen, "hm:%s: port '%s' is not a number in [1, 65535]", spec, colon + 1);
		return -1;
	}
	c->addr.sin_family = AF_INET;
	c->addr.sin_port = htons((uint16_t)port);
	if (inet_pton(AF_INET, host, &c->addr.sin_addr) != 1) {
		const struct addrinfo hints = { .ai_family = AF_INET, .ai_socktype = SOCK_STREAM };
		struct addrinfo *res = NULL;

		if (getaddrinfo(host, NULL, &hints, &res) != 0 || !res) {
			snprintf(err, errlen, "hm:%s: cannot resolve '%s'", spec, host);
			return -1;
		}
		c->addr.sin_addr = ((const struct sockaddr_in *)(const void *)res->ai_addr)->sin_addr;
		freeaddrinfo(res);
	}
	snprintf(c->name, sizeof(c->name), "hm:%s:%ld", host, port);
	start_connect(c);
	return 0;
}

/* Writes what is queued; -1 when the connection failed. */
static int flush(struct hm_client *c)
{
	size_t sent;

	return swell_hm_frame_flush(c->fd, c->out, &c->out_len, c->out_len, &sent);
}

/* Queues a framed request and notes it in flight; -1 when there is no room (nothing queued). */
static int request(struct hm_client *c, int kind, const char *text, size_t n)
{
	unsigned slot;

	if (c->ring_n >= HMC_RING || swell_hm_frame_put(c->out, sizeof(c->out), &c->out_len, text, n) < 0)
		return -1;
	slot = (c->ring_head + c->ring_n) % HMC_RING;
	c->ring_kind[slot] = (uint8_t)kind;
	c->ring_tick[slot] = c->tick;
	c->ring_ns[slot] = now_ns();
	c->ring_n++;
	if (c->ring_n > c->st.max_inflight)
		c->st.max_inflight = c->ring_n;
	if (flush(c) < 0) {
		disconnect(c, 1);
		return -1;
	}
	return 0;
}

static void startup(struct hm_client *c)
{
	if (c->cleanup && request(c, KIND_ZERO, c->cleanup, strlen(c->cleanup)) < 0)
		return; /* no room: the next retry */
	if (request(c, KIND_PROBE, probe_text, sizeof(probe_text) - 1) == 0) {
		c->phase = HMC_STARTING;
		c->st.startups++;
	}
}

/* The start-up stops here: why, kept for the program's log (refusal_seq counts changes of reason), and
 * the next attempt after the pause. */
static void refuse(struct hm_client *c, const char *why)
{
	c->st.startup_failures++;
	if (strcmp(c->refusal, why) != 0) {
		snprintf(c->refusal, sizeof(c->refusal), "%s", why);
		c->refusal_seq++;
	}
	hold(c, HMC_HOLDOFF);
}

void hm_client_force(struct hm_client *c, const int16_t f_cN[3], int enable)
{
	char text[HMC_TEXT_MAX], f[3][16];
	/* zero until the start-up has found the e-stop released and the device calibrated (RUNNING) */
	int n, k, zero = !enable || c->phase != HMC_RUNNING || (f_cN[0] == 0 && f_cN[1] == 0 && f_cN[2] == 0);

	c->tick++;
	if (c->phase == HMC_DOWN || c->phase == HMC_CONNECTING)
		return;
	/* an answer to a request sent behind max_age_ticks others would be stale on arrival: do not
	 * deepen the pipeline, let it drain; only a change to zero force always goes */
	if (c->ring_n > c->max_age_ticks && !(zero && !c->sent_zero)) {
		c->st.skipped++;
		return;
	}
	for (k = 0; k < 3; k++)
		hm_client_fmt_fixed(f[k], sizeof(f[k]), zero ? 0 : f_cN[k], 2); /* "-1.23" from -123 cN */
	n = snprintf(text, sizeof(text), "set " BIAS " force [%s,%s,%s];get measpos;get modelvel;get state%s%s", f[0],
		     f[1], f[2], c->extra[0] ? ";" : "", c->extra);
	c->extra[0] = '\0';
	if (n < 0 || (size_t)n >= sizeof(text) || request(c, KIND_TICK, text, (size_t)n) < 0) {
		c->st.skipped += c->fd >= 0;
	} else {
		c->st.requests++;
		c->sent_zero = zero;
	}
}

int hm_client_set_extra(struct hm_client *c, const char *cmds)
{
	size_t n = strlen(cmds);

	if (n >= sizeof(c->extra))
		return -1;
	memcpy(c->extra, cmds, n + 1);
	return 0;
}

int hm_client_request(struct hm_client *c, const char *text, int checked)
{
	if (c->fd < 0 || c->phase == HMC_DOWN || c->phase == HMC_CONNECTING)
		return -1;
	return request(c, checked ? KIND_CHECKED : KIND_ZERO, text, strlen(text));
}

/* The i-th ';'-separated part of text (length n) */
static const char *part(const char *text, int i)
{
	for (; i > 0; i--) {
		text = strchr(text, ';');
		if (!text)
			return NULL;
		text++;
	}
	while (*text == ' ')
		text++;
	return text;
}

static uint8_t status_of_state(const char *st)
{
	size_t n = strcspn(st, ";");

	while (n > 0 && (st[n - 1] == ' ' || st[n - 1] == '"'))
		n--;
	if (*st == '"') {
		st++;
		n = n ? n - 1 : 0;
	}
	if (n == 5 && !strncmp(st, "force", 5))
		return SWELL_DEV_POWERED | SWELL_DEV_FORCE_ON;
	if (n == 3 && !strncmp(st, "off", 3))
		return 0u;
	return SWELL_DEV_POWERED | SWELL_DEV_ESTOP; /* stop (e-stop), init, home, position: not rendering our force */
}

/* Part i of an answer is "true" (a boolean get's answer, maybe quoted). */
static int part_true(const char *text, int i)
{
	const char *p = part(text, i);

	while (p && *p == '"')
		p++;
	return p && !strncmp(p, "true", 4);
}

/* Part i of an answer exists and is not an error. */
static int part_ok(const char *text, int i)
{
	const char *p = part(text, i);

	return p && *p && strncmp(p, "---", 3) != 0;
}

/* An answer to one of the start-up's three requests: the next request, RUNNING, or a refusal. */
static void startup_answer(struct hm_client *c, int kind, const char *text)
{
	static const int16_t none[3] = { 0, 0, 0 };
	char req[sizeof(init_text) + 40], kg[24];
	int n;

	if (kind == KIND_PROBE && (!part_ok(text, 0) || !part_ok(text, 1))) {
		refuse(c, "the device did not answer 'get emergencybuttonpushed;get state'");
	} else if (kind == KIND_PROBE && part_true(text, 0)) {
		refuse(c, "the device's e-stop is pushed: no force until it is released");
	} else if (kind == KIND_PROBE) {
		/* the inertia swell's force law is tuned for, after the calibrations are read */
		hm_client_fmt_fixed(kg, sizeof(kg), c->inertia_g, 3);
		n = snprintf(req, sizeof(req), "%s%s%s", init_text, c->inertia_g ? ";set inertia " : "",
			     c->inertia_g ? kg : "");
		if (n < 0 || (size_t)n >= sizeof(req) || request(c, KIND_INIT, req, (size_t)n) < 0)
			refuse(c, "no room for the start-up request");
	} else if (kind == KIND_INIT) {
		/* the removes may fail (nothing of swell's was there); init must not */
		if (!part_ok(text, REMOVE_N))
			refuse(c, "the device refused 'set state init' (e-stop, or its own fault)");
		else if (!part_true(text, REMOVE_N + 1))
			refuse(c,
			       "the device's position is not calibrated after init: calibrate it with the "
			       "vendor's tools");
		else if (!part_true(text, REMOVE_N + 2))
			refuse(c,
			       "the device's force sensor is not calibrated after init: calibrate it (handle "
			       "free) with the vendor's tools");
		else if (c->inertia_g && !part_ok(text, REMOVE_N + 3))
			refuse(c, "the device refused 'set inertia' (hm.inertia)");
		else if (request(c, KIND_START, start_text, sizeof(start_text) - 1) < 0)
			refuse(c, "no room for the start-up request");
	} else if (!part_ok(text, 0) || !part_ok(text, 1) || !part_ok(text, 2) || !part_ok(text, 3)) {
		refuse(c, "the device refused the force state or swell's zero bias force");
	} else {
		c->phase = HMC_RUNNING;
		c->refusal[0] = '\0';
		/* a first sample at once: a controller clocked by the device ticks on it */
		c->tick--;
		hm_client_force(c, none, 0);
	}
}

/* One answer of len bytes; may write a sample into out. Returns messages written. */
static size_t answer(struct hm_client *c, char *text, struct swell_msg *out, size_t cap, uint8_t node)
{
	unsigned slot = c->ring_head;
	int kind = c->ring_kind[slot];
	uint32_t age = c->tick - c->ring_tick[slot];
	int64_t rtt = now_ns() - c->ring_ns[slot];
	const char *p1, *p2, *p3;
	int32_t pos[3], vel[3];
	uint8_t status;
	int err;

	c->ring_head = (c->ring_head + 1) % HMC_RING;
	c->ring_n--;
	c->st.answers++;
	c->st.rtt_ns_sum += (uint64_t)rtt;
	if ((uint64_t)rtt > c->st.rtt_ns_max)
		c->st.rtt_ns_max = (uint64_t)rtt;
	c->st.rtt_hist[rtt / 1000 > HMC_RTT_US ? HMC_RTT_US : rtt / 1000]++;
	if (kind == KIND_PROBE || kind == KIND_INIT || kind == KIND_START) {
		startup_answer(c, kind, text);
		return 0;
	}
	if (kind == KIND_CHECKED && strstr(text, "---")) {
		c->st.error_answers++;
		c->fault_next = 1;
	}
	if (kind != KIND_TICK)
		return 0;
	p1 = part(text, 1);
	p2 = part(text, 2);
	p3 = part(text, 3);
	if (!p1 || !p2 || !p3 || parse_vec3(&p1, 5, 30000, pos) < 0 || parse_vec3(&p2, 4, 30000, vel) < 0) {
		c->st.garbage++;
		return 0;
	}
	status = status_of_state(p3);
	err = !strncmp(text, "---", 3) || strstr(p3, "---");
	if (err || c->fault_next) { /* a checked request's error answer was counted with it */
		c->st.error_answers += (uint32_t)err;
		c->fault_next = 0;
		status = (uint8_t)((status & ~SWELL_DEV_FORCE_ON) | SWELL_DEV_ESTOP | SWELL_DEV_FAULT);
	}
	c->status = status;
	if (!(status & SWELL_DEV_FORCE_ON) && c->phase == HMC_RUNNING) {
		/* stopped by someone else, e-stop, or our effect is gone: start again after a pause */
		c->st.not_force++;
		hold(c, HMC_HOLDOFF);
	}
	c->st.late += age > c->max_age_ticks;
	if (age > c->max_age_ticks || cap < 2)
		return 0;
	memset(out, 0, 2 * sizeof(*out));
	out[0].type = SWELL_MSG_DEVICE_VEL;
	out[0].node = node;
	out[0].u.device_vel.vx_100ums = (int16_t)vel[0];
	out[0].u.device_vel.vy_100ums = (int16_t)vel[1];
	out[0].u.device_vel.vz_100ums = (int16_t)vel[2];
	out[0].u.device_vel.seq = c->seq;
	out[1].type = SWELL_MSG_DEVICE_POS;
	out[1].node = node;
	out[1].u.device_pos.x_10um = (int16_t)pos[0];
	out[1].u.device_pos.y_10um = (int16_t)pos[1];
	out[1].u.device_pos.z_10um = (int16_t)pos[2];
	out[1].u.device_pos.seq = c->seq++;
	out[1].u.device_pos.status = status;
	c->st.samples++;
	return 2;
}

size_t hm_client_poll(struct hm_client *c, struct swell_msg *out, size_t cap, uint8_t node)
{
	size_t n = 0;
	int rounds;

	if (c->phase == HMC_DOWN) {
		if (now_ns() >= c->retry_at_ns)
			start_connect(c);
		return 0;
	}
	if (c->phase == HMC_CONNECTING) {
		struct pollfd pf = { c->fd, POLLOUT, 0 };
		int e = 0;
		socklen_t el = sizeof(e);

		if (poll(&pf, 1, 0) <= 0)
			return 0;
		if (getsockopt(c->fd, SOL_SOCKET, SO_ERROR, &e, &el) < 0 || e != 0) {
			disconnect(c, 0);
			return 0;
		}
		c->st.connects++;
		startup(c);
		return 0;
	}
	if (c->phase == HMC_HOLDOFF && now_ns() >= c->retry_at_ns)
		startup(c);
	if (flush(c) < 0) {
		disconnect(c, 1);
		return 0;
	}
	for (rounds = 0; rounds < 8; rounds++) { /* bounded: a flood of answers cannot hold the tick */
		ssize_t r;

		if (c->in_len < sizeof(c->in)) {
			r = recv(c->fd, c->in + c->in_len, sizeof(c->in) - c->in_len, MSG_DONTWAIT);
			if (r == 0 || (r < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
				disconnect(c, 1);
				return n;
			}
			if (r > 0)
				c->in_len += (size_t)r;
		}
		while (c->in_len >= SWELL_HM_FRAME_HDR) {
			uint32_t len;
			const int whole = swell_hm_frame_next(c->in, c->in_len, HMC_TEXT_MAX, &len, NULL);
			char text[HMC_TEXT_MAX + 1];

			if (whole < 0 || c->ring_n == 0) {
				/* not an answer to anything we asked: the stream cannot be trusted any more */
				c->st.garbage++;
				disconnect(c, 1);
				return n;
			}
			if (!whole)
				break;
			memcpy(text, c->in + SWELL_HM_FRAME_HDR, len);
			text[len] = '\0';
			swell_hm_frame_pop(c->in, &c->in_len, len);
			n += answer(c, text, out + n, cap - n, node);
		}
		if (c->in_len < sizeof(c->in)) {
			struct pollfd pf = { c->fd, POLLIN, 0 };

			if (poll(&pf, 1, 0) <= 0)
				break;
		}
	}
	return n;
}

int hm_client_zero_wait(struct hm_client *c, int wait_ms)
{
	static const char zero[] = "set " BIAS " force [0,0,0];" REMOVE_ALL;
	int64_t end = now_ns() + (int64_t)wait_ms * 1000000;
	uint32_t want;

	if (c->fd < 0 || c->phase == HMC_CONNECTING || c->phase == HMC_DOWN)
		return -1;
	if (request(c, KIND_ZERO, zero, sizeof(zero) - 1) < 0)
		return -1;
	want = c->st.answers + c->ring_n; /* every request before it, then the zero's answer */
	while (c->fd >= 0 && c->st.answers < want && now_ns() < end) {
		struct swell_msg m[2 * HMC_RING];
		struct pollfd pf = { c->fd, (short)(POLLIN | (c->out_len ? POLLOUT : 0)), 0 };

		poll(&pf, 1, 1);
		if (flush(c) < 0)
			disconnect(c, 1);
		else
			hm_client_poll(c, m, sizeof(m) / sizeof(m[0]), 0);
	}
	return c->fd >= 0 && c->st.answers >= want ? 0 : -1;
}

void hm_client_report(const struct hm_client *c, FILE *f)
{
	const struct hmc_stats *s = &c->st;

	fprintf(f,
		"  hm link         %s: %s; %u requests, %u answers, %u samples; %u late (older than %u ticks, "
		"dropped), %u lost in resets, %u not sent (%u in flight), %u error answers, %u not understood\n",
		c->name, hm_client_phase_name(c->phase), s->requests, s->answers, s->samples, s->late, c->max_age_ticks,
		s->lost, s->skipped, c->max_age_ticks + 1, s->error_answers, s->garbage);
	fprintf(f, "  hm round trip   p50 %.0f us, p99 %.0f us, max %.0f us, mean %.0f us; most in flight %u\n",
		hm_hist_pct(s->rtt_hist, HMC_RTT_US, s->answers, 0.5),
		hm_hist_pct(s->rtt_hist, HMC_RTT_US, s->answers, 0.99), (double)s->rtt_ns_max / 1e3,
		s->answers ? (double)s->rtt_ns_sum / s->answers / 1e3 : 0.0, s->max_inflight);
	fprintf(f,
		"  hm sessions     %u connections, %u resets, %u start-ups (%u failed), %u times found not in "
		"force\n",
		s->connects, s->resets, s->startups, s->startup_failures, s->not_force);
}

int hm_client_fd(const struct hm_client *c)
{
	return c->phase == HMC_DOWN || c->phase == HMC_CONNECTING ? -1 : c->fd;
}

void hm_client_close(struct hm_client *c)
{
	if (c->fd >= 0)
		close(c->fd);
	c->fd = -1;
	c->phase = HMC_DOWN;
}
