#include "timer_div.h"

enum swell_err fw_timer_div(uint32_t clk_hz, uint32_t rate_hz, uint32_t *psc, uint32_t *arr)
{
	uint32_t total, div;

	if (!psc || !arr)
		return SWELL_EINVAL;
	if (rate_hz == 0 || rate_hz > clk_hz / 2 || clk_hz % rate_hz != 0)
		return SWELL_ERANGE;
	total = clk_hz / rate_hz;
	for (div = 1; div <= 65536u; div++)
		if (total % div == 0 && total / div <= 65536u) {
			*psc = div - 1;
			*arr = total / div - 1;
			return SWELL_OK;
		}
	return SWELL_ERANGE;
}
