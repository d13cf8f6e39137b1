/* libFuzzer targets for the protocol decoders (one per carrier, chosen by SWELL_FUZZ_CAN,
 * SWELL_FUZZ_CANFD or SWELL_FUZZ_PKT). Besides "no crash, no sanitizer report" each checks two
 * properties: a rejected frame leaves the output untouched, and an accepted frame re-encodes to
 * exactly the same bytes (the decoders accept one encoding per value and nothing else).
 * Input layout: can, canfd: 2-byte identifier (little-endian) then the data; pkt: a mode byte, then
 * the packet; when bit 0 of the mode is set the harness writes the right CRC into the packet's last
 * 4 bytes first, so that mutations reach the record parser instead of dying at the CRC check. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "swell/crc.h"
#include "swell/proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int ok)
{
	if (!ok)
		abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct swell_proto_stats st;
	struct swell_msg out[SWELL_CANFD_MSGS_MAX + 1], before[SWELL_CANFD_MSGS_MAX + 1];
	enum swell_err err;

	memset(out, 0x5A, sizeof(out));
	memcpy(before, out, sizeof(out));
#if defined(SWELL_FUZZ_CAN) || defined(SWELL_FUZZ_CANFD)
	if (size < 2)
		return 0;
	uint32_t id = (uint32_t)data[0] | (uint32_t)data[1] << 8, id2;
	const uint8_t *body = data + 2;
	size_t len = size - 2;
	uint8_t again[64], len2;
#if defined(SWELL_FUZZ_CAN)
	err = swell_can_decode(id, body, len, out, &st);
	if (err == SWELL_OK) {
		check(swell_can_encode(out, &id2, again, &len2) == SWELL_OK);
		check(id2 == id && len2 == len && memcmp(again, body, len) == 0);
		check(memcmp(&out[1], &before[1], sizeof(out[1])) == 0);
		return 0;
	}
#else
	size_t n = 0, used = 0;
	err = swell_canfd_decode(id, body, len, out, SWELL_CANFD_MSGS_MAX, &n, &st);
	if (err == SWELL_OK) {
		check(n >= 1 && n <= SWELL_CANFD_MSGS_MAX);
		check(swell_canfd_encode(out, n, &id2, again, &len2, &used) == SWELL_OK);
		check(used == n && id2 == id && len2 == len && memcmp(again, body, len) == 0);
		return 0;
	}
#endif
#elif defined(SWELL_FUZZ_PKT)
	size_t n = 0, used = 0, len2 = 0;
	uint8_t seq = 0, again[SWELL_PKT_MAX], pkt[SWELL_PKT_MAX + 16];
	if (size < 1 || size - 1 > sizeof(pkt))
		return 0;
	memcpy(pkt, data + 1, size - 1);
	if ((data[0] & 1u) && size - 1 >= 4) {
		uint32_t crc = swell_crc32(0, pkt, size - 5);
		pkt[size - 5] = (uint8_t)crc;
		pkt[size - 4] = (uint8_t)(crc >> 8);
		pkt[size - 3] = (uint8_t)(crc >> 16);
		pkt[size - 2] = (uint8_t)(crc >> 24);
	}
	data = pkt;
	size -= 1;
	err = swell_pkt_decode(data, size, out, SWELL_PKT_MSGS_MAX, &n, &seq, &st);
	if (err == SWELL_OK) {
		check(n >= 1 && n <= SWELL_PKT_MSGS_MAX);
		check(swell_pkt_encode(out[0].node, seq, out, n, again, sizeof(again), &len2, &used) == SWELL_OK);
		check(used == n && len2 == size && memcmp(again, data, size) == 0);
		return 0;
	}
#else
#error "define SWELL_FUZZ_CAN, SWELL_FUZZ_CANFD or SWELL_FUZZ_PKT"
#endif
	check(err > SWELL_OK && err < SWELL_ERR_COUNT);
	check(memcmp(out, before, sizeof(out)) == 0);
	return 0;
}
