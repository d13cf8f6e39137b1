/* The HapticMaster's command language, emulated; see hm_cmd.h and docs/hapticmaster.md. */
#include "hm_cmd.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LINE_MAX_CHARS 256 /* one command; longer ones are refused whole */

static const char *const state_names[] = { "off", "init", "home", "force", "position", "stop" };
static const char *const kind_names[] = { "spring", "damper", "biasforce" };

const char *hm_dev_state_name(enum hm_dev_state s)
{
	return (unsigned)s < sizeof(state_names) / sizeof(state_names[0]) ? state_names[s] : "?";
}

void hm_dev_init(struct hm_dev *d, double rate_hz, double f_max_N)
{
	int k;

	memset(d, 0, sizeof(*d));
	d->state = HM_STATE_OFF;
	d->rate_hz = rate_hz;
	d->f_max_N = f_max_N;
	d->inertia_kg = 2.0;
	for (k = 0; k < HM_EFFECTS_MAX; k++)
		d->fx[k].owner = -1;
}

/* ---- the reply being written ---- */

struct out {
	char *buf;
	size_t cap, len;
	int full, answers;
};

__attribute__((format(printf, 2, 3))) static void put(struct out *o, const char *fmt, ...)
{
	va_list ap;
	int n;

	if (o->full || o->cap == 0)
		return;
	va_start(ap, fmt);
	n = vsnprintf(o->buf + o->len, o->cap - o->len, fmt, ap);
	va_end(ap);
	if (n < 0 || (size_t)n >= o->cap - o->len)
		o->full = 1;
	else
		o->len += (size_t)n;
}

/* An error answer: counted; the command changed nothing. */
__attribute__((format(printf, 3, 4))) static void fail(struct hm_dev *d, struct out *o, const char *fmt, ...)
{
	char why[160];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(why, sizeof(why), fmt, ap);
	va_end(ap);
	d->errors++;
	put(o, "--- ERROR: %s", why);
}

/* A value of n numbers ("%.9g", more than one as "[a,b,c]"), or with n 0 an int as true or false. */
static void put_value(struct out *o, const void *field, int n)
{
	const double *v = field;
	int k;

	if (n == 0)
		put(o, "%s", *(const int *)field ? "true" : "false");
	for (k = 0; k < n; k++)
		put(o, "%s%.9g", k ? "," : n > 1 ? "[" : "", v[k]);
	if (n > 1)
		put(o, "]");
}

/* ---- values ---- */

/* What get and set name: an effect's parameters (kind: the effect kind that has it, -1 every kind;
 * set: the answer to setting it, NULL when it is read only) and the device's own quantities. n: the
 * numbers in the value, 0 for true or false (an int). */
struct field {
	const char *name;
	int kind, n;
	size_t off; /* in struct hm_effect, or struct hm_dev */
	const char *set;
};

static const struct field params[] = {
	{ "enabled", -1, 0, offsetof(struct hm_effect, enabled), NULL },
	{ "pos", -1, 3, offsetof(struct hm_effect, pos_m), "Effect's position set" },
	{ "vel", -1, 3, offsetof(struct hm_effect, vel_m_s), "Effect's velocity set" },
	{ "att", -1, 4, offsetof(struct hm_effect, att), "Effect's attitude set" },
	{ "stiffness", HM_FX_SPRING, 1, offsetof(struct hm_effect, spring.k_N_m), "Spring's stiffness set" },
	{ "dampfactor", HM_FX_SPRING, 1, offsetof(struct hm_effect, spring.dampfactor), "Spring's damp factor set" },
	{ "deadband", HM_FX_SPRING, 1, offsetof(struct hm_effect, spring.deadband_m), "Spring's deadband set" },
	{ "direction", HM_FX_SPRING, 3, offsetof(struct hm_effect, spring.dir), "Spring's direction set" },
	{ "maxforce", HM_FX_SPRING, 1, offsetof(struct hm_effect, spring.maxforce_N), "Spring's maximum force set" },
	{ "dampglobal", HM_FX_SPRING, 0, offsetof(struct hm_effect, spring.dampglobal), "Spring's damping global set" },
	{ "dampcoef", HM_FX_DAMPER, 3, offsetof(struct hm_effect, dampcoef_Ns_m), "Damper's damp coefficient set" },
	{ "force", HM_FX_BIAS, 3, offsetof(struct hm_effect, force_N), "Bias force's force set" },
};

/* Read by get; "state" and "all" are taken too (valid_name) */
static const struct field quantities[] = {
	{ "measpos", -1, 3, offsetof(struct hm_dev, x_m), NULL },
	{ "modelpos", -1, 3, offsetof(struct hm_dev, x_m), NULL },
	{ "modelvel", -1, 3, offsetof(struct hm_dev, v_m_s), NULL },
	{ "modelacc", -1, 3, offsetof(struct hm_dev, a_m_s2), NULL },
	{ "measforce", -1, 3, offsetof(struct hm_dev, fmeas_N), NULL },
	{ "inertia", -1, 1, offsetof(struct hm_dev, inertia_kg), NULL },
	{ "coulombfriction", -1, 1, offsetof(struct hm_dev, coulomb_N), NULL },
	{ "emergencybuttonpushed", -1, 0, offsetof(struct hm_dev, estop), NULL },
	{ "position_calibrated", -1, 0, offsetof(struct hm_dev, force_calibrated), NULL },
	{ "force_calibrated", -1, 0, offsetof(struct hm_dev, force_calibrated), NULL },
};

/* The field of t (n entries) called name, for an effect of this kind (-1: a quantity); NULL: none. */
static const struct field *field(const struct field *t, size_t n, const char *name, int kind)
{
	for (; n > 0; n--, t++)
		if (!strcmp(t->name, name) && (t->kind < 0 || t->kind == kind))
			return t;
	return NULL;
}

/* n numbers: with n 1 a bare number (spaces and tabs may follow), else "[a,b,c]" with exactly n
 * (spaces allowed around them). */
static int parse_numbers(const char *s, double *v, int n)
{
	const int vec = n > 1;
	int k;

	while (vec && *s == ' ')
		s++;
	if (vec && *s++ != '[')
		return -1;
	for (k = 0; k < n; k++) {
		char *end;

		errno = 0;
		v[k] = strtod(s, &end);
		if (errno || end == s || !isfinite(v[k]))
			return -1;
		while (*end == ' ' || (!vec && *end == '\t'))
			end++;
		if (vec && *end++ != (k + 1 < n ? ',' : ']'))
			return -1;
		s = end;
	}
	while (*s == ' ')
		s++;
	return *s ? -1 : 0;
}

static int parse_bool(const char *s, int *b)
{
	if (!strcmp(s, "true") || !strcmp(s, "1"))
		*b = 1;
	else if (!strcmp(s, "false") || !strcmp(s, "0"))
		*b = 0;
	else
		return -1;
	return 0;
}

static int valid_name(const char *s)
{
	size_t k;

	for (k = 0; s[k]; k++) {
		const char c = s[k];

		if (k + 1 >= HM_NAME_MAX ||
		    !((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || (k > 0 && c >= '0' && c <= '9')))
			return 0;
	}
	return k > 0 && strcmp(s, "state") && strcmp(s, "all") &&
		!field(quantities, sizeof(quantities) / sizeof(quantities[0]), s, -1);
}

static struct hm_effect *find(struct hm_dev *d, const char *name)
{
	int k;

	for (k = 0; k < HM_EFFECTS_MAX; k++)
		if (d->fx[k].used && !strcmp(d->fx[k].name, name))
			return &d->fx[k];
	return NULL;
}

/* A client is gone or silent: the bias forces it set drop to zero, the springs and dampers it last set
 * are disabled (the emulator's choice: docs/hapticmaster.md). client -1 (the device stopped): every
 * bias force drops to zero, the springs and dampers stay. Returns how many were acting. */
static uint32_t silence_client(struct hm_dev *d, int client)
{
	uint32_t n = 0;
	int k;

	for (k = 0; k < HM_EFFECTS_MAX; k++) {
		struct hm_effect *e = &d->fx[k];

		if (!e->used || (client >= 0 ? e->owner != client : e->kind != HM_FX_BIAS))
			continue;
		if (e->kind == HM_FX_BIAS) {
			n += e->force_N[0] != 0.0 || e->force_N[1] != 0.0 || e->force_N[2] != 0.0;
			memset(e->force_N, 0, sizeof(e->force_N));
		} else {
			n += (uint32_t)e->enabled;
			e->enabled = 0;
		}
		e->owner = -1;
	}
	return n;
}

/* ---- commands ---- */

static void cmd_state(struct hm_dev *d, struct out *o, const char *v)
{
	int s, n = (int)(sizeof(state_names) / sizeof(state_names[0]));

	for (s = 0; s < n; s++)
		if (!strcmp(v, state_names[s]))
			break;
	if (s == n) {
		fail(d, o, "unknown state '%s' (off, init, home, force, position, stop)", v);
		return;
	}
	if (d->estop && s != HM_STATE_STOP && s != HM_STATE_OFF) {
		fail(d, o, "emergency button pushed: state '%s' refused", v);
		return;
	}
	if ((s == HM_STATE_HOME || s == HM_STATE_FORCE || s == HM_STATE_POSITION) &&
	    (d->state == HM_STATE_OFF || d->state == HM_STATE_STOP)) {
		fail(d, o, "state '%s' needs 'init' first (device is in '%s')", v, hm_dev_state_name(d->state));
		return;
	}
	if (s == HM_STATE_INIT)
		d->force_calibrated = !d->init_fails_calibration;
	if (s != HM_STATE_FORCE && s != HM_STATE_POSITION && s != HM_STATE_HOME)
		silence_client(d, -1); /* off, init, stop: a client sets its force again afterwards */
	d->state = (enum hm_dev_state)s;
	put(o, "state set to '%s'", v);
}

/* Integration stays resolved: sqrt(k / m) dt <= 0.5 and b dt / m <= 0.5 at the device inertia. */
static int stable(const struct hm_dev *d, double k_N_m, double b_Ns_m)
{
	double dt = 1.0 / d->rate_hz;

	return sqrt(fabs(k_N_m) / d->inertia_kg) * dt <= 0.5 && b_Ns_m * dt / d->inertia_kg <= 0.5;
}

static double spring_damping(const struct hm_spring *s, double m_kg)
{
	return s->dampfactor * 2.0 * sqrt(fabs(s->k_N_m) * m_kg);
}

static void set_effect(struct hm_dev *d, struct out *o, int client, struct hm_effect *e, const char *p, const char *v)
{
	const struct field *q = field(params, sizeof(params) / sizeof(params[0]), p, (int)e->kind);
	const double k = e->spring.k_N_m, m = d->inertia_kg, f = d->f_max_N;
	const uint32_t errors = d->errors;
	double x[4] = { 0.0, 0.0, 0.0, 0.0 }, n2 = 0.0;
	int b = 0, bad, i;

	if (!strcmp(p, "enable") || !strcmp(p, "disable")) {
		if (*v) {
			fail(d, o, "'%s' takes no value", p);
			return;
		}
		e->enabled = p[0] == 'e';
		if (e->kind != HM_FX_BIAS)
			e->owner = client;
		put(o, "Effect %s %s", e->name, e->enabled ? "enabled" : "disabled");
		return;
	}
	if (!q || !q->set) {
		fail(d, o, "%s '%s' has no parameter '%s'", kind_names[e->kind], e->name, p);
		return;
	}
	bad = q->n ? parse_numbers(v, x, q->n) : parse_bool(v, &b);
	for (i = 0; i < q->n; i++)
		n2 += x[i] * x[i];
	/* each parameter's own limits: refused whole, the effect as it was */
	if (!strcmp(p, "pos") || !strcmp(p, "vel")) {
		if (bad || fabs(x[0]) > 10.0 || fabs(x[1]) > 10.0 || fabs(x[2]) > 10.0)
			fail(d, o, "malformed value '%s' for %s (want [x,y,z], |x| <= 10)", v, p);
	} else if (!strcmp(p, "att")) {
		if (bad || !(n2 > 1e-12))
			fail(d, o, "malformed value '%s' for att (want a quaternion [x,y,z,w], not zero)", v);
	} else if (!strcmp(p, "stiffness")) {
		if (bad || fabs(x[0]) > 100000.0 || !stable(d, x[0], e->spring.dampfactor * 2.0 * sqrt(fabs(x[0]) * m)))
			fail(d, o, "stiffness '%s' refused (|k| <= 100000 N/m, resolved at %g Hz on %g kg)", v,
			     d->rate_hz, m);
	} else if (!strcmp(p, "dampfactor")) {
		if (bad || x[0] < 0.0 || x[0] > 10.0 || !stable(d, k, x[0] * 2.0 * sqrt(fabs(k) * m)))
			fail(d, o, "dampfactor '%s' refused (0..10, resolved at %g Hz on %g kg)", v, d->rate_hz, m);
	} else if (!strcmp(p, "deadband")) {
		if (bad || x[0] < 0.0 || x[0] > 10.0)
			fail(d, o, "deadband '%s' refused (0..10 m)", v);
	} else if (!strcmp(p, "maxforce")) {
		if (bad || !(x[0] > 0.0) || x[0] > f)
			fail(d, o, "maxforce '%s' refused (0 < F <= %g N)", v, f);
	} else if (!strcmp(p, "dampcoef")) {
		if (bad || x[0] < 0.0 || x[1] < 0.0 || x[2] < 0.0 || !stable(d, 0.0, x[0]) || !stable(d, 0.0, x[1]) ||
		    !stable(d, 0.0, x[2]))
			fail(d, o, "dampcoef '%s' refused (want [bx,by,bz] >= 0 N s/m, resolved at %g Hz on %g kg)", v,
			     d->rate_hz, m);
	} else if (!strcmp(p, "force")) {
		if (bad || fabs(x[0]) > f || fabs(x[1]) > f || fabs(x[2]) > f)
			fail(d, o, "malformed value '%s' for force (want [fx,fy,fz], each within +-%g N)", v, f);
	} else if (bad) { /* direction, dampglobal: any value */
		fail(d, o, "malformed value '%s' for %s (%s)", v, p, q->n ? "want [x,y,z]" : "true or false");
	}
	if (d->errors != errors)
		return;
	if (!strcmp(p, "att") || !strcmp(p, "direction")) /* unit length; a direction of zero: every way */
		for (i = 0; i < q->n; i++)
			x[i] = sqrt(n2) > 1e-12 ? x[i] / sqrt(n2) : 0.0;
	if (q->n)
		memcpy((char *)e + q->off, x, (size_t)q->n * sizeof(double));
	else
		memcpy((char *)e + q->off, &b, sizeof(b));
	if (e->kind != HM_FX_BIAS || !strcmp(p, "force"))
		e->owner = client; /* a spring or damper: whoever last set it; a bias force: its force */
	put(o, "%s", q->set);
}

static void get_effect(struct hm_dev *d, struct out *o, const struct hm_effect *e, const char *p)
{
	const struct field *q = field(params, sizeof(params) / sizeof(params[0]), p, (int)e->kind);

	if (q)
		put_value(o, (const char *)e + q->off, q->n);
	else
		fail(d, o, "%s '%s' has no parameter '%s'", kind_names[e->kind], e->name, p);
}

static void cmd_get(struct hm_dev *d, struct out *o, const char *w1, const char *w2, const char *rest)
{
	const struct hm_effect *e = find(d, w1);
	const struct field *q = field(quantities, sizeof(quantities) / sizeof(quantities[0]), w1, -1);

	if (*w2) {
		if (!e)
			fail(d, o, "unknown effect '%s'", w1);
		else if (*rest)
			fail(d, o, "too many words after 'get %s %s'", w1, w2);
		else
			get_effect(d, o, e, w2);
	} else if (!strcmp(w1, "state")) {
		put(o, "%s", hm_dev_state_name(d->state));
	} else if (q) {
		put_value(o, (const char *)d + q->off, q->n);
	} else if (e) {
		fail(d, o, "'get %s' needs a parameter", w1);
	} else {
		fail(d, o, "unknown quantity '%s'", w1);
	}
}

static void cmd_set(struct hm_dev *d, struct out *o, int client, const char *w1, const char *w2, const char *rest,
		    const char *after_w1)
{
	struct hm_effect *e;
	double x;

	if (!strcmp(w1, "state")) {
		if (*rest || !*w2)
			fail(d, o, "'set state' takes one state name");
		else
			cmd_state(d, o, w2);
	} else if (!strcmp(w1, "inertia")) {
		if (parse_numbers(after_w1, &x, 1) || x < 1.0 || x > 100.0) {
			fail(d, o, "inertia '%s' refused (1..100 kg)", after_w1);
			return;
		}
		d->inertia_kg = x;
		put(o, "Inertia set");
	} else if (!strcmp(w1, "coulombfriction")) {
		if (parse_numbers(after_w1, &x, 1) || x < 0.0 || x > 20.0) {
			fail(d, o, "coulombfriction '%s' refused (0..20 N)", after_w1);
			return;
		}
		d->coulomb_N = x;
		put(o, "Coulomb friction set");
	} else if ((e = find(d, w1)) != NULL) {
		if (!*w2)
			fail(d, o, "'set %s' needs a parameter", w1);
		else
			set_effect(d, o, client, e, w2, rest);
	} else {
		fail(d, o, "unknown effect or quantity '%s'", w1);
	}
}

static void cmd_create(struct hm_dev *d, struct out *o, const char *kind, const char *name, const char *rest)
{
	int k, slot = -1, n = (int)(sizeof(kind_names) / sizeof(kind_names[0]));
	struct hm_effect *e;

	for (k = 0; k < n; k++)
		if (!strcmp(kind, kind_names[k]))
			break;
	if (k == n) {
		fail(d, o, "unknown effect kind '%s' (spring, damper, biasforce)", kind);
		return;
	}
	if (!valid_name(name) || *rest) {
		fail(d, o, "bad effect name '%s%s%s' (a letter or _, then letters, digits, _; under %d characters)",
		     name, *rest ? " " : "", rest, HM_NAME_MAX);
		return;
	}
	if (find(d, name)) {
		fail(d, o, "effect name '%s' is in use", name);
		return;
	}
	for (slot = 0; slot < HM_EFFECTS_MAX && d->fx[slot].used; slot++)
		;
	if (slot == HM_EFFECTS_MAX) {
		fail(d, o, "no room for another effect (%d in use)", HM_EFFECTS_MAX);
		return;
	}
	e = &d->fx[slot];
	memset(e, 0, sizeof(*e));
	e->used = 1;
	e->kind = (enum hm_effect_kind)k;
	e->owner = -1;
	e->att[3] = 1.0;
	e->spring.maxforce_N = d->f_max_N;
	memcpy(e->name, name, strlen(name) + 1); /* valid_name: shorter than HM_NAME_MAX */
	put(o, "Effect %s with name %s created", kind, name);
}

static void cmd_remove(struct hm_dev *d, struct out *o, const char *w1, const char *w2)
{
	struct hm_effect *e;
	int k;

	if (*w2 || !*w1) {
		fail(d, o, "'remove' takes 'all' or one effect name");
	} else if (!strcmp(w1, "all")) {
		for (k = 0; k < HM_EFFECTS_MAX; k++)
			d->fx[k].used = 0;
		put(o, "Removed all effects");
	} else if ((e = find(d, w1)) != NULL) {
		e->used = 0;
		put(o, "Removed effect %s", w1);
	} else {
		fail(d, o, "unknown effect '%s'", w1);
	}
}

/* The next word of s at *i (spaces and tabs between words) into w; 0 when it does not fit in cap bytes. */
static int word(const char *s, size_t *i, char *w, size_t cap)
{
	const size_t a = *i + strspn(s + *i, " \t"), n = strcspn(s + a, " \t");

	*i = a + n;
	memcpy(w, s + a, n < cap ? n : 0); /* one that does not fit: "" */
	w[n < cap ? n : 0] = '\0';
	return n < cap;
}

/* One command, already trimmed and NUL-terminated. */
static void command(struct hm_dev *d, struct out *o, int client, const char *s)
{
	char w0[32], w1[LINE_MAX_CHARS], w2[LINE_MAX_CHARS];
	const char *after_w1, *rest;
	size_t i = 0;

	d->commands++;
	if (!word(s, &i, w0, sizeof(w0))) {
		fail(d, o, "unknown command '%.40s'", s);
		return;
	}
	word(s, &i, w1, sizeof(w1)); /* w1 and w2 fit: the whole command does */
	after_w1 = s + i + strspn(s + i, " \t");
	word(s, &i, w2, sizeof(w2));
	rest = s + i + strspn(s + i, " \t");
	if (!strcmp(w0, "get"))
		cmd_get(d, o, w1, w2, rest);
	else if (!strcmp(w0, "set"))
		cmd_set(d, o, client, w1, w2, rest, after_w1);
	else if (!strcmp(w0, "create"))
		cmd_create(d, o, w1, w2, rest);
	else if (!strcmp(w0, "remove"))
		cmd_remove(d, o, w1, w2);
	else if (!strcmp(w0, "calibrateforcesensor") && !*w1) {
		d->force_calibrated = 1;
		put(o, "Force sensor calibrated");
	} else
		fail(d, o, "unknown command '%.40s'", s);
}

size_t hm_dev_request(struct hm_dev *d, int client, const char *text, size_t len, char *reply, size_t cap)
{
	struct out o = { reply, cap, 0, 0, 0 };
	char line[LINE_MAX_CHARS];
	size_t a = 0;

	if (cap)
		reply[0] = '\0';
	if (client >= 0 && client < HM_CLIENTS_MAX)
		d->client_heard[client] = d->tick;
	while (a <= len) {
		size_t b = a, n;

		while (b < len && text[b] != ';')
			b++;
		while (a < b && isspace((unsigned char)text[a]))
			a++;
		n = b - a;
		while (n > 0 && isspace((unsigned char)text[a + n - 1]))
			n--;
		if (n > 0) {
			if (o.answers++)
				put(&o, ";");
			if (n >= sizeof(line)) {
				d->commands++;
				fail(d, &o, "command of %zu characters over the limit of %zu", n, sizeof(line) - 1);
			} else {
				memcpy(line, text + a, n);
				line[n] = '\0';
				command(d, &o, client, line);
			}
		}
		a = b + 1;
	}
	if (o.answers == 0)
		fail(d, &o, "empty request");
	if (o.full && cap > 0) {
		static const char cut[] = "--- ERROR: reply too long";

		o.len = cap > sizeof(cut) ? cap - sizeof(cut) : 0;
		snprintf(reply + o.len, cap - o.len, "%s", cut);
		o.len = strlen(reply);
	}
	return o.len;
}

void hm_dev_client_gone(struct hm_dev *d, int client)
{
	if (client < 0)
		return;
	d->vanished_zeroed += silence_client(d, client);
}

void hm_dev_set_estop(struct hm_dev *d, int pressed)
{
	if (pressed && !d->estop) {
		d->estop_stops++;
		d->state = HM_STATE_STOP;
		silence_client(d, -1);
	}
	d->estop = pressed != 0;
}

void hm_spring_force(const struct hm_spring *s, const double pos_m[3], const double vel_m_s[3], double m_kg,
		     const double x_m[3], const double v_m_s[3], double f_N[3])
{
	const double c = spring_damping(s, m_kg), D = s->deadband_m;
	const int axial = s->dir[0] != 0.0 || s->dir[1] != 0.0 || s->dir[2] != 0.0;
	double e[3], ed[3], mag;
	int k, outside;

	for (k = 0; k < 3; k++) {
		e[k] = x_m[k] - pos_m[k];
		ed[k] = v_m_s[k] - vel_m_s[k];
	}
	if (axial) {
		double sd = 0.0, sdot = 0.0, fs;

		for (k = 0; k < 3; k++) {
			sd += s->dir[k] * e[k];
			sdot += s->dir[k] * ed[k];
		}
		outside = fabs(sd) > D;
		fs = outside ? -s->k_N_m * (sd > 0.0 ? sd - D : sd + D) : 0.0;
		if (outside || s->dampglobal)
			fs -= c * sdot;
		for (k = 0; k < 3; k++)
			f_N[k] = fs * s->dir[k];
	} else {
		double r = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);

		outside = r > D;
		for (k = 0; k < 3; k++) {
			f_N[k] = outside ? -s->k_N_m * (r - D) * e[k] / r : 0.0;
			if (outside || s->dampglobal)
				f_N[k] -= c * ed[k];
		}
	}
	mag = sqrt(f_N[0] * f_N[0] + f_N[1] * f_N[1] + f_N[2] * f_N[2]);
	if (mag > s->maxforce_N)
		for (k = 0; k < 3; k++)
			f_N[k] *= s->maxforce_N / mag;
}

void hm_dev_tick(struct hm_dev *d, const double x_m[3], const double v_m_s[3], double f_N[3])
{
	const double dt = 1.0 / d->rate_hz;
	int k, a;

	/* the watchdog: a client silent for watchdog_ticks loses the bias forces it set */
	if (d->watchdog_ticks > 0)
		for (k = 0; k < HM_CLIENTS_MAX; k++)
			if (d->tick - d->client_heard[k] >= d->watchdog_ticks)
				d->watchdog_trips += silence_client(d, k);
	memset(f_N, 0, 3 * sizeof(double));
	for (k = 0; k < HM_EFFECTS_MAX; k++) {
		struct hm_effect *e = &d->fx[k];
		double f[3] = { 0.0, 0.0, 0.0 };

		if (!e->used)
			continue;
		if (e->enabled && d->state == HM_STATE_FORCE) {
			if (e->kind == HM_FX_SPRING)
				hm_spring_force(&e->spring, e->pos_m, e->vel_m_s, d->inertia_kg, x_m, v_m_s, f);
			for (a = 0; a < 3; a++) {
				if (e->kind == HM_FX_DAMPER)
					f[a] = -e->dampcoef_Ns_m[a] * (v_m_s[a] - e->vel_m_s[a]);
				else if (e->kind == HM_FX_BIAS)
					f[a] = e->force_N[a];
				f_N[a] += f[a];
			}
		}
		for (a = 0; a < 3; a++)
			e->pos_m[a] += e->vel_m_s[a] * dt;
	}
	if (d->state == HM_STATE_FORCE && d->coulomb_N > 0.0) {
		/* Coulomb friction, smoothed below 1 mm/s so that it never reverses the motion in a tick */
		double sp = sqrt(v_m_s[0] * v_m_s[0] + v_m_s[1] * v_m_s[1] + v_m_s[2] * v_m_s[2]);
		double scale = d->coulomb_N / (sp > 1e-3 ? sp : 1e-3);

		for (a = 0; a < 3; a++)
			f_N[a] -= scale * v_m_s[a];
	}
	for (a = 0; a < 3; a++)
		f_N[a] = f_N[a] > d->f_max_N ? d->f_max_N : f_N[a] < -d->f_max_N ? -d->f_max_N : f_N[a];
	d->tick++;
}
