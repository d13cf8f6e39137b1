/* Parameter values with units; see swell/param_text.h. */
#include "swell/param_text.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

double swell_param_phys(const struct swell_param_desc *d, int32_t raw)
{
	return (double)raw * strtod(d->factor, NULL);
}

void swell_param_format(const struct swell_param_desc *d, int32_t raw, char *buf, size_t len)
{
	snprintf(buf, len, "%.7g%s%s", swell_param_phys(d, raw), d->unit[0] ? " " : "", d->unit);
}

/* The scale of an SI prefix; 0 for none known. */
static double prefix_scale(char c)
{
	static const char prefixes[] = "kcmu";
	static const double scales[] = { 1e3, 1e-2, 1e-3, 1e-6 };
	const char *at = c ? strchr(prefixes, c) : NULL;

	return at ? scales[at - prefixes] : 0;
}

/* Scale of user unit u against the parameter's unit pu: value_in_pu = value_in_u * scale. Both may
 * carry a one-letter prefix on a common base ("mm" and "m": base "m"). 0 when they do not match. */
static double unit_scale(const char *u, const char *pu)
{
	double su = 1, sp = 1;
	const char *bu = u, *bp = pu;

	if (!strcmp(u, pu))
		return 1;
	/* the parameter's unit: "mm" is milli-metre, "m" alone is the metre, "N" has no prefix */
	if (strlen(pu) > 1 && prefix_scale(pu[0]) != 0 && strcmp(pu + 1, "m") == 0) {
		sp = prefix_scale(pu[0]);
		bp = pu + 1;
	}
	if (!strcmp(u, bp))
		return su / sp;
	if (strlen(u) > strlen(bp) && !strcmp(u + 1, bp) && prefix_scale(u[0]) != 0) {
		su = prefix_scale(u[0]);
		bu = u + 1;
	}
	return strcmp(bu, bp) ? 0 : su / sp;
}

int swell_param_parse(const struct swell_param_desc *d, const char *text, int32_t *raw, char *err, size_t errlen)
{
	const double factor = strtod(d->factor, NULL);
	char unit[16];
	const char *p;
	char *end;
	double v, scale, r;
	size_t n;

	errno = 0;
	v = strtod(text, &end);
	if (end == text || errno || !isfinite(v)) {
		snprintf(err, errlen, "%s: '%s' is not a number", d->name, text);
		return -1;
	}
	p = end + strspn(end, " ");
	n = strlen(p);
	if (n >= sizeof(unit)) {
		snprintf(err, errlen, "%s: unit '%s' is not %s", d->name, p, d->unit[0] ? d->unit : "(none)");
		return -1;
	}
	memcpy(unit, p, n + 1);
	scale = 1;
	if (unit[0]) {
		scale = d->unit[0] ? unit_scale(unit, d->unit) : 0;
		if (scale == 0) {
			if (d->unit[0])
				snprintf(err, errlen, "%s: unit '%s' is not %s (or %s with another prefix)", d->name,
					 unit, d->unit, d->unit);
			else
				snprintf(err, errlen, "%s: has no unit, '%s' given", d->name, unit);
			return -1;
		}
	}
	r = nearbyint(v * scale / factor);
	if (r < (double)d->min || r > (double)d->max) {
		char lo[48], hi[48];

		swell_param_format(d, d->min, lo, sizeof(lo));
		swell_param_format(d, d->max, hi, sizeof(hi));
		snprintf(err, errlen, "%s: %s is outside %s .. %s", d->name, text, lo, hi);
		return -1;
	}
	*raw = (int32_t)r;
	return 0;
}
