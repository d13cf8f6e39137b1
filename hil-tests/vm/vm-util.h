/* Helpers shared by the VM test tools (swell-vm-cantest, swell-vm-usbtest, swell-vm-dfuse): strict number
 * parsing (swell_parse_long) with a one-line reason, and a monotonic clock in seconds. Host programs only. */
#ifndef SWELL_VM_UTIL_H
#define SWELL_VM_UTIL_H

#include <stdio.h>
#include <time.h>

#include "swell/num.h"

/* s as a whole number in [min, max] (base as strtol); on failure prints why, returns -1, *out untouched. */
static inline int vm_parse_num(const char *prog, const char *opt, const char *s, int base, long min, long max,
			       long *out)
{
	if (swell_parse_long(s, base, min, max, out) == 0)
		return 0;
	fprintf(stderr, "%s: %s needs a number in %ld..%ld, not '%s'\n", prog, opt, min, max, s);
	return -1;
}

static inline double vm_now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#endif
