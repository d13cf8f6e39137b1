/* swell-view sources, see sources.h. */
#define _GNU_SOURCE
#include "sources.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "swell/transport.h"

#define PATTERN_FRAME_US 20000u /* the pattern controller sends a frame every 20 ms */
#define PATTERN_REFRESH 10u     /* scene and unchanged heights again every 10 frames (200 ms) */
#define PATTERN_RESTART_US 400000u

static bool open_udp(struct source *s, const char *arg, char *err, size_t errlen)
{
	long port = SWELL_UDP_PORT_VIEWER;
	if (arg) {
		char *end;
		port = strtol(arg, &end, 10);
		if (*arg == '\0' || *end || port < 1 || port > 65535) {
			snprintf(err, errlen, "udp port '%s' is not in 1..65535", arg);
			return false;
		}
	}
	s->fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (s->fd < 0) {
		snprintf(err, errlen, "udp socket: %s", strerror(errno));
		return false;
	}
	struct sockaddr_in a;
	memset(&a, 0, sizeof(a));
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	a.sin_port = htons((uint16_t)port);
	if (bind(s->fd, (struct sockaddr *)&a, sizeof(a)) < 0) {
		snprintf(err, errlen, "udp bind 127.0.0.1:%ld: %s", port, strerror(errno));
		close(s->fd);
		s->fd = -1;
		return false;
	}
	snprintf(s->desc, sizeof(s->desc), "UDP 127.0.0.1:%ld", port);
	return true;
}

FILE *rec_create(const char *path)
{
	FILE *f = fopen(path, "wb");
	if (f && fwrite(REC_MAGIC, 1, 8, f) != 8) {
		fclose(f);
		return NULL;
	}
	return f;
}

void rec_write(FILE *f, uint64_t t_us, unsigned carrier, uint32_t can_id, const uint8_t *p, size_t len)
{
	uint8_t h[15];
	for (int k = 0; k < 8; k++)
		h[k] = (uint8_t)(t_us >> (8 * k));
	h[8] = (uint8_t)carrier;
	for (int k = 0; k < 4; k++)
		h[9 + k] = (uint8_t)(can_id >> (8 * k));
	h[13] = (uint8_t)len;
	h[14] = (uint8_t)(len >> 8);
	fwrite(h, 1, sizeof(h), f);
	fwrite(p, 1, len, f);
}

static bool open_replay(struct source *s, const char *path, char *err, size_t errlen)
{
	char magic[8];
	s->in = fopen(path, "rb");
	if (!s->in) {
		snprintf(err, errlen, "replay %s: %s", path, strerror(errno));
		return false;
	}
	if (fread(magic, 1, 8, s->in) != 8 || memcmp(magic, REC_MAGIC, 8) != 0) {
		snprintf(err, errlen, "replay %s: not a swell-view recording (no %s magic)", path, REC_MAGIC);
		fclose(s->in);
		s->in = NULL;
		return false;
	}
	snprintf(s->desc, sizeof(s->desc), "REPLAY %.80s", path);
	return true;
}

/* Read the next record into the pending slot; false at the end or on a damaged record. */
static bool replay_next(struct source *s)
{
	uint8_t h[15];
	if (fread(h, 1, sizeof(h), s->in) != sizeof(h))
		return false;
	uint64_t t = 0;
	for (int k = 7; k >= 0; k--)
		t = t << 8 | h[k];
	uint32_t id = (uint32_t)h[9] | (uint32_t)h[10] << 8 | (uint32_t)h[11] << 16 | (uint32_t)h[12] << 24;
	uint16_t len = (uint16_t)(h[13] | h[14] << 8);
	if (h[8] > REC_CANFD || len > sizeof(s->pend) || fread(s->pend, 1, len, s->in) != len) {
		s->rec_bad++;
		return false; /* a damaged or cut recording ends here */
	}
	s->pend_t = t;
	s->pend_carrier = h[8];
	s->pend_id = id;
	s->pend_len = len;
	s->have_pending = true;
	return true;
}

bool source_open(struct source *s, const char *spec, char *err, size_t errlen)
{
	memset(s, 0, sizeof(*s));
	s->fd = -1;
	s->rng = 0x12345678u;
	if (strncmp(spec, "udp", 3) == 0 && (spec[3] == 0 || spec[3] == ':')) {
		s->kind = SOURCE_UDP;
		return open_udp(s, spec[3] ? spec + 4 : NULL, err, errlen);
	}
	if (strncmp(spec, "pattern:", 8) == 0) {
		s->kind = SOURCE_PATTERN;
		gen_default(&s->g);
		if (strcmp(spec + 8, "bump") == 0) {
			s->animate = false;
		} else if (strcmp(spec + 8, "bump2") == 0) {
			/* the mirror image of bump: bump left, object right, force the other way */
			s->animate = false;
			s->g.bump_x_um = (int32_t)(0.30 * 64 * 6250);
			s->g.bump_y_um = (int32_t)(0.40 * 64 * 6250);
			s->g.obj_x_10um = (int16_t)(0.72 * 64 * 625);
			s->g.obj_y_10um = (int16_t)(0.70 * 64 * 625);
			s->g.fx_cN = -120;
			s->g.fy_cN = 160;
			s->g.scene_id = 2;
		} else if (strcmp(spec + 8, "ripple") == 0) {
			s->animate = true;
			s->g.bump_amp_um = 2000;
			s->g.ripple_amp_um = 1200;
			s->g.ripple_len_um = 60000;
			s->g.ripple_speed_um_s = 120000;
		} else {
			snprintf(err, errlen, "unknown pattern '%s' (bump, bump2, ripple)", spec + 8);
			return false;
		}
		snprintf(s->desc, sizeof(s->desc), "PATTERN %s (NOT A CONTROLLER)", spec + 8);
		return true;
	}
	if (strncmp(spec, "replay:", 7) == 0 || strncmp(spec, "replay-fast:", 12) == 0) {
		s->kind = SOURCE_REPLAY;
		s->fast = spec[6] == '-';
		return open_replay(s, strchr(spec, ':') + 1, err, errlen);
	}
	if (strncmp(spec, "usb", 3) == 0 || strncmp(spec, "can:", 4) == 0) {
		snprintf(err, errlen, "source '%s' needs the host links (host/links), not built in yet", spec);
		return false;
	}
	snprintf(err, errlen, "unknown source '%s' (udp[:PORT], replay:FILE, replay-fast:FILE, pattern:NAME)", spec);
	return false;
}

bool source_faults(struct source *s, const char *list, char *err, size_t errlen)
{
	static const struct { const char *name; unsigned bit; } names[] = {
		{"garbage", FAULT_GARBAGE}, {"truncate", FAULT_TRUNCATE}, {"corrupt", FAULT_CORRUPT},
		{"reorder", FAULT_REORDER}, {"drop", FAULT_DROP}, {"noscene", FAULT_NOSCENE},
		{"restart", FAULT_RESTART}};
	char buf[256];
	snprintf(buf, sizeof(buf), "%s", list);
	for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
		unsigned k;
		for (k = 0; k < sizeof(names) / sizeof(names[0]); k++)
			if (strcmp(t, names[k].name) == 0)
				break;
		if (k == sizeof(names) / sizeof(names[0])) {
			snprintf(err, errlen, "unknown fault '%s' (garbage, truncate, corrupt, reorder, drop, noscene, restart)", t);
			return false;
		}
		s->faults |= names[k].bit;
	}
	return true;
}

static void deliver_frame(struct source *s, unsigned carrier, uint32_t id, const uint8_t *p, size_t len)
{
	if (s->record)
		rec_write(s->record, s->now_us, carrier, id, p, len);
	if (carrier == REC_PACKET)
		feed_packet(s->feed, p, len, s->now_us);
	else
		feed_can(s->feed, id, p, len, carrier == REC_CANFD, s->now_us);
	s->delivered++;
}

static void deliver(struct source *s, const uint8_t *p, size_t len)
{
	deliver_frame(s, REC_PACKET, 0, p, len);
}

static void replay_poll(struct source *s, uint64_t now_us)
{
	if (s->ended)
		return;
	if (!s->feed->vm->link_up)
		vm_link(s->feed->vm, true, now_us);
	for (;;) {
		if (!s->have_pending && !replay_next(s)) {
			s->ended = true;
			snprintf(s->desc + strlen(s->desc), sizeof(s->desc) - strlen(s->desc), " - ENDED");
			vm_link(s->feed->vm, false, now_us);
			return;
		}
		if (s->rec_t0 == 0) {
			s->rec_t0 = now_us ? now_us : 1;
			s->rec_first = s->pend_t;
		}
		if (!s->fast && s->pend_t - s->rec_first > now_us - s->rec_t0)
			return; /* not yet due */
		s->have_pending = false;
		deliver_frame(s, s->pend_carrier, s->pend_id, s->pend, s->pend_len);
	}
}

static uint32_t rnd(struct source *s)
{
	s->rng ^= s->rng << 13;
	s->rng ^= s->rng >> 17;
	s->rng ^= s->rng << 5;
	return s->rng;
}

/* The pattern's packets pass through the fault injector on their way to the feed. */
static void pattern_emit(void *ctx, const uint8_t *pkt, size_t len)
{
	struct source *s = ctx;
	uint8_t p[SWELL_PKT_MAX];
	uint32_t n = s->emitted++;

	memcpy(p, pkt, len);
	if (s->faults & FAULT_GARBAGE) {
		uint8_t junk[SWELL_PKT_MAX];
		size_t jl = 1 + rnd(s) % sizeof(junk);
		for (size_t k = 0; k < jl; k++)
			junk[k] = (uint8_t)rnd(s);
		if (n % 4 == 0 && jl > 2) {
			junk[0] = SWELL_PKT_MAGIC; /* looks like a packet header, is not one */
			junk[1] = 1;
		}
		deliver(s, junk, jl);
	}
	if ((s->faults & FAULT_DROP) && n % 7 == 3)
		return;
	if ((s->faults & FAULT_TRUNCATE) && n % 3 == 1) {
		uint8_t cut[SWELL_PKT_MAX];
		size_t cl = rnd(s) % len;
		memcpy(cut, p, cl);
		deliver(s, cut, cl); /* the cut packet arrives; its full copy never does */
		return;
	}
	if ((s->faults & FAULT_CORRUPT) && n % 5 == 2) {
		uint8_t bad[SWELL_PKT_MAX];
		memcpy(bad, p, len);
		bad[rnd(s) % len] ^= (uint8_t)(1u << (rnd(s) % 8));
		deliver(s, bad, len);
		return;
	}
	if (s->faults & FAULT_REORDER) {
		if (s->held_len == 0) {
			memcpy(s->held, p, len);
			s->held_len = len;
			return;
		}
		deliver(s, p, len);
		deliver(s, s->held, s->held_len);
		s->held_len = 0;
		return;
	}
	deliver(s, p, len);
}

static void pattern_poll(struct source *s, uint64_t now_us)
{
	if (s->t0_us == 0) {
		s->t0_us = now_us ? now_us : 1;
		s->next_us = s->t0_us;
	}
	/* at most a second of frames at once: a slow renderer does not flood the feed */
	if (now_us > s->next_us + 1000000u)
		s->next_us = now_us - 1000000u;
	while (s->next_us <= now_us) {
		uint64_t t = s->next_us - s->t0_us;
		bool restart_now = (s->faults & FAULT_RESTART) && !s->restarted && t >= PATTERN_RESTART_US;
		if (restart_now) {
			s->restarted = true;
			s->g.state = 0;
			s->g.scene_id++;
			s->g.bump_x_um = (int32_t)(0.30 * 64 * 6250); /* the new run starts elsewhere */
			s->g.obj_x_10um = (int16_t)(0.70 * 64 * 625);
		} else if (s->restarted && s->g.state == 0 && s->frame % PATTERN_REFRESH == 0) {
			s->g.state = 3;
		}
		bool hb = s->frame % 5 == 0 || restart_now;
		bool scene = !(s->faults & FAULT_NOSCENE) && (s->frame % PATTERN_REFRESH == 0 || restart_now);
		/* heights: every frame when animated; otherwise a refresh for late joiners */
		bool tiles = s->animate || s->frame % PATTERN_REFRESH == 0 || restart_now;
		gen_frame(&s->g, t, (uint8_t)s->frame, hb, s->hb_seq, scene, tiles, &s->seq, pattern_emit, s, NULL);
		if (hb)
			s->hb_seq++;
		s->frame++;
		s->next_us += PATTERN_FRAME_US;
	}
}

uint32_t source_poll(struct source *s, struct view_feed *f, uint64_t now_us)
{
	s->feed = f;
	s->now_us = now_us;
	s->delivered = 0;
	if (s->kind == SOURCE_PATTERN) {
		if (!f->vm->link_up)
			vm_link(f->vm, true, now_us);
		pattern_poll(s, now_us);
		return s->delivered;
	}
	if (s->kind == SOURCE_REPLAY) {
		replay_poll(s, now_us);
		return s->delivered;
	}
	if (!f->vm->link_up && s->fd >= 0)
		vm_link(f->vm, true, now_us); /* a bound socket is a link that is up; silence is STALE */
	for (int k = 0; k < 4096; k++) {
		uint8_t buf[2048];
		ssize_t n = recv(s->fd, buf, sizeof(buf), 0);
		if (n < 0)
			break;
		deliver(s, buf, (size_t)n);
	}
	return s->delivered;
}

void source_close(struct source *s)
{
	if (s->fd >= 0)
		close(s->fd);
	s->fd = -1;
	if (s->in)
		fclose(s->in);
	s->in = NULL;
}
