/* The host programs' command lines: a table of options and one scan over argv. Host only.
 *
 * Each program lists its options as a table of rows made with the macros below: a flag, a string, a
 * dotted IPv4 address, a number in [lo, hi] (or (lo, hi]) with a unit, a whole number (decimal or
 * hexadecimal), a comma list of numbers, one of a few words, or a hook (the program's own code for an
 * option that needs it). -h and --help print the usage text. A refused
 * argument writes nothing (the destinations keep what they had) and gives one reason; swell_cli_parse
 * prints it as "PROG: reason" on stderr and exits 2 before the program has done anything.
 *
 * The reasons, for an option OPT and its value V:
 *   OPT 'V' is not a number in [LO, HI] UNIT           (a number, "(LO" for a bound that is excluded)
 *   OPT 'V' is not a whole number in [LO, HI] UNIT
 *   OPT 'V' is not a hexadecimal number in [LO, HI]       (LO and HI in hexadecimal)
 *   OPT 'V' is not N comma-separated numbers in [LO, HI] UNIT    ("N to M" when the count may vary)
 *   OPT 'V' is not a dotted IPv4 address
 *   OPT 'V' is not orbit, top or map                   (a choice among "orbit|top|map")
 *   OPT needs a value (see --help)
 *   unknown option 'OPT' (see --help)
 *   unexpected argument 'ARG' (see --help)                (a program without an operand hook)
 * Numbers are strtod's (decimal, exponent, hex) and finite; a whole number is one without a fraction; the
 * range -HUGE_VAL to HUGE_VAL takes any number and the reason says no range. */
#ifndef SWELL_CLI_H
#define SWELL_CLI_H

#include <stddef.h>

#define SWELL_CLI_LIST_MAX 16 /* the most numbers in a comma list */

struct swell_cli;

/* An option's own code: 0, or -1 with the reason given by swell_cli_refuse (return its result). val is
 * NULL for an option without a value, and for an optional value that is not there. */
typedef int (*swell_cli_hook)(struct swell_cli *c, const char *opt, const char *val);

enum swell_cli_kind {
	SWELL_CLI_K_SET, /* no value: the integer at dst (of size bytes) becomes lo */
	SWELL_CLI_K_STR, /* the const char * at dst points at the value */
	SWELL_CLI_K_IPV4, /* the same, for a dotted IPv4 address */
	SWELL_CLI_K_NUM, /* the float or double at dst (by size) becomes a number in range */
	SWELL_CLI_K_WHOLE, /* the integer at dst (of size 1, 2, 4 or 8 bytes) becomes a whole number in range;
			    * n 16: written in hexadecimal (strtol's, "0x" or not) */
	SWELL_CLI_K_LIST, /* the n doubles at dst become n comma-separated numbers in range */
	SWELL_CLI_K_CHOICE, /* the integer at dst becomes the place (from 0) of the value among the words of
			     * unit, "orbit|top|map" */
	SWELL_CLI_K_HOOK, /* hook(c, name, value); n: 0 no value, 1 a value, 2 a value unless the next
			    * argument is missing or starts with "--" */
};

struct swell_cli_opt {
	const char *name; /* "--port" */
	enum swell_cli_kind kind;
	void *dst;
	size_t size;
	double lo, hi; /* the range, both ends included unless above */
	int above; /* 1: lo itself is refused */
	const char *unit; /* said after the range, "" for none */
	int n; /* LIST: how many numbers (up to SWELL_CLI_LIST_MAX); HOOK: how it takes a value (above) */
	swell_cli_hook hook;
};

/* Table rows; field is an lvalue (o->port), its size says how to write it. */
/* clang-format off */
#define SWELL_CLI_SET(name, field, value) { name, SWELL_CLI_K_SET, &(field), sizeof(field), value, value, 0, "", 0, 0 }
#define SWELL_CLI_FLAG(name, field) SWELL_CLI_SET(name, field, 1)
#define SWELL_CLI_STR(name, field) { name, SWELL_CLI_K_STR, &(field), 0, 0, 0, 0, "", 0, 0 }
#define SWELL_CLI_IPV4(name, field) { name, SWELL_CLI_K_IPV4, &(field), 0, 0, 0, 0, "", 0, 0 }
#define SWELL_CLI_NUM(name, field, lo, hi, unit) \
	{ name, SWELL_CLI_K_NUM, &(field), sizeof(field), lo, hi, 0, unit, 0, 0 }
#define SWELL_CLI_NUM_ABOVE(name, field, lo, hi, unit) \
	{ name, SWELL_CLI_K_NUM, &(field), sizeof(field), lo, hi, 1, unit, 0, 0 }
#define SWELL_CLI_WHOLE(name, field, lo, hi, unit) \
	{ name, SWELL_CLI_K_WHOLE, &(field), sizeof(field), lo, hi, 0, unit, 0, 0 }
#define SWELL_CLI_HEX(name, field, lo, hi) { name, SWELL_CLI_K_WHOLE, &(field), sizeof(field), lo, hi, 0, "", 16, 0 }
#define SWELL_CLI_LIST(name, array, n, lo, hi, unit) { name, SWELL_CLI_K_LIST, array, 0, lo, hi, 0, unit, n, 0 }
#define SWELL_CLI_CHOICE(name, field, words) { name, SWELL_CLI_K_CHOICE, &(field), sizeof(field), 0, 0, 0, words, 0, 0 }
#define SWELL_CLI_HOOK(name, hook, takes) { name, SWELL_CLI_K_HOOK, 0, 0, 0, 0, 0, "", takes, hook }
/* clang-format on */

#define SWELL_CLI_N(table) (sizeof(table) / sizeof((table)[0])) /* a table's rows */

/* Set with designated initializers: { .prog = "swell-x", .usage = usage, .opt = opts, .n_opt = ... }. */
struct swell_cli {
	const char *prog; /* the messages' prefix */
	const char *usage; /* -h, --help: on stdout */
	const struct swell_cli_opt *opt; /* the table */
	size_t n_opt;
	void *ctx; /* for the hooks */
	/* an argument that is not an option ("-" and a negative number "-5", "-.5" are none); NULL: into
	 * words below */
	int (*operand)(struct swell_cli *c, const char *arg);
	char why[512]; /* the reason of a refusal */
	/* without an operand hook: up to max_words of them into words[n_words++] (0: none taken) */
	const char **words;
	int max_words, n_words;
};

/* argv[1..argc-1] against the table: 0 done, 1 at -h/--help (nothing after it looked at), or -1 at the
 * first refused argument with c->why set (what came before it is taken, the refused one is not). */
int swell_cli_scan(struct swell_cli *c, int argc, char **argv);

/* swell_cli_scan; -h/--help print c->usage on stdout and exit 0, a refusal exits 2 (swell_cli_die). */
void swell_cli_parse(struct swell_cli *c, int argc, char **argv);

/* c->why from a printf format; returns -1 (a hook's "refused"). */
int swell_cli_refuse(struct swell_cli *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* "prog: message" and a newline on stderr, exit 2: a bad command line, for checks after the scan. */
void swell_cli_die(const char *prog, const char *fmt, ...) __attribute__((noreturn, format(printf, 2, 3)));

/* For hooks: v as one number in [lo, hi] (above: lo excluded), or as min..max comma-separated numbers
 * into out (their count returned); -1 with the reason of the list above and out untouched. */
int swell_cli_number(struct swell_cli *c, const char *opt, const char *v, double lo, double hi, const char *unit,
		     double *out);
int swell_cli_numbers(struct swell_cli *c, const char *opt, const char *v, int min, int max, double lo, double hi,
		      const char *unit, double *out);

#endif
