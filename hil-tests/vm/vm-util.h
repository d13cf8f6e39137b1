/* Shared by the VM test tools (swell-vm-cantest, swell-vm-usbtest, swell-vm-dfuse): a monotonic clock in
 * seconds. Host programs only. */
#ifndef SWELL_VM_UTIL_H
#define SWELL_VM_UTIL_H

#include <time.h>

static inline double vm_now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#endif
