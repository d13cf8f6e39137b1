/* The safe state of the force output, at the bottom of the port. A driver that can put a force on a
 * wire registers a hook that takes it off again; safe_force_zero() runs every hook. This module
 * calls nothing above it: the drivers call down into it, never the other way round. */
#ifndef SWELL_FW_SAFE_H
#define SWELL_FW_SAFE_H

#include <stdint.h>

#include "swell/err.h"

#define SAFE_HOOKS_MAX 4

typedef void (*safe_hook)(void);

/* Register a hook at start-up, before its driver can send a force. Hooks run in the order they
 * were registered (a transmit abort before a fresh zero command); registering one twice keeps one.
 * SWELL_EINVAL for a null hook, SWELL_ESIZE when SAFE_HOOKS_MAX are taken. */
enum swell_err safe_register(safe_hook fn);

/* Every force output into its safe state now: the record to zero, then each hook; from any context. */
void safe_force_zero(void);

/* The force the port has put on the wire, per axis (0 x, 1 y, 2 z) in 0.01 N: recorded (the one
 * writer), read back (0 after safe_force_zero). */
void safe_force_record(int32_t fx_cN, int32_t fy_cN, int32_t fz_cN);
int32_t safe_force_cN(unsigned axis);

#endif
