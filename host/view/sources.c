/* swell-view sources, see sources.h. */
#define _GNU_SOURCE
#include "sources.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "swell/num.h"
#include "swell/pool.h"
#include "swell/transport.h"

#define PATTERN_FRAME_US 20000u /* the pattern controller sends a frame every 20 ms */
#define PATTERN_REFRESH 10u /* scene and unchanged heights again every 10 frames (200 ms) */
#define PATTERN_RESTART_US 400000u

/* Open (or re-open) the link of a link source; 0 or a negative errno with the reason in err. */
static int link_open(struct source *s, char *err, size_t errlen)
{
	/* the description is written only when it changes: the reader thread calls this again while the
	 * display thread shows s->desc */
	char d[sizeof(s->desc)] = "";
	struct swell_link *l = NULL;
	const struct swell_link_open_opts o = { .udp_answer = 1, .can_errors = 1 };
	int rc = swell_link_open_spec(&l, &s->ls, &o);

	if (s->ls.kind == SWELL_LINK_UDP)
		snprintf(d, sizeof(d), "UDP %s:%u", SWELL_UDP_HOST, (unsigned)s->ls.port);
	else if (s->ls.kind == SWELL_LINK_CAN || s->ls.kind == SWELL_LINK_CANFD)
		snprintf(d, sizeof(d), "%s %.40s", s->ls.kind == SWELL_LINK_CANFD ? "CAN FD" : "CAN", s->ls.name);
	else if (s->ls.kind == SWELL_LINK_USB && s->ls.iface)
		snprintf(d, sizeof(d), "USB %04x:%04x IF %d", s->ls.vid, s->ls.pid, s->ls.iface);
	else if (s->ls.kind == SWELL_LINK_USB)
		snprintf(d, sizeof(d), "USB %04x:%04x", s->ls.vid, s->ls.pid);
	else
		snprintf(d, sizeof(d), "REPLAY %.80s", s->ls.name);
	if (strcmp(d, s->desc) != 0)
		memcpy(s->desc, d, sizeof(d));
	if (rc < 0) {
		snprintf(err, errlen, "%s: %s", s->spec, rc == -EPROTO ? "not a swell recording" : strerror(-rc));
		return rc;
	}
	if (s->record) {
		struct swell_link *r = NULL;
		rc = swell_link_open_record(&r, l, s->record);
		if (rc < 0) {
			swell_link_close(l);
			snprintf(err, errlen, "record %s: %s", s->record, strerror(-rc));
			return rc;
		}
		l = r;
		s->record = NULL; /* one recording file: a re-opened USB link is not recorded again */
	}
	s->link = l;
	atomic_store_explicit(&s->have_link, true, memory_order_release); /* s->link set before */
	return 0;
}

static void ring_put(struct source *s, int rc, const struct swell_frame *f)
{
	unsigned h = atomic_load_explicit(&s->head, memory_order_relaxed);
	unsigned t = atomic_load_explicit(&s->tail, memory_order_acquire);
	if (h - t >= RX_RING) {
		atomic_fetch_add(&s->overflow, 1u);
		return;
	}
	struct rx_item *it = &s->ring[h % RX_RING];
	it->rc = rc;
	it->t_us = swell_link_now_ns() / 1000u;
	if (f)
		it->f = *f;
	atomic_store_explicit(&s->head, h + 1u, memory_order_release);
}

static void *reader(void *arg)
{
	struct source *s = arg;
	int last = 0;
	while (!atomic_load(&s->stop)) {
		if (!s->link) { /* USB not there when we started: try again every 500 ms */
			char err[128];
			nanosleep(&(struct timespec){ 0, 500000000 }, NULL);
			if (link_open(s, err, sizeof(err)) != 0)
				continue;
		}
		struct swell_frame f;
		int rc = swell_link_recv(s->link, &f, 50);
		if (rc == -ETIMEDOUT || rc == -EAGAIN || rc == -EINTR)
			continue;
		if (rc == 0 || rc != last)
			ring_put(s, rc, &f); /* report a lasting error once */
		if (rc < 0 && rc != -ENODEV) {
			nanosleep(&(struct timespec){ 0, 50000000 }, NULL); /* a broken link: do not spin */
		}
		last = rc;
	}
	return NULL;
}

bool source_open(struct source *s, const char *spec, const char *record, int usb_iface, char *err, size_t errlen)
{
	const unsigned accept = SWELL_LINK_ACCEPT(SWELL_LINK_UDP) | SWELL_LINK_ACCEPT(SWELL_LINK_CAN) |
		SWELL_LINK_ACCEPT(SWELL_LINK_CANFD) | SWELL_LINK_ACCEPT(SWELL_LINK_USB) |
		SWELL_LINK_ACCEPT(SWELL_LINK_REPLAY);
	const bool pattern = strncmp(spec, "pattern:", 8) == 0;
	struct swell_link_spec ls;

	if (!pattern && swell_link_spec_parse(spec, accept, SWELL_UDP_PORT_VIEWER, &ls, err, errlen) != 0)
		return false;
	if (usb_iface != 0 && (pattern || ls.kind != SWELL_LINK_USB)) {
		snprintf(err, errlen, "--iface %d is for a usb source, not '%s'", usb_iface, spec);
		return false;
	}
	memset(s, 0, sizeof(*s));
	s->rng = 0x12345678u;
	snprintf(s->spec, sizeof(s->spec), "%s", spec);
	s->record = record;
	if (pattern) {
		if (record) {
			snprintf(err, errlen, "--record needs a link source (record a pattern with swell-view-gen)");
			return false;
		}
		s->kind = SOURCE_PATTERN;
		gen_default(&s->g);
		/* NAME[:N]: N cells a side (8..256) instead of 64 */
		char name[32];
		const char *cells = strchr(spec + 8, ':');
		snprintf(name, sizeof(name), "%.*s", cells ? (int)(cells - spec - 8) : 31, spec + 8);
		if (cells) {
			long n;
			if (swell_parse_long(cells + 1, 10, 8, 256, &n) < 0) {
				snprintf(err, errlen, "pattern cells '%s' is not a number in 8..256", cells + 1);
				return false;
			}
			gen_cells(&s->g, (uint16_t)n);
		}
		if (strcmp(name, "bump") == 0) {
			s->animate = false;
		} else if (strcmp(name, "bump2") == 0) {
			gen_mirror(&s->g);
		} else if (strcmp(name, "ripple") == 0) {
			gen_ripple(&s->g);
			s->animate = true;
		} else if (strcmp(name, "bob") == 0) {
			gen_bob(&s->g);
		} else if (strcmp(name, "wake") == 0) {
			gen_wake(&s->g);
			s->animate = true;
		} else if (strcmp(name, "still") == 0) {
			gen_still(&s->g);
		} else {
			snprintf(err, errlen,
				 "unknown pattern '%s' (bump, bump2, ripple, bob, wake, still; NAME:N for N x N cells)",
				 name);
			return false;
		}
		snprintf(s->desc, sizeof(s->desc), "PATTERN %s (NOT A CONTROLLER)", spec + 8);
		return true;
	}
	s->kind = SOURCE_LINK;
	s->ls = ls;
	s->ls.iface = (uint8_t)usb_iface;
	int rc = link_open(s, err, errlen);
	if (rc != 0 && !(rc == -ENODEV && s->ls.kind == SWELL_LINK_USB))
		return false; /* (USB not plugged in yet: LINK DOWN on screen, tried again every 500 ms) */
	if (s->ls.kind == SWELL_LINK_REPLAY)
		return true; /* replays are read in step with the display: same pictures every run */
	s->ring = calloc(RX_RING, sizeof(*s->ring));
	if (!s->ring || pthread_create(&s->thread, NULL, reader, s) != 0) {
		snprintf(err, errlen, "%s: cannot start the reader thread", spec);
		source_close(s);
		return false;
	}
	s->threaded = true;
	return true;
}

bool source_faults(struct source *s, const char *list, char *err, size_t errlen)
{
	static const struct {
		const char *name;
		unsigned bit;
	} names[] = { { "garbage", FAULT_GARBAGE }, { "truncate", FAULT_TRUNCATE }, { "corrupt", FAULT_CORRUPT },
		      { "reorder", FAULT_REORDER }, { "drop", FAULT_DROP },         { "noscene", FAULT_NOSCENE },
		      { "restart", FAULT_RESTART } };
	char buf[256];
	snprintf(buf, sizeof(buf), "%s", list);
	for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
		unsigned k;
		for (k = 0; k < sizeof(names) / sizeof(names[0]); k++)
			if (strcmp(t, names[k].name) == 0)
				break;
		if (k == sizeof(names) / sizeof(names[0])) {
			snprintf(err, errlen,
				 "unknown fault '%s' (garbage, truncate, corrupt, reorder, drop, noscene, restart)", t);
			return false;
		}
		s->faults |= names[k].bit;
	}
	return true;
}

static void deliver(struct source *s, const uint8_t *p, size_t len)
{
	feed_packet(s->feed, p, len, s->now_us);
	s->delivered++;
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
		deliver(s, p, rnd(s) % len); /* the cut packet arrives; its full copy never does */
		return;
	}
	if ((s->faults & FAULT_CORRUPT) && n % 5 == 2) {
		p[rnd(s) % len] ^= (uint8_t)(1u << (rnd(s) % 8));
		deliver(s, p, len);
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
			s->g.bump_x_um = (int32_t)(0.30 * SWELL_POOL_SIDE_UM); /* the new run starts elsewhere */
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

static void deliver_link_frame(struct source *s, const struct swell_frame *f, uint64_t t_us)
{
	s->delivered++;
	if (s->ls.kind == SWELL_LINK_REPLAY) { /* the recording's times, for what is about time on the link */
		s->feed->rec_clock = true;
		s->feed->rec_us = f->t_ns / 1000u;
	}
	if (swell_link_carrier(s->link) == SWELL_CARRIER_PKT)
		feed_packet(s->feed, f->data, f->len, t_us);
	else if (f->flags & SWELL_FRAME_EFF)
		vm_bad(s->feed->vm); /* a 29-bit id is never a swell frame */
	else
		feed_can(s->feed, f->id, f->data, f->len, (f->flags & SWELL_FRAME_FD) != 0, t_us);
}

static void ring_poll(struct source *s, uint64_t now_us)
{
	struct view_model *vm = s->feed->vm;
	unsigned t = atomic_load_explicit(&s->tail, memory_order_relaxed);
	unsigned h = atomic_load_explicit(&s->head, memory_order_acquire);

	if (atomic_load_explicit(&s->have_link, memory_order_acquire) && !vm->link_up && t == h && vm->st.frames == 0)
		vm_link(vm, true, now_us); /* open, nothing yet: up and waiting (then STALE) */
	for (; t != h; t++) {
		const struct rx_item *it = &s->ring[t % RX_RING];
		/* times from the reader thread are older than now_us: keep them, they are the truth */
		uint64_t at = it->t_us < now_us ? it->t_us : now_us;
		if (it->rc == 0) {
			if (!vm->link_up)
				vm_link(vm, true, at);
			deliver_link_frame(s, &it->f, at);
		} else if (vm->link_up) {
			vm_link(vm, false, at); /* unplugged or broken; the link layer reconnects */
		}
	}
	atomic_store_explicit(&s->tail, t, memory_order_release);
	vm->st.dropped += atomic_exchange(&s->overflow, 0u);
}

static void link_poll(struct source *s, uint64_t now_us)
{
	struct view_model *vm = s->feed->vm;

	if (s->threaded) {
		ring_poll(s, now_us);
		return;
	}

	if (!s->link) {
		if (s->ls.kind != SWELL_LINK_USB || now_us < s->retry_us)
			return;
		char err[128];
		s->retry_us = now_us + 500000u;
		if (link_open(s, err, sizeof(err)) != 0)
			return;
	}
	if (!vm->link_up && !s->ended)
		vm_link(vm, true, now_us);
	/* everything that is there now, bounded so a flood cannot stall the display */
	for (int k = 0; k < 20000; k++) {
		struct swell_frame f;
		int rc = swell_link_recv(s->link, &f, 0);
		if (rc == -ETIMEDOUT || rc == -EAGAIN)
			return;
		if (rc == -ENODEV) { /* unplugged; the link re-opens it when it is back */
			if (vm->link_up)
				vm_link(vm, false, now_us);
			return;
		}
		if (rc == -ENODATA || rc == -EIO) { /* end of a replay, or a damaged record */
			if (rc == -EIO)
				s->rec_damaged++;
			s->ended = true;
			vm_link(vm, false, now_us);
			source_close(s); /* not threaded: a replay */
			return;
		}
		if (rc < 0) {
			if (vm->link_up)
				vm_link(vm, false, now_us);
			return;
		}
		if (!vm->link_up)
			vm_link(vm, true, now_us);
		deliver_link_frame(s, &f, now_us);
	}
}

uint32_t source_poll(struct source *s, struct view_feed *f, uint64_t now_us)
{
	s->feed = f;
	s->now_us = now_us;
	s->delivered = 0;
	if (s->kind == SOURCE_PATTERN && !f->vm->link_up)
		vm_link(f->vm, true, now_us);
	if (s->kind == SOURCE_PATTERN)
		pattern_poll(s, now_us);
	else
		link_poll(s, now_us);
	return s->delivered;
}

void source_close(struct source *s)
{
	if (s->threaded) {
		atomic_store(&s->stop, true);
		pthread_join(s->thread, NULL);
		s->threaded = false;
	}
	free(s->ring);
	s->ring = NULL;
	atomic_store(&s->have_link, false);
	swell_link_close(s->link);
	s->link = NULL;
}
