/* The safety stage every force passes on its way to the device: haptic gain, magnitude limit, rate
 * limit, and zero force whenever the loop is not running. Integers only.
 *
 * Order on every tick:
 *   not running        -> output 0 at once (fail-safe beats the rate limit)
 *   F' = round(gain F) -> clamp to +-f_max -> move the output toward F' by at most step per tick,
 *   step = floor(rate / tick_hz), so |dF/dt| <= rate
 *   finally clamp the output to +-f_max again (a lowered limit cuts at once: force beats rate).
 * Every limit is a validated parameter; a rejected value changes nothing. */
#ifndef SWELL_FORCE_SAFETY_H
#define SWELL_FORCE_SAFETY_H

#include <stdint.h>

#include "swell/err.h"
#include "swell/fixed.h"

#define SWELL_FSAFETY_MAX_GAIN (4 * SWELL_Q16_ONE)
#define SWELL_FSAFETY_MAX_FORCE_UN 1000000000u /* 1000 N */

struct swell_fsafety_params {
	q16_t gain; /* haptic gain, Q15.16, in [0, 4] */
	uint32_t f_max_uN; /* |F| <= f_max, in [1, 1e9] uN */
	uint32_t rate_uN_per_s; /* |dF/dt| <= rate, at least tick_hz (1 uN per tick) */
	uint32_t tick_hz; /* device rate, [10, 100000] */
};

struct swell_fsafety {
	struct swell_fsafety_params p;
	int32_t step_uN; /* largest change per tick */
	int32_t out_uN; /* last output */
	uint32_t force_limited, rate_limited, zeroed;
};

/* SWELL_EINVAL (null), SWELL_ERANGE (a value outside its range). */
enum swell_err swell_fsafety_check(const struct swell_fsafety_params *p);

/* Output starts at 0. On error *s is untouched. */
enum swell_err swell_fsafety_init(struct swell_fsafety *s, const struct swell_fsafety_params *p);

/* New limits while running (the output stays where it is); on error nothing changes. */
enum swell_err swell_fsafety_set(struct swell_fsafety *s, const struct swell_fsafety_params *p);

/* One tick: the force to send, in uN. */
int32_t swell_fsafety_apply(struct swell_fsafety *s, int32_t f_uN, int running);

#endif
