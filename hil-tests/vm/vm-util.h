/* Shared by the VM test tools (swell-vm-cantest, swell-vm-usbtest, swell-vm-dfuse, swell-ffs-echo): a
 * monotonic clock in seconds and a stop flag set by SIGTERM and SIGINT. Host programs only. */
#ifndef SWELL_VM_UTIL_H
#define SWELL_VM_UTIL_H

#include <signal.h>
#include <string.h>
#include <time.h>

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
