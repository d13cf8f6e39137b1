/* Scripted hands; see hm_hand.h. */
#define _POSIX_C_SOURCE 200809L
#include "hm_hand.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

static const char *const names[] = { "idle", "drop", "release", "press", "shake" };

const char *hm_hand_name(enum hm_hand_kind kind)
{
	return (unsigned)kind < sizeof(names) / sizeof(names[0]) ? names[kind] : "?";
}

/* One key a script may take: its field, the scale from the text's unit to SI, and its range in the
 * text's unit. The kinds that take it are a bit mask. */
struct key {
	const char *name;
	size_t offset;
	double scale, lo, hi;
	unsigned kinds;
	const char *unit;
};

#define K(kind) (1u << (kind))
#define ALL (K(HM_HAND_IDLE) | K(HM_HAND_DROP) | K(HM_HAND_RELEASE) | K(HM_HAND_PRESS) | K(HM_HAND_SHAKE))
static const struct key keys[] = {
	{ "k", offsetof(struct hm_hand, k_N_m), 1.0, 0.0, 1e6, ALL, "N/m" },
	{ "b", offsetof(struct hm_hand, b_Ns_m), 1.0, 0.0, 1e4, ALL, "N s/m" },
	{ "z", offsetof(struct hm_hand, z_m), 1e-3, -200.0, 200.0, K(HM_HAND_DROP), "mm" },
	{ "hold", offsetof(struct hm_hand, hold_s), 1.0, 0.0, 1e6, K(HM_HAND_DROP) | K(HM_HAND_PRESS), "s" },
	{ "at", offsetof(struct hm_hand, at_s), 1.0, 0.0, 1e6, K(HM_HAND_RELEASE) | K(HM_HAND_PRESS) | K(HM_HAND_SHAKE),
	  "s" },
	{ "depth", offsetof(struct hm_hand, depth_m), 1e-3, -200.0, 200.0, K(HM_HAND_PRESS), "mm" },
	{ "ramp", offsetof(struct hm_hand, ramp_s), 1.0, 0.001, 1e3, K(HM_HAND_PRESS), "s" },
	{ "f", offsetof(struct hm_hand, f_hz), 1.0, 0.001, 100.0, K(HM_HAND_SHAKE), "Hz" },
	{ "amp", offsetof(struct hm_hand, amp_m), 1e-3, 0.0, 200.0, K(HM_HAND_SHAKE), "mm" },
	{ "for", offsetof(struct hm_hand, for_s), 1.0, 0.0, 1e6, K(HM_HAND_SHAKE), "s" },
};

static void defaults(struct hm_hand *h, enum hm_hand_kind kind)
{
	memset(h, 0, sizeof(*h));
	h->kind = kind;
	h->k_N_m = 2000.0;
	h->b_Ns_m = 60.0;
	h->z_m = 0.020;
	h->hold_s = kind == HM_HAND_PRESS ? 2.0 : 1.0;
	h->at_s = kind == HM_HAND_RELEASE ? 0.5 : 3.0;
	h->depth_m = 0.045;
	h->ramp_s = 0.5;
	h->f_hz = 1.0;
	h->amp_m = 0.010;
	h->axis = 2;
	h->for_s = 3.0;
}

enum swell_err hm_hand_parse(const char *spec, struct hm_hand *out, char *why, size_t n)
{
	struct hm_hand h;
	char buf[256], *p, *save = NULL, *tok;
	size_t len;
	int kind = -1, k;
	uint32_t seen = 0; /* keys given (bit i: keys[i]; bit 31: axis): each at most once */

	if (!spec || !out)
		return SWELL_EINVAL;
	len = strcspn(spec, ":");
	for (k = 0; k < (int)(sizeof(names) / sizeof(names[0])); k++)
		if (strlen(names[k]) == len && !strncmp(spec, names[k], len))
			kind = k;
	if (kind < 0) {
		snprintf(why, why ? n : 0, "unknown hand '%.*s' (idle, drop, release, press, shake)", (int)len, spec);
		return SWELL_EUNKNOWN;
	}
	defaults(&h, (enum hm_hand_kind)kind);
	if (spec[len] == '\0') {
		*out = h;
		return SWELL_OK;
	}
	if (strlen(spec + len + 1) >= sizeof(buf)) {
		snprintf(why, why ? n : 0, "hand parameters too long");
		return SWELL_ERANGE;
	}
	strcpy(buf, spec + len + 1);
	for (p = buf; (tok = strtok_r(p, ",", &save)) != NULL; p = NULL) {
		char *eq = strchr(tok, '='), *end;
		const struct key *key = NULL;
		double v;
		size_t i;

		if (!eq) {
			snprintf(why, why ? n : 0, "hand parameter '%s' is not key=value", tok);
			return SWELL_ERANGE;
		}
		*eq = '\0';
		for (i = 0; i < sizeof(keys) / sizeof(keys[0]); i++)
			if (!strcmp(tok, keys[i].name) && (keys[i].kinds & K(kind)))
				key = &keys[i];
		if (!key && !strcmp(tok, "axis") && kind == HM_HAND_SHAKE) {
			if (seen & (1u << 31)) {
				snprintf(why, why ? n : 0, "hand %s: axis given twice", names[kind]);
				return SWELL_EINVAL;
			}
			seen |= 1u << 31;
			if (strlen(eq + 1) != 1 || !strchr("xyz", eq[1])) {
				snprintf(why, why ? n : 0, "shake axis must be x, y or z, not '%s'", eq + 1);
				return SWELL_ERANGE;
			}
			h.axis = eq[1] - 'x';
			continue;
		}
		if (!key) {
			snprintf(why, why ? n : 0, "hand %s takes no parameter '%s'", names[kind], tok);
			return SWELL_EUNKNOWN;
		}
		i = (size_t)(key - keys);
		if (seen & (1u << i)) {
			snprintf(why, why ? n : 0, "hand %s: %s given twice", names[kind], key->name);
			return SWELL_EINVAL;
		}
		seen |= 1u << i;
		v = strtod(eq + 1, &end);
		if (end == eq + 1 || *end || !(v >= key->lo && v <= key->hi)) {
			snprintf(why, why ? n : 0, "hand %s: %s = '%s' is not a number in [%g, %g] %s", names[kind],
				 key->name, eq + 1, key->lo, key->hi, key->unit);
			return SWELL_ERANGE;
		}
		v *= key->scale;
		memcpy((char *)&h + key->offset, &v, sizeof v); /* the key's double field in h */
	}
	*out = h;
	return SWELL_OK;
}

void hm_hand_start(const struct hm_hand *h, double x0_m[3])
{
	x0_m[0] = 0.0;
	x0_m[1] = 0.0;
	x0_m[2] = h->kind == HM_HAND_DROP ? h->z_m : 0.0;
}

int hm_hand_force(struct hm_hand *h, double t, const double x[3], const double v[3], double f_N[3])
{
	double target[3], target_v[3] = { 0.0, 0.0, 0.0 }, u;
	int k, holding;

	switch (h->kind) {
	case HM_HAND_DROP:
		holding = t < h->hold_s;
		break;
	case HM_HAND_RELEASE:
		holding = t < h->at_s;
		break;
	case HM_HAND_PRESS:
		holding = t >= h->at_s && t < h->at_s + h->ramp_s + h->hold_s;
		break;
	case HM_HAND_SHAKE:
		holding = t >= h->at_s && !(h->for_s > 0.0 && t >= h->at_s + h->for_s);
		break;
	case HM_HAND_IDLE:
	default:
		holding = 0;
	}
	if (!holding) { /* let go */
		h->grabbed = 0;
		f_N[0] = f_N[1] = f_N[2] = 0.0;
		return 0;
	}
	if (!h->grabbed) /* takes the handle where it is */
		memcpy(h->grab_m, x, sizeof(h->grab_m));
	h->grabbed = 1;
	memcpy(target, h->grab_m, sizeof(target));
	if (h->kind == HM_HAND_DROP) {
		target[2] = h->z_m;
	} else if (h->kind == HM_HAND_PRESS) {
		u = (t - h->at_s) / h->ramp_s;
		target[2] = h->grab_m[2] + (-h->depth_m - h->grab_m[2]) * (u < 1.0 ? u : 1.0);
		if (u < 1.0)
			target_v[2] = (-h->depth_m - h->grab_m[2]) / h->ramp_s;
	} else if (h->kind == HM_HAND_SHAKE) {
		u = 2.0 * PI * h->f_hz * (t - h->at_s);
		target[h->axis] += h->amp_m * sin(u);
		target_v[h->axis] = h->amp_m * 2.0 * PI * h->f_hz * cos(u);
	}
	for (k = 0; k < 3; k++)
		f_N[k] = h->k_N_m * (target[k] - x[k]) + h->b_Ns_m * (target_v[k] - v[k]);
	return 1;
}
