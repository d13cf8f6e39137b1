/* swell-view-gen: encodes a known scene (gen.h) with the real encoders and either records it, as a
 * viewer would have received it, or sends it live over UDP. The gui tests replay its recordings, so
 * they need no controller. */
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "gen.h"
#include "swell/cli.h"
#include "swell/link.h"
#include "swell/transport.h"

static const char usage[] =
	"usage: swell-view-gen [options] (--out FILE | --udp PORT)\n"
	"Encodes a known scene with the real protocol encoders, one controller frame every 20 ms.\n"
	"\n"
	"  --scene NAME    bump (default): a 3 mm bump at (0.70, 0.50) of a 64 x 64 pool of 6.25 mm cells,\n"
	"                  the object at (0.30, 0.35), force (+1.5, -1.0, +0.8) N;\n"
	"                  bump2: its mirror image; ripple: an animated ripple; bump-info: bump from\n"
	"                  a controller that sends CTL_INFO (firmware 2.7.1, object 100 x 60 x 40 mm)\n"
	"  --frames N      controller frames (default 50, i.e. 1 s)\n"
	"  --out FILE      write a recording: the packets go through UDP on 127.0.0.1 and a recording\n"
	"                  link, exactly as swell-view --record stores what it receives\n"
	"  --udp PORT      send live to 127.0.0.1:PORT at 50 frames/s instead (swell-view --source udp:PORT)\n"
	"  -h, --help      this text\n"
	"Exit status: 0 done, 1 a link or file failed, 2 bad arguments.\n";

struct sink {
	struct swell_link *tx, *rx; /* rx is the recording link, or NULL when sending live */
	unsigned sent, recorded;
	int err;
};

static void drain(struct sink *k)
{
	struct swell_frame f;
	while (k->rx && swell_link_recv(k->rx, &f, 0) == 0)
		k->recorded++;
}

static void emit(void *ctx, const uint8_t *pkt, size_t len)
{
	struct sink *k = ctx;
	struct swell_frame f;
	memset(&f, 0, sizeof(f));
	f.len = (uint16_t)len;
	memcpy(f.data, pkt, len);
	int rc = swell_link_send(k->tx, &f);
	if (rc < 0 && !k->err)
		k->err = rc;
	k->sent++;
	drain(k); /* take each datagram at once: the socket buffer never overflows */
}

int main(int argc, char **argv)
{
	const char *scene = "bump", *out = NULL;
	long frames = 50, port = -1;

	const struct swell_cli_opt opts[] = {
		SWELL_CLI_STR("--scene", scene),
		SWELL_CLI_WHOLE("--frames", frames, 1, 1000000, ""),
		SWELL_CLI_STR("--out", out),
		SWELL_CLI_WHOLE("--udp", port, 1, 65535, ""),
	};
	struct swell_cli cli = { .prog = "swell-view-gen", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts) };

	swell_cli_parse(&cli, argc, argv);
	if (!out == (port < 0)) {
		fprintf(stderr, "swell-view-gen: give exactly one of --out FILE and --udp PORT (see --help)\n");
		return 2;
	}
	struct gen_scene g;
	gen_default(&g);
	bool animate = false;
	if (!strcmp(scene, "bump2")) {
		gen_mirror(&g);
	} else if (!strcmp(scene, "ripple")) {
		gen_ripple(&g);
		animate = true;
	} else if (!strcmp(scene, "bump-info")) {
		gen_info(&g);
	} else if (strcmp(scene, "bump") != 0) {
		fprintf(stderr, "swell-view-gen: unknown scene '%s' (bump, bump2, ripple, bump-info)\n", scene);
		return 2;
	}

	struct sink k = { 0 };
	int rc;
	if (out) {
		struct swell_link *rx;
		rc = swell_link_open_udp(&rx, SWELL_UDP_HOST, 0, NULL, 0);
		if (rc == 0) {
			uint16_t rx_port = swell_link_udp_port(rx);
			rc = swell_link_open_record(&k.rx, rx, out);
			if (rc == 0)
				rc = swell_link_open_udp(&k.tx, SWELL_UDP_HOST, 0, SWELL_UDP_HOST, rx_port);
		}
	} else {
		rc = swell_link_open_udp(&k.tx, SWELL_UDP_HOST, 0, SWELL_UDP_HOST, (uint16_t)port);
	}
	if (rc < 0) {
		fprintf(stderr, "swell-view-gen: cannot open the links%s%s: %s\n", out ? " for " : "", out ? out : "",
			strerror(-rc));
		return 1;
	}

	uint8_t seq = 0, hb_seq = 0;
	struct timespec next;
	clock_gettime(CLOCK_MONOTONIC, &next);
	for (long n = 0; n < frames && !k.err; n++) {
		bool hb = n % 5 == 0, sc = n % 10 == 0, tiles = animate || n % 10 == 0;
		enum swell_err e;
		gen_frame(&g, (uint64_t)n * 20000u, (uint8_t)n, hb, hb_seq, sc, tiles, &seq, emit, &k, &e);
		if (e != SWELL_OK) {
			fprintf(stderr, "swell-view-gen: encoder refused frame %ld: %s\n", n, swell_err_str(e));
			return 1;
		}
		hb_seq = (uint8_t)(hb_seq + hb);
		if (!out) { /* live: one frame every 20 ms */
			next.tv_nsec += 20000000;
			if (next.tv_nsec >= 1000000000) {
				next.tv_nsec -= 1000000000;
				next.tv_sec++;
			}
			clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
		}
	}
	drain(&k);
	swell_link_close(k.tx);
	swell_link_close(k.rx);
	if (k.err) {
		fprintf(stderr, "swell-view-gen: send failed: %s\n", strerror(-k.err));
		return 1;
	}
	if (out && k.recorded != k.sent) {
		fprintf(stderr, "swell-view-gen: %u packets sent, only %u recorded\n", k.sent, k.recorded);
		return 1;
	}
	printf("swell-view-gen: %ld frames (%.2f s), %u packets%s%s\n", frames, (double)frames * 0.02, k.sent,
	       out ? " recorded to " : " sent", out ? out : "");
	return 0;
}
