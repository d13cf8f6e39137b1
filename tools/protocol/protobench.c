/* swell-protobench: host cost of the protocol codecs, ns per message, per carrier. The controller
 * decodes a DEVICE_POS and encodes a FORCE_CMD every haptic tick; this says what that costs. */
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/cli.h"
#include "swell/proto.h"

static const char usage[] = "usage: swell-protobench [--count N]\n"
			    "Encodes and decodes N messages of every type (default 200000) on classic CAN, CAN FD\n"
			    "and packets and prints ns per message for each, as CSV on stdout:\n"
			    "  carrier,op,messages,ns_per_msg\n"
			    "Exit status 1 if any decoded message differs from the one encoded.\n";

static double now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return 1e9 * (double)ts.tv_sec + (double)ts.tv_nsec;
}

#define POOL 4096u

int main(int argc, char **argv)
{
	static struct swell_msg pool[POOL], back[SWELL_CANFD_MSGS_MAX];
	static uint8_t can_data[POOL][8], can_len[POOL], fd_data[POOL][64], fd_len[POOL], pkt[POOL][64];
	static uint32_t can_id[POOL], fd_id[POOL];
	static size_t pkt_len[POOL], fd_used[POOL], pkt_used[POOL];
	unsigned long count = 200000, i, rounds;
	uint64_t rng = 88172645463325252ull;
	unsigned k, bad = 0;
	double t0, t;
	volatile unsigned sink = 0;

	const struct swell_cli_opt opts[] = { SWELL_CLI_WHOLE("--count", count, POOL, 1000000000, "messages") };
	struct swell_cli cli = { .prog = "swell-protobench", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts) };

	swell_cli_parse(&cli, argc, argv);
	/* runs of 8 messages of one type, so that CAN FD batches as it would for heights */
	for (k = 0; k < POOL; k++) {
		const struct swell_msg_desc *d = &swell_msg_descs[(k / 8) % swell_msg_desc_count];
		unsigned f;

		memset(&pool[k], 0, sizeof(pool[k]));
		pool[k].type = d->type;
		for (f = 0; f < d->nfields; f++) {
			uint64_t span = (uint64_t)(d->fields[f].max - d->fields[f].min) + 1u;

			rng ^= rng << 13;
			rng ^= rng >> 7;
			rng ^= rng << 17;
			swell_msg_field_set(&pool[k], &d->fields[f], d->fields[f].min + (int64_t)(rng % span));
		}
	}
	rounds = count / POOL;
	printf("carrier,op,messages,ns_per_msg\n");

	t0 = now_ns();
	for (i = 0; i < rounds; i++)
		for (k = 0; k < POOL; k++)
			sink += swell_can_encode(&pool[k], &can_id[k], can_data[k], &can_len[k]);
	t = now_ns() - t0;
	printf("can,encode,%lu,%.1f\n", rounds * POOL, t / (double)(rounds * POOL));
	t0 = now_ns();
	for (i = 0; i < rounds; i++)
		for (k = 0; k < POOL; k++)
			sink += swell_can_decode(can_id[k], can_data[k], can_len[k], &back[0], NULL);
	t = now_ns() - t0;
	printf("can,decode,%lu,%.1f\n", rounds * POOL, t / (double)(rounds * POOL));
	for (k = 0; k < POOL; k++)
		if (swell_can_decode(can_id[k], can_data[k], can_len[k], &back[0], NULL) ||
		    !swell_msg_equal(&back[0], &pool[k]))
			bad++;

	/* CAN FD and packets: frames cover the pool from the start, as many messages as fit */
	{
		unsigned nf = 0, np = 0, pos;
		unsigned long msgs;

		t0 = now_ns();
		for (i = 0; i < rounds; i++)
			for (pos = 0, nf = 0; pos < POOL; pos += (unsigned)fd_used[nf++])
				sink += swell_canfd_encode(&pool[pos], POOL - pos, &fd_id[nf], fd_data[nf], &fd_len[nf],
							   &fd_used[nf]);
		t = now_ns() - t0;
		printf("canfd,encode,%lu,%.1f\n", rounds * POOL, t / (double)(rounds * POOL));
		t0 = now_ns();
		for (i = 0; i < rounds; i++)
			for (k = 0; k < nf; k++) {
				size_t n;

				sink += swell_canfd_decode(fd_id[k], fd_data[k], fd_len[k], back, SWELL_CANFD_MSGS_MAX,
							   &n, NULL);
			}
		t = now_ns() - t0;
		printf("canfd,decode,%lu,%.1f\n", rounds * POOL, t / (double)(rounds * POOL));
		for (k = 0, pos = 0; k < nf; pos += (unsigned)fd_used[k++]) {
			size_t n = 0, j;

			if (swell_canfd_decode(fd_id[k], fd_data[k], fd_len[k], back, SWELL_CANFD_MSGS_MAX, &n, NULL))
				bad++;
			for (j = 0; j < n; j++)
				bad += !swell_msg_equal(&back[j], &pool[pos + j]);
		}

		t0 = now_ns();
		for (i = 0; i < rounds; i++)
			for (pos = 0, np = 0; pos < POOL; pos += (unsigned)pkt_used[np++])
				sink += swell_pkt_encode(0, (uint8_t)np, &pool[pos], POOL - pos, pkt[np], 64,
							 &pkt_len[np], &pkt_used[np]);
		t = now_ns() - t0;
		printf("pkt,encode,%lu,%.1f\n", rounds * POOL, t / (double)(rounds * POOL));
		msgs = 0;
		t0 = now_ns();
		for (i = 0; i < rounds; i++)
			for (k = 0; k < np; k++) {
				size_t n = 0;
				uint8_t seq;

				sink += swell_pkt_decode(pkt[k], pkt_len[k], back, SWELL_PKT_MSGS_MAX, &n, &seq, NULL);
				msgs += n;
			}
		t = now_ns() - t0;
		printf("pkt,decode,%lu,%.1f\n", msgs, t / (double)msgs);
		for (k = 0, pos = 0; k < np; pos += (unsigned)pkt_used[k++]) {
			size_t n = 0, j;
			uint8_t seq;

			if (swell_pkt_decode(pkt[k], pkt_len[k], back, SWELL_PKT_MSGS_MAX, &n, &seq, NULL))
				bad++;
			for (j = 0; j < n; j++)
				bad += !swell_msg_equal(&back[j], &pool[pos + j]);
		}
	}
	if (sink || bad) {
		fprintf(stderr, "swell-protobench: %u messages did not round-trip, %u codec errors\n", bad, sink);
		return 1;
	}
	return 0;
}
