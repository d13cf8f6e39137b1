/* Helpers shared by the VM test tools (swell-vm-cantest, swell-vm-usbtest, swell-vm-dfuse, swell-ffs-echo):
 * strict number parsing (swell_parse_long) with a one-line reason, a monotonic clock in seconds and a stop
 * flag set by SIGTERM and SIGINT. Host programs only. */
#ifndef SWELL_VM_UTIL_H
#define SWELL_VM_UTIL_H

#include <signal.h>
#include <stdio.h>
#include <string.h>
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

static volatile sig_atomic_t vm_stop;

static inline void vm_on_stop(int sig)
{
	(void)sig;
	vm_stop = 1;
}

/* SIGTERM and SIGINT set vm_stop, without SA_RESTART: a poll they interrupt returns EINTR. */
static inline void vm_catch_stop(void)
{
	struct sigaction sa;

	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = vm_on_stop;
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);
}

#endif
