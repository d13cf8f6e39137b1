#include "swell/crc.h"

uint32_t swell_crc32(uint32_t crc, const void *data, size_t len)
{
	const uint8_t *p = data;

	crc = ~crc;
	while (len--) {
		crc ^= *p++;
		for (int k = 0; k < 8; k++)
			crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
	}
	return ~crc;
}

uint32_t swell_crc32_words(uint32_t crc, const int32_t *x, size_t n)
{
	for (size_t k = 0; k < n; k++) {
		const uint32_t u = (uint32_t)x[k];
		const uint8_t le[4] = { (uint8_t)u, (uint8_t)(u >> 8), (uint8_t)(u >> 16), (uint8_t)(u >> 24) };

		crc = swell_crc32(crc, le, sizeof(le));
	}
	return crc;
}
