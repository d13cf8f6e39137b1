#include "swell/cli.h"
#include "swell/num.h"

#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int swell_cli_refuse(struct swell_cli *c, const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(c->why, sizeof(c->why), fmt, ap);
	va_end(ap);
	return -1;
}

void swell_cli_die(const char *prog, const char *fmt, ...)
{
	va_list ap;

	fprintf(stderr, "%s: ", prog);
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fputc('\n', stderr);
	exit(2);
}

/* One number at p, in range (above: lo excluded): 0 with *x and *end set, or -1. */
static int one(const char *p, char **end, double lo, double hi, int above, double *x)
{
	errno = 0;
	*x = strtod(p, end);
	return errno || *end == p || !isfinite(*x) || !(*x >= lo && *x <= hi) || (above && *x == lo) ? -1 : 0;
}

/* The reason with the range and unit: " in [lo, hi] unit" (nothing for -HUGE_VAL to HUGE_VAL). */
static int refuse_range(struct swell_cli *c, const char *opt, const char *v, const char *what, double lo, double hi,
			int above, const char *unit)
{
	if (isinf(lo) && isinf(hi))
		return swell_cli_refuse(c, "%s '%s' is not %s", opt, v, what);
	return swell_cli_refuse(c, "%s '%s' is not %s in %c%.15g, %.15g]%s%s", opt, v, what, above ? '(' : '[', lo, hi,
				*unit ? " " : "", unit);
}

int swell_cli_number(struct swell_cli *c, const char *opt, const char *v, double lo, double hi, const char *unit,
		     double *out)
{
	char *end;
	double x;

	if (one(v, &end, lo, hi, 0, &x) < 0 || *end)
		return refuse_range(c, opt, v, "a number", lo, hi, 0, unit);
	*out = x;
	return 0;
}

int swell_cli_numbers(struct swell_cli *c, const char *opt, const char *v, int min, int max, double lo, double hi,
		      const char *unit, double *out)
{
	double x[SWELL_CLI_LIST_MAX];
	const char *p = v;
	char *end, what[48];
	int k;

	/* each number ends at a comma but the last, which ends the string */
	for (k = 0; k < max && k < SWELL_CLI_LIST_MAX && one(p, &end, lo, hi, 0, &x[k]) == 0; k++) {
		if (!*end && k + 1 >= min) {
			memcpy(out, x, (size_t)(k + 1) * sizeof(x[0]));
			return k + 1;
		}
		if (*end != ',')
			break;
		p = end + 1;
	}
	if (min == max)
		snprintf(what, sizeof(what), "%d comma-separated numbers", max);
	else
		snprintf(what, sizeof(what), "%d to %d comma-separated numbers", min, max);
	return refuse_range(c, opt, v, what, lo, hi, 0, unit);
}

/* A whole number into an integer of size bytes; the value is in its range, so the low bytes of its two's
 * complement are the integer, signed or not. */
static void put_whole(void *dst, size_t size, double x)
{
	const uint64_t u = (uint64_t)(int64_t)x;
	const uint8_t u8 = (uint8_t)u;
	const uint16_t u16 = (uint16_t)u;
	const uint32_t u32 = (uint32_t)u;

	if (size == 1)
		memcpy(dst, &u8, 1);
	else if (size == 2)
		memcpy(dst, &u16, 2);
	else if (size == 4)
		memcpy(dst, &u32, 4);
	else
		memcpy(dst, &u, 8);
}

/* v's place among the words "a|b|c", or -1 with the reason naming them: "is not a, b or c". */
static int choice(struct swell_cli *c, const char *opt, const char *v, const char *words)
{
	const size_t n = strlen(v);
	const char *w = words, *bar;
	char list[256] = "";
	size_t at = 0;
	int k;

	for (k = 0; *w; k++, w = bar + !!*bar) {
		bar = w + strcspn(w, "|");
		if ((size_t)(bar - w) == n && !strncmp(w, v, n))
			return k;
		at += (size_t)snprintf(list + at, sizeof(list) - at, "%s%.*s",
				       k == 0         ? ""
					       : *bar ? ", "
						      : " or ",
				       (int)(bar - w), w);
		if (at >= sizeof(list))
			break;
	}
	return swell_cli_refuse(c, "%s '%s' is not %s", opt, v, list);
}

/* One option and its value (NULL for none): 0 or -1 with c->why. */
static int take(struct swell_cli *c, const struct swell_cli_opt *o, const char *v)
{
	struct in_addr ip;
	char *end;
	double x;

	switch (o->kind) {
	case SWELL_CLI_K_SET:
		put_whole(o->dst, o->size, o->lo);
		return 0;
	case SWELL_CLI_K_IPV4:
		if (inet_pton(AF_INET, v, &ip) != 1)
			return swell_cli_refuse(c, "%s '%s' is not a dotted IPv4 address", o->name, v);
		/* fall through */
	case SWELL_CLI_K_STR:
		memcpy(o->dst, &v, sizeof(v));
		return 0;
	case SWELL_CLI_K_NUM:
		if (one(v, &end, o->lo, o->hi, o->above, &x) < 0 || *end)
			return refuse_range(c, o->name, v, "a number", o->lo, o->hi, o->above, o->unit);
		if (o->size == sizeof(float)) {
			const float f = (float)x;

			memcpy(o->dst, &f, sizeof(f));
		} else {
			memcpy(o->dst, &x, sizeof(x));
		}
		return 0;
	case SWELL_CLI_K_WHOLE:
		if (o->n == 16) {
			long h;

			if (swell_parse_long(v, 16, (long)o->lo, (long)o->hi, &h) < 0)
				return swell_cli_refuse(c, "%s '%s' is not a hexadecimal number in [%lx, %lx]", o->name,
							v, (long)o->lo, (long)o->hi);
			put_whole(o->dst, o->size, (double)h);
			return 0;
		}
		if (one(v, &end, o->lo, o->hi, o->above, &x) < 0 || *end || x != floor(x))
			return refuse_range(c, o->name, v, "a whole number", o->lo, o->hi, o->above, o->unit);
		put_whole(o->dst, o->size, x);
		return 0;
	case SWELL_CLI_K_LIST:
		return swell_cli_numbers(c, o->name, v, o->n, o->n, o->lo, o->hi, o->unit, o->dst) < 0 ? -1 : 0;
	case SWELL_CLI_K_CHOICE:
		if ((x = choice(c, o->name, v, o->unit)) < 0)
			return -1;
		put_whole(o->dst, o->size, x);
		return 0;
	case SWELL_CLI_K_HOOK:
		return o->hook(c, o->name, v);
	}
	return -1;
}

int swell_cli_scan(struct swell_cli *c, int argc, char **argv)
{
	int k;

	c->why[0] = '\0';
	for (k = 1; k < argc && argv[k]; k++) {
		const char *a = argv[k], *v = k + 1 < argc ? argv[k + 1] : NULL;
		const struct swell_cli_opt *o = NULL;
		size_t i;
		int takes;

		if (!strcmp(a, "-h") || !strcmp(a, "--help"))
			return 1;
		if (a[0] != '-' || !a[1] || a[1] == '.' || (a[1] >= '0' && a[1] <= '9')) { /* "-", "-5": operands */
			if (c->operand) {
				if (c->operand(c, a) < 0)
					return -1;
			} else if (c->n_words < c->max_words) {
				c->words[c->n_words++] = a;
			} else {
				return swell_cli_refuse(c, "unexpected argument '%s' (see --help)", a);
			}
			continue;
		}
		for (i = 0; i < c->n_opt && !o; i++)
			if (!strcmp(a, c->opt[i].name))
				o = &c->opt[i];
		if (!o)
			return swell_cli_refuse(c, "unknown option '%s' (see --help)", a);
		takes = o->kind == SWELL_CLI_K_HOOK ? o->n : o->kind != SWELL_CLI_K_SET;
		if (takes == 2 && v && !strncmp(v, "--", 2))
			v = NULL;
		if (takes == 1 && !v)
			return swell_cli_refuse(c, "%s needs a value (see --help)", a);
		if (take(c, o, takes ? v : NULL) < 0)
			return -1;
		if (takes && v)
			k++;
	}
	return 0;
}

void swell_cli_parse(struct swell_cli *c, int argc, char **argv)
{
	const int r = swell_cli_scan(c, argc, argv);

	if (r > 0) {
		fputs(c->usage, stdout);
		exit(0);
	}
	if (r < 0)
		swell_cli_die(c->prog, "%s", c->why);
}
