/* Whole numbers from the command line, one strict rule for every host program. Host only. */
#ifndef SWELL_NUM_H
#define SWELL_NUM_H

/* s as a whole number in [lo, hi] (base as strtol: 10, 16, or 0 for a C prefix), nothing before or
 * after it but strtol's leading blanks and sign: 0 with *out set, or -1 (*out untouched) for a NULL or
 * empty s, a trailing character, an overflow or a value outside the range. The caller says why. */
int swell_parse_long(const char *s, int base, long lo, long hi, long *out);

#endif
