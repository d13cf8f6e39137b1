/* CRC-32 (IEEE 802.3: reflected polynomial 0xEDB88320, initial value and final xor 0xFFFFFFFF),
 * the CRC of zlib, PNG and Ethernet: check value of "123456789" is 0xCBF43926.
 * Table-free (bitwise, 8 shifts a byte) so it costs no flash table on the controller. */
#ifndef SWELL_CRC_H
#define SWELL_CRC_H

#include <stddef.h>
#include <stdint.h>

/* Continue a CRC: start with crc = 0 for a new message; feed pieces in order. */
uint32_t swell_crc32(uint32_t crc, const void *data, size_t len);

/* The same over n int32 words, each little-endian (the solver's checksums). */
uint32_t swell_crc32_words(uint32_t crc, const int32_t *x, size_t n);

#endif
