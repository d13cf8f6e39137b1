#include "can_tx.h"

enum swell_err can_tx_pick(uint32_t tme, const uint32_t pend_id[3], uint32_t new_id, unsigned *mb, int *abort)
{
	unsigned m, lowest_ok = 0, worst = 3;

	if (!pend_id || !mb || !abort)
		return SWELL_EINVAL;
	/* Mailboxes below a pending frame of the same id are out: the new frame would overtake it. */
	for (m = 0; m < 3; m++)
		if (!(tme & (1u << m)) && pend_id[m] == new_id)
			lowest_ok = m + 1;
	for (m = lowest_ok; m < 3; m++)
		if (tme & (1u << m)) {
			*mb = m;
			*abort = 0;
			return SWELL_OK;
		}
	/* All usable mailboxes busy: abort the least urgent pending frame if less urgent than ours. */
	for (m = lowest_ok; m < 3; m++)
		if (pend_id[m] > new_id && (worst == 3 || pend_id[m] >= pend_id[worst]))
			worst = m;
	if (worst == 3)
		return SWELL_ESIZE;
	*mb = worst;
	*abort = 1;
	return SWELL_OK;
}
