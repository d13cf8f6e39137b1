#include "safe.h"

static safe_hook hooks[SAFE_HOOKS_MAX];
static volatile unsigned n_hooks;
static volatile int32_t force_cN[3];

enum swell_err safe_register(safe_hook fn)
{
	if (!fn)
		return SWELL_EINVAL;
	for (unsigned i = 0; i < n_hooks; i++)
		if (hooks[i] == fn)
			return SWELL_OK;
	if (n_hooks >= SAFE_HOOKS_MAX)
		return SWELL_ESIZE;
	hooks[n_hooks] = fn;
	n_hooks = n_hooks + 1; /* published after the slot is written: an interrupt sees it whole */
	return SWELL_OK;
}

void safe_force_record(int32_t fx_cN, int32_t fy_cN, int32_t fz_cN)
{
	force_cN[0] = fx_cN;
	force_cN[1] = fy_cN;
	force_cN[2] = fz_cN;
}

void safe_force_zero(void)
{
	const unsigned n = n_hooks;

	safe_force_record(0, 0, 0);
	for (unsigned i = 0; i < n; i++)
		hooks[i]();
}

int32_t safe_force_cN(unsigned axis)
{
	return axis < 3 ? force_cN[axis] : 0;
}
