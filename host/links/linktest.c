/* swell-linktest: exercises the host links for real and exits 0 with a one-line summary when every
 * frame arrived intact, in order and decoded to the values sent. Used by the VM bench (SocketCAN,
 * libusb) and by ctest (UDP, recordings). */
#define _GNU_SOURCE
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/cli.h"
#include "swell/link.h"
#include "swell/transport.h"

static const char usage[] = "usage: swell-linktest COMMAND [options]\n"
			    "  can-pair TX RX [--count N] [--fd] [--bitrate BPS] [--record FILE]\n"
			    "      send every message type on SocketCAN interface TX, receive and decode on RX\n"
			    "      (both on one bus); check values and per-type sequence numbers\n"
			    "  usb-echo [--vid HEX] [--pid HEX] [--iface N] [--count N] [--replug]\n"
			    "      write packets to bulk OUT 0x01 of the device (default 1209:0001, interface 0),\n"
			    "      expect each back unchanged on bulk IN 0x81; report round-trip times. With\n"
			    "      --replug the device is expected to be unplugged and plugged in meanwhile: packets\n"
			    "      lost while it is away are counted, and the link must reconnect and go on\n"
			    "  udp-pair [--count N] [--record FILE]\n"
			    "      the same check over two UDP links on 127.0.0.1, both directions\n"
			    "  replay FILE [--fast]\n"
			    "      decode a recording (at recorded speed, or as fast as possible with --fast)\n"
			    "options:\n"
			    "  --count N      frames to send, 1..10000000 (default 1000)\n"
			    "  --fd           CAN FD frames (messages of one type batched up to 64 bytes)\n"
			    "  --bitrate BPS  set the CAN bitrate first through libsocketcan (needs CAP_NET_ADMIN)\n"
			    "  --record FILE  record every frame the receiving side gets\n"
			    "  --timeout MS   receive timeout per frame in ms (default 1000)\n"
			    "Exit status: 0 all frames correct, 1 a check failed, 2 bad arguments or no link.\n";

struct opts {
	unsigned long count;
	int fd, fast, timeout_ms, replug;
	unsigned long bitrate;
	const char *record;
	struct swell_usb_opts usb;
};

/* ---- deterministic message source ---- */
static uint64_t rng = 0x9E3779B97F4A7C15ull;
static uint64_t rnd(void)
{
	rng ^= rng >> 12;
	rng ^= rng << 25;
	rng ^= rng >> 27;
	return rng * 2685821657736338717ull;
}

static uint8_t type_seq[128];

/* A valid message of type index ti with random values; SEQ fields count per type. */
static void make_msg(unsigned ti, struct swell_msg *m)
{
	const struct swell_msg_desc *d = &swell_msg_descs[ti % swell_msg_desc_count];
	unsigned i;

	memset(m, 0, sizeof(*m));
	m->type = d->type;
	for (i = 0; i < d->nfields; i++) {
		const struct swell_field_desc *f = &d->fields[i];
		uint64_t span = (uint64_t)(f->max - f->min) + 1u;
		int64_t v = f->kind == SWELL_FK_SEQ ? type_seq[d->type] : f->min + (int64_t)(rnd() % span);

		swell_msg_field_set(m, f, v);
	}
	type_seq[d->type]++;
}

static int64_t seq_of(const struct swell_msg *m)
{
	const struct swell_msg_desc *d = swell_msg_desc_find(m->type);
	unsigned i;

	for (i = 0; d && i < d->nfields; i++)
		if (d->fields[i].kind == SWELL_FK_SEQ)
			return swell_msg_field_get(m, &d->fields[i]);
	return -1;
}

static double now_s(void)
{
	return (double)swell_link_now_ns() / 1e9;
}

struct pair_result {
	unsigned long frames, msgs, bad_values, lost, repeated, pkt_lost, rejected, timeouts;
	unsigned types_seen;
	double seconds;
};

/* Sends count frames on tx, receives each on rx (lock-step) and checks it. */
static int run_pair(struct swell_link *tx, struct swell_link *rx, const struct opts *o, uint8_t node,
		    struct pair_result *r)
{
	enum swell_carrier c = swell_link_carrier(tx);
	struct swell_seq seqs[128], pkt_seq = { 0 };
	struct swell_proto_stats st = { 0 };
	int seen[128] = { 0 };
	unsigned long i;
	unsigned ti = 0;
	double t0 = now_s();

	memset(r, 0, sizeof(*r));
	memset(seqs, 0, sizeof(seqs));
	for (i = 0; i < o->count; i++) {
		struct swell_msg sent[SWELL_CANFD_MSGS_MAX], got[SWELL_CANFD_MSGS_MAX];
		struct swell_frame f, in;
		size_t want = 1, used = 0, n = 0, k;
		uint8_t rseq = 0;
		int rc;

		if (c == SWELL_CARRIER_CANFD)
			want = 1 + i % 8; /* one type per FD frame */
		else if (c == SWELL_CARRIER_PKT)
			want = 1 + i % 6;
		for (k = 0; k < want; k++) {
			make_msg(c == SWELL_CARRIER_CANFD ? ti : ti + (unsigned)k, &sent[k]);
			sent[k].node = node;
		}
		ti += c == SWELL_CARRIER_CANFD ? 1u : (unsigned)want;
		if (swell_link_encode(c, node, (uint8_t)i, sent, want, &f, &used) != SWELL_OK) {
			fprintf(stderr, "swell-linktest: encoder refused frame %lu\n", i);
			return 1;
		}
		/* messages that did not fit are sent again next time: roll their seq counters back */
		for (k = used; k < want; k++)
			type_seq[sent[k].type]--;
		rc = swell_link_send(tx, &f);
		if (rc) {
			fprintf(stderr, "swell-linktest: send on %s failed: %s\n", swell_link_name(tx), strerror(-rc));
			return 1;
		}
		rc = swell_link_recv(rx, &in, o->timeout_ms);
		if (rc == -ETIMEDOUT) {
			r->timeouts++;
			continue;
		}
		if (rc) {
			fprintf(stderr, "swell-linktest: receive on %s failed: %s\n", swell_link_name(rx),
				strerror(-rc));
			return 1;
		}
		r->frames++;
		if (swell_link_decode(c, &in, got, SWELL_CANFD_MSGS_MAX, &n, &rseq, &st) != SWELL_OK) {
			r->rejected++;
			continue;
		}
		if (c == SWELL_CARRIER_PKT)
			swell_seq_track(&pkt_seq, rseq);
		if (n != used) {
			r->bad_values++;
			continue;
		}
		for (k = 0; k < n; k++) {
			int64_t s = seq_of(&got[k]);

			r->msgs++;
			seen[got[k].type] = 1;
			if (!swell_msg_equal(&got[k], &sent[k]))
				r->bad_values++;
			if (s >= 0)
				swell_seq_track(&seqs[got[k].type], (uint8_t)s);
		}
	}
	r->seconds = now_s() - t0;
	for (i = 0; i < 128; i++) {
		r->lost += seqs[i].lost;
		r->repeated += seqs[i].repeated;
		r->types_seen += (unsigned)seen[i];
	}
	r->pkt_lost = pkt_seq.lost;
	return 0;
}

static int report(const char *what, const struct pair_result *r, const struct swell_link *rx, unsigned long count)
{
	const struct swell_link_counters *c = swell_link_get_counters(rx);
	int ok = r->frames == count && r->bad_values == 0 && r->lost == 0 && r->repeated == 0 && r->pkt_lost == 0 &&
		r->rejected == 0 && r->timeouts == 0 && r->types_seen == swell_msg_desc_count;

	printf("%s: %s: %lu/%lu frames, %lu messages of %u/%u types, %lu wrong values, %lu lost, "
	       "%lu repeated, %lu rejected, %lu timeouts, %llu bus errors, %.1f ms (%.0f frames/s)\n",
	       what, ok ? "OK" : "FAILED", r->frames, count, r->msgs, r->types_seen, swell_msg_desc_count,
	       r->bad_values, r->lost + r->pkt_lost, r->repeated, r->rejected, r->timeouts,
	       (unsigned long long)c->bus_errors, 1e3 * r->seconds,
	       r->seconds > 0 ? (double)r->frames / r->seconds : 0.0);
	return ok ? 0 : 1;
}

/* With a path, rx wrapped in a recording; on failure both links closed. */
static int wrap_record(struct swell_link **rx, const char *path, struct swell_link *tx)
{
	struct swell_link *rec;
	int rc = path ? swell_link_open_record(&rec, *rx, path) : 0;

	if (rc) {
		fprintf(stderr, "swell-linktest: cannot record to %s: %s\n", path, strerror(-rc));
		swell_link_close(tx);
		swell_link_close(*rx);
	} else if (path) {
		*rx = rec;
	}
	return rc;
}

static int cmd_can_pair(const char *txname, const char *rxname, const struct opts *o)
{
	struct swell_can_opts co = { 0 };
	struct swell_link *tx = NULL, *rx = NULL;
	struct pair_result r;
	char what[128];
	int rc;

	co.fd = o->fd;
	co.error_frames = 1;
	co.bitrate = (uint32_t)o->bitrate;
	rc = swell_link_open_can(&tx, txname, &co);
	if (rc == 0) {
		co.bitrate = 0; /* one bus: set once */
		rc = swell_link_open_can(&rx, rxname, &co);
	}
	if (rc) {
		fprintf(stderr, "swell-linktest: cannot open SocketCAN %s/%s: %s\n", txname, rxname, strerror(-rc));
		swell_link_close(tx);
		return 2;
	}
	if (wrap_record(&rx, o->record, tx))
		return 2;
	rc = run_pair(tx, rx, o, 1, &r);
	snprintf(what, sizeof(what), "can-pair %s -> %s%s", txname, rxname, o->fd ? " (CAN FD)" : "");
	if (rc == 0)
		rc = report(what, &r, rx, o->count);
	swell_link_close(tx);
	swell_link_close(rx);
	return rc;
}

static int cmd_udp_pair(const struct opts *o)
{
	struct swell_link *a = NULL, *b = NULL;
	struct pair_result r;
	int rc, rc2;

	rc = swell_link_open_udp(&b, SWELL_UDP_HOST, 0, NULL, 0);
	if (rc == 0)
		rc = swell_link_open_udp(&a, SWELL_UDP_HOST, 0, SWELL_UDP_HOST, swell_link_udp_port(b));
	if (rc) {
		fprintf(stderr, "swell-linktest: cannot open UDP on %s: %s\n", SWELL_UDP_HOST, strerror(-rc));
		swell_link_close(b);
		return 2;
	}
	if (wrap_record(&b, o->record, a))
		return 2;
	rc = run_pair(a, b, o, 2, &r);
	if (rc == 0)
		rc = report("udp-pair a -> b", &r, b, o->count);
	/* b answers whoever wrote to it last: a */
	rc2 = run_pair(b, a, o, 3, &r);
	if (rc2 == 0)
		rc2 = report("udp-pair b -> a", &r, a, o->count);
	swell_link_close(a);
	swell_link_close(b);
	return rc ? rc : rc2;
}

static int cmp_u64(const void *x, const void *y)
{
	uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;

	return a < b ? -1 : a > b;
}

static int cmd_usb_echo(const struct opts *o)
{
	struct swell_link *l;
	struct swell_proto_stats st = { 0 };
	uint64_t *rtt;
	unsigned long i, ok = 0, wrong = 0, timeouts = 0, away = 0, ok_after = 0;
	unsigned long long reconnects;
	int rc, pass;

	rc = swell_link_open_usb(&l, &o->usb);
	if (rc) {
		fprintf(stderr, "swell-linktest: cannot open USB %04x:%04x interface %d: %s\n", o->usb.vid, o->usb.pid,
			o->usb.iface, strerror(-rc));
		return 2;
	}
	rtt = calloc(o->count, sizeof(*rtt));
	if (!rtt) {
		swell_link_close(l);
		return 2;
	}
	for (i = 0; i < o->count; i++) {
		struct swell_msg sent[6], got[SWELL_PKT_MSGS_MAX];
		struct swell_frame f, in;
		size_t want = 1 + i % 6, used, n, k;
		uint64_t t0;

		for (k = 0; k < want; k++)
			make_msg((unsigned)(i * 6 + k), &sent[k]);
		swell_link_encode(SWELL_CARRIER_PKT, 0, (uint8_t)i, sent, want, &f, &used);
		t0 = swell_link_now_ns();
		rc = swell_link_send(l, &f);
		if (rc == 0)
			rc = swell_link_recv(l, &in, o->timeout_ms);
		if (rc == -ETIMEDOUT) {
			timeouts++;
			continue;
		}
		if (rc == -ENODEV && o->replug) {
			struct timespec ts = { 0, 20000000 };

			away++; /* unplugged: the link re-opens it when it is back; try again in 20 ms */
			nanosleep(&ts, NULL);
			continue;
		}
		if (rc) {
			fprintf(stderr, "swell-linktest: usb-echo packet %lu: %s\n", i, strerror(-rc));
			break;
		}
		rtt[ok + wrong] = in.t_ns - t0;
		if (in.len != f.len || memcmp(in.data, f.data, f.len) ||
		    swell_link_decode(SWELL_CARRIER_PKT, &in, got, SWELL_PKT_MSGS_MAX, &n, NULL, &st) != SWELL_OK ||
		    n != used) {
			wrong++;
			continue;
		}
		for (k = 0; k < n; k++)
			if (!swell_msg_equal(&got[k], &sent[k]))
				break;
		if (k == n) {
			ok++;
			if (swell_link_get_counters(l)->reconnects)
				ok_after++;
		} else {
			wrong++;
		}
	}
	reconnects = (unsigned long long)swell_link_get_counters(l)->reconnects;
	if (o->replug) /* a replug may also lose a packet in flight (timeout) */
		pass = wrong == 0 && reconnects >= 1 && ok_after >= 1 && ok + away + timeouts == o->count;
	else
		pass = ok == o->count;
	qsort(rtt, ok + wrong, sizeof(*rtt), cmp_u64);
	const unsigned long median = (ok + wrong) / 2; /* index of the median round trip */
	printf("usb-echo %s: %s: %lu/%lu packets echoed intact, %lu wrong, %lu timeouts, %lu while "
	       "unplugged, %llu reconnects (%lu intact after), round trip min %.1f us, median %.1f us, "
	       "max %.1f us\n",
	       swell_link_name(l), pass ? "OK" : "FAILED", ok, o->count, wrong, timeouts, away, reconnects, ok_after,
	       ok + wrong ? rtt[0] / 1e3 : 0.0, ok + wrong ? rtt[median] / 1e3 : 0.0,
	       ok + wrong ? rtt[ok + wrong - 1] / 1e3 : 0.0);
	free(rtt);
	swell_link_close(l);
	return pass ? 0 : 1;
}

static int cmd_replay(const char *path, const struct opts *o)
{
	struct swell_link *l;
	struct swell_proto_stats st = { 0 };
	unsigned long frames = 0, msgs = 0, per_type[128] = { 0 };
	uint64_t last_t = 0;
	double t0 = now_s();
	unsigned types = 0, i;
	int rc;

	rc = swell_link_open_replay(&l, path, !o->fast);
	if (rc) {
		fprintf(stderr, "swell-linktest: cannot replay %s: %s\n", path, strerror(-rc));
		return 2;
	}
	for (;;) {
		struct swell_frame f;
		struct swell_msg got[SWELL_CANFD_MSGS_MAX];
		size_t n = 0, k;

		rc = swell_link_recv(l, &f, -1);
		if (rc == -ENODATA)
			break;
		if (rc) {
			fprintf(stderr, "swell-linktest: %s: damaged recording after %lu frames: %s\n", path, frames,
				strerror(-rc));
			swell_link_close(l);
			return 1;
		}
		frames++;
		last_t = f.t_ns;
		if (swell_link_decode(swell_link_carrier(l), &f, got, SWELL_CANFD_MSGS_MAX, &n, NULL, &st))
			continue;
		for (k = 0; k < n; k++) {
			per_type[got[k].type & 0x7F]++;
			msgs++;
		}
	}
	for (i = 0; i < 128; i++)
		types += per_type[i] != 0;
	printf("replay %s: %lu frames, %lu messages of %u types, %u rejected, recorded %.3f s, replayed "
	       "in %.3f s (%s)\n",
	       path, frames, msgs, types, swell_proto_rejected_total(&st), last_t / 1e9, now_s() - t0,
	       o->fast ? "fast" : "recorded speed");
	swell_link_close(l);
	return 0;
}

int main(int argc, char **argv)
{
	const char *pos[3] = { NULL, NULL, NULL }; /* the command and its arguments */
	struct opts o;

	memset(&o, 0, sizeof(o));
	o.count = 1000;
	o.timeout_ms = 1000;
	swell_usb_opts_default(&o.usb);
	if (argc < 2) {
		fputs(usage, stderr);
		return 2;
	}
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_FLAG("--fd", o.fd),
		SWELL_CLI_FLAG("--fast", o.fast),
		SWELL_CLI_FLAG("--replug", o.replug),
		SWELL_CLI_WHOLE("--count", o.count, 1, 10000000, ""),
		SWELL_CLI_WHOLE("--bitrate", o.bitrate, 10000, 8000000, "bit/s"),
		SWELL_CLI_WHOLE("--timeout", o.timeout_ms, 1, 600000, "ms"),
		SWELL_CLI_HEX("--vid", o.usb.vid, 0, 0xFFFF),
		SWELL_CLI_HEX("--pid", o.usb.pid, 0, 0xFFFF),
		SWELL_CLI_WHOLE("--iface", o.usb.iface, 0, 255, ""),
		SWELL_CLI_STR("--record", o.record),
	};
	struct swell_cli cli = { .prog = "swell-linktest",
				 .usage = usage,
				 .opt = opts,
				 .n_opt = SWELL_CLI_N(opts),
				 .ctx = &o,
				 .words = pos,
				 .max_words = 3 };
	int npos;

	swell_cli_parse(&cli, argc, argv);
	npos = cli.n_words;
	if (!pos[0]) {
		fprintf(stderr, "swell-linktest: no command given (see --help)\n");
		return 2;
	}
	if (!strcmp(pos[0], "can-pair") && npos == 3)
		return cmd_can_pair(pos[1], pos[2], &o);
	if (!strcmp(pos[0], "usb-echo") && npos == 1)
		return cmd_usb_echo(&o);
	if (!strcmp(pos[0], "udp-pair") && npos == 1)
		return cmd_udp_pair(&o);
	if (!strcmp(pos[0], "replay") && npos == 2)
		return cmd_replay(pos[1], &o);
	fprintf(stderr, "swell-linktest: unknown command or wrong arguments: '%s' (see --help)\n", pos[0]);
	return 2;
}
