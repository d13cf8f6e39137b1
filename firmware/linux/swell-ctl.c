/* swell-ctl: the controller as a Linux real-time process. The core (firmware/core) does everything
 * that matters; this port gives it a clock, its two links and a report. Clock: absolute-deadline
 * clock_nanosleep on CLOCK_MONOTONIC at the device rate under SCHED_FIFO and mlockall where
 * permitted, or with --clock device one tick per DEVICE_POS (in effect mode as many as its seq step),
 * the device's silence still timed out (swell_ctl_silent_limit). SIGINT/SIGTERM: zero force, the
 * report, exit 0; an accepted ENTER_BOOTLOADER: zero force and the last heartbeat out, the report,
 * exit 3 for a supervisor to flash and start the new image. Its parts: ctl_main.h. */
#define _GNU_SOURCE
#include <errno.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include "ctl_main.h"

static volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
	(void)sig;
	stop_flag = 1;
}

/* The device silence limit without real-time scheduling: 20 ms of ticks, at least the default. */
#define SLOW_SILENCE_MS 20

/* ---- timing ---- */

static void jitter_add(struct jitter *j, int64_t late_ns)
{
	int64_t us = late_ns < 0 ? 0 : late_ns / 1000;

	j->hist[us > HIST_US ? HIST_US : us]++;
	j->n++;
	if (late_ns > j->max_ns)
		j->max_ns = late_ns;
}

static struct timespec ts_of(int64_t ns)
{
	return (struct timespec){ (time_t)(ns / 1000000000), (long)(ns % 1000000000) };
}

static int64_t now_ns(void) /* CLOCK_MONOTONIC, the links' clock */
{
	return (int64_t)swell_link_now_ns();
}

/* ---- the loop ---- */

/* A host message: a start-up parameter (the pool) restarts the core in the port's arena and is
 * answered at once (swell/ctl_pool.h; between ticks, so no tick sees half a restart); anything else
 * is the core's. */
static void host_rx(struct port *p, const struct swell_msg *m)
{
	struct swell_msg answer;

	if (!fw_pool_param(&p->c, &p->mem, m, &answer, &p->place)) {
		swell_ctl_rx(&p->c, SWELL_LINK_HOST, m);
		return;
	}
	if (answer.type == SWELL_MSG_PARAM_ACK && m->type == SWELL_MSG_PARAM_SET)
		fprintf(stderr, "swell-ctl: pool now %ux%u cells of %u um, depth %u um (restarted, water at rest)\n",
			p->c.cfg.nx, p->c.cfg.ny, p->c.cfg.dx_um, p->c.cfg.depth_um);
	ctl_link_send(&p->host, &answer, 1);
}

/* 1 when nothing more is waiting on the link. */
static int link_idle(const struct ctl_link *l)
{
	struct pollfd pf = { ctl_link_fd(l), POLLIN, 0 };

	return pf.fd < 0 || poll(&pf, 1, 0) <= 0;
}

/* Take everything waiting on both links into the core; returns 0 if no DEVICE_POS came in, else the
 * device ticks they stand for: 1, or in effect mode the sum of their seq steps (the device reports once
 * an update there; two samples in one take, the first late, stand for both periods), at most the
 * silence limit. */
static uint32_t take_input(struct port *p)
{
	struct swell_msg m[SWELL_PKT_MSGS_MAX + 1];
	size_t n, k;
	int pos = 0, rounds;
	uint32_t bad, steps = 0;

	/* Bounded, a flood cannot hold the tick; deep enough that a flood of datagrams from other senders,
	 * each dropped unread (no CRC), does not hide the device's samples behind it: 256 reads a tick
	 * drain 640 000 datagrams a second at 2500 Hz. */
	p->dev.hm.inertia_g = p->c.cfg.hm_inertia_g; /* hm: the next start-up sets it (hm.inertia) */
	for (rounds = 0; rounds < 256; rounds++) {
		n = ctl_link_recv(&p->dev, m, sizeof(m) / sizeof(m[0]));
		if (n == 0 && p->dev.frames_rx == 0)
			break;
		for (k = 0; k < n; k++) {
			swell_ctl_rx(&p->c, SWELL_LINK_DEVICE, &m[k]);
			if (m[k].type == SWELL_MSG_DEVICE_POS) {
				pos = 1;
				steps += p->c.dev_step;
			}
		}
		if (n == 0 && link_idle(&p->dev))
			break;
	}
	if (pos)
		p->sample_ns = now_ns();
	/* Read first, poll only when nothing came: on USB the fd is the AIO eventfd, and a write's reap
	 * (telemetry, flush_output) can take the event of a finished OUT transfer, whose packet would
	 * then wait for the next transfer to finish. ctl_link_recv never blocks. */
	for (rounds = 0; p->have_host && rounds < 16; rounds++) {
		n = ctl_link_recv(&p->host, m, sizeof(m) / sizeof(m[0]));
		for (k = 0; k < n; k++)
			host_rx(p, &m[k]);
		if (n == 0 && link_idle(&p->host))
			break;
	}
	bad = swell_proto_rejected_total(&p->dev.st) + (p->have_host ? swell_proto_rejected_total(&p->host.st) : 0);
	if (bad != p->bad_seen) {
		swell_ctl_bad_frames(&p->c, bad - p->bad_seen);
		p->bad_seen = bad;
	}
	if (!pos)
		return 0;
	if (p->c.cfg.force_mode != SWELL_FORCE_EFFECT || steps == 0 || steps > swell_ctl_silent_limit(&p->c))
		return 1;
	return steps;
}

static void flush_output(struct port *p)
{
	struct swell_msg m[SWELL_CTL_QUEUE];
	size_t n;

	/* the force first: it is what the device waits for */
	n = swell_ctl_tx(&p->c, SWELL_LINK_DEVICE, m, SWELL_CTL_QUEUE);
	if (n)
		ctl_link_send(&p->dev, m, n);
	n = swell_ctl_tx(&p->c, SWELL_LINK_HOST, m, SWELL_CTL_QUEUE);
	if (n && p->have_host)
		ctl_link_send(&p->host, m, n);
}

/* Nothing reached the device (send refused, no destination) for silent_ticks ticks in a row while it
 * was there: it is starved even if it still talks, and the loop faults as for a silent device (zero
 * force, the zero goes out as soon as the carrier takes it). Returns 1 while starved. */
static int device_starved(struct port *p)
{
	if (p->dev.unsent_run < p->c.cfg.silent_ticks) { /* sends: in effect mode one an update */
		p->starving = 0;
		return 0;
	}
	if (p->c.state != SWELL_CTL_ARMED && p->c.state != SWELL_CTL_RUNNING)
		return 0;
	swell_ctl_link_down(&p->c, SWELL_LINK_DEVICE); /* this tick faults: zero force from the safety stage */
	if (!p->starving) {
		p->starving = 1;
		p->starved++;
		fprintf(stderr,
			"swell-ctl: device link %s: no command reached the device for %u ticks: force "
			"zeroed, loop faulted\n",
			p->dev.name, p->dev.unsent_run);
	}
	return 1;
}

/* CAN error frames (ctl_link.c keeps the bus state). A bus-off of the device link zeroes the force
 * at once and faults the loop like a silent device; while the bus is off the link drops whatever
 * comes in, and after the restart (restart-ms, a manual restart, down/up) the device is heard again
 * and autorun recovers. Returns 1 when the loop must tick now (to enter the fault). */
static int link_faults(struct port *p)
{
	struct ctl_link *l[2] = { &p->dev, &p->host };
	int k, tick = 0;

	for (k = 0; k < 2; k++) {
		const struct swell_can_health *h = &l[k]->can;

		if (l[k]->kind != CTL_LINK_CAN || (k == 1 && !p->have_host))
			continue;
		if (h->bus_offs != p->bus_offs_seen[k]) {
			p->bus_offs_seen[k] = h->bus_offs;
			if (k == 0) {
				swell_ctl_zero_force(&p->c);
				swell_ctl_link_down(&p->c, SWELL_LINK_DEVICE);
				flush_output(p);
				tick = 1;
			}
			fprintf(stderr, "swell-ctl: %s link %s: bus-off %u (tx/rx error counters %u/%u)%s at %.6f s\n",
				k ? "host" : "device", l[k]->name, h->bus_offs, h->tx_err, h->rx_err,
				k ? "" : ": force zeroed, loop faulted", now_ns() / 1e9);
		}
		if (h->restarts != p->restarts_seen[k]) {
			p->restarts_seen[k] = h->restarts;
			fprintf(stderr, "swell-ctl: %s link %s: back on the bus (restart %u, %s) at %.6f s\n",
				k ? "host" : "device", l[k]->name, h->restarts, swell_can_state_name(h->state),
				now_ns() / 1e9);
		}
	}
	return tick;
}

/* SCHED_FIFO and mlockall where permitted. Without real-time scheduling the tick is late by
 * milliseconds on a loaded machine: unless --silent-ticks says otherwise, the device silence limit
 * becomes SLOW_SILENCE_MS of ticks, and the start line says so. Returns 1 with SCHED_FIFO. */
static int setup_rt(struct opts *o)
{
	struct sched_param sp = { .sched_priority = 80 };
	const char *why = "--no-rt";
	char buf[96], more[64] = "";
	uint32_t slow;

	if (o->rt) {
		if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
			fprintf(stderr, "swell-ctl: warning: mlockall: %s; running without locked memory\n",
				strerror(errno));
		if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
			fprintf(stderr,
				"swell-ctl: real-time: SCHED_FIFO priority 80; device silence limit %u ticks "
				"(%.1f ms)\n",
				o->cfg.silent_ticks, o->cfg.silent_ticks * 1e3 / o->cfg.tick_hz);
			return 1;
		}
		snprintf(buf, sizeof(buf), "SCHED_FIFO refused: %s", strerror(errno));
		why = buf;
	}
	slow = o->cfg.tick_hz * SLOW_SILENCE_MS / 1000;
	if (!o->silent_given && slow > o->cfg.silent_ticks) {
		snprintf(more, sizeof(more), " instead of %u; --silent-ticks N to choose", o->cfg.silent_ticks);
		o->cfg.silent_ticks = (uint16_t)slow;
	}
	fprintf(stderr, "swell-ctl: no real-time scheduling (%s): device silence limit %u ticks (%.1f ms)%s\n", why,
		o->cfg.silent_ticks, o->cfg.silent_ticks * 1e3 / o->cfg.tick_hz, more);
	return 0;
}

int main(int argc, char **argv)
{
	static struct port p;
	static struct jitter jit;
	struct opts o;
	struct sigaction sa;
	int32_t *arena;
	size_t words;
	char err[160], abuf[48];
	int rc;
	int64_t period, next, start, last_status;
	int32_t peak_h = 0;
	int64_t last_sample = 0; /* --clock device: when the last DEVICE_POS came */
	uint64_t max_ticks, ticks = 0; /* the core's count is 32 bits: it wraps after 19.9 days at 2500 Hz */
	enum swell_err e;

	parse(argc, argv, &o);
	setup_rt(&o); /* first: it may set the silence limit the core is configured with */
	words = swell_ctl_arena_words(o.pool_max, o.pool_max);
	if (words < swell_ctl_arena_words(o.cfg.nx, o.cfg.ny))
		words = swell_ctl_arena_words(o.cfg.nx, o.cfg.ny);
	arena = calloc(words, sizeof(*arena)); /* the only allocation, before the loop starts */
	if (!arena) {
		fprintf(stderr, "swell-ctl: out of memory\n");
		return 1;
	}
	p.mem = (struct fw_mem){ arena, words, NULL, 0, "none" };
	e = fw_pool_start(&p.c, &o.cfg, &p.mem, &p.place);
	if (e != SWELL_OK)
		fprintf(stderr, "swell-ctl: controller refused its configuration: %s\n", swell_err_str(e));
	if (e != SWELL_OK || (o.scene_path && scene_params(&p.c, &o) < 0) || first_run_limits(&p.c, &o) < 0) {
		free(arena);
		return 2;
	}
	p.have_host = strcmp(o.host, "none") != 0;
	rc = ctl_link_open(&p.dev, o.device, 1, o.cfg.node, err, sizeof(err));
	if (rc < 0) {
		fprintf(stderr, "swell-ctl: device link: %s\n", err);
	} else if (p.have_host && (rc = ctl_link_open(&p.host, o.host, 0, o.cfg.node, err, sizeof(err))) < 0) {
		fprintf(stderr, "swell-ctl: host link: %s\n", err);
		ctl_link_close(&p.dev);
	}
	if (rc < 0) {
		free(arena);
		return rc == -2 ? 2 : 1; /* a malformed spec is a bad argument */
	}
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	fprintf(stderr, "swell-ctl: %ux%u pool, tick %u Hz, solver %u Hz, device %s, host %s, clock %s\n", o.cfg.nx,
		o.cfg.ny, o.cfg.tick_hz, o.cfg.solver_hz, p.dev.name, p.have_host ? p.host.name : "none",
		o.device_clock ? "device" : "internal");
	if (p.have_host && p.host.kind == CTL_LINK_UDP)
		fprintf(stderr, "swell-ctl: host link clients: send to %s (up to %u, kept while they speak)%s\n",
			addr_str(&p.host.local, 1, 0, abuf, sizeof(abuf)), SWELL_PEERS_CLIENTS,
			p.host.clients_port_taken ? "; the default port 47802 is taken (another controller?): tools "
						    "need --link udp:PORT with this port"
						  : "");

	period = 1000000000 / o.cfg.tick_hz;
	max_ticks = o.seconds > 0 ? (uint64_t)(o.seconds * o.cfg.tick_hz + 0.5) : UINT64_MAX;
	start = next = now_ns();
	last_status = start;
	while (!stop_flag && ticks < max_ticks) {
		uint32_t burst = 1, b;

		if (o.device_clock) {
			/* One tick per device sample, so that a trace replays bit-identically whatever the
			 * machine's load. Nothing ticks before the first sample. Once the device has been
			 * silent for silent_ticks periods of wall time, the loop ticks on its own every period,
			 * so the core sees the silence (and faults silent_ticks ticks later). */
			struct pollfd pf = { ctl_link_fd(&p.dev), POLLIN, 0 };
			const struct timespec one = ts_of(period); /* not poll's whole ms: 2.5 periods at 2500 Hz */
			int r = ppoll(&pf, 1, &one, NULL);

			if (r < 0 && errno == EINTR)
				continue;
			burst = take_input(&p);
			if (burst)
				last_sample = now_ns();
			else if (!link_faults(&p) &&
				 (last_sample == 0 ||
				  now_ns() - last_sample < (int64_t)swell_ctl_silent_limit(&p.c) * period))
				continue;
			else
				burst = 1;
		} else {
			struct timespec dl;
			int64_t late;

			next += period;
			dl = ts_of(next);
			while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &dl, NULL) == EINTR && !stop_flag)
				;
			late = now_ns() - next;
			jitter_add(&jit, late);
			if (late > period) { /* a whole period lost: count it and start again from now */
				swell_ctl_overrun(&p.c);
				next = now_ns();
			}
			take_input(&p);
		}
		/* --clock device in effect mode: a sample every update stands for the device ticks since the
		 * last one (its seq step), and the core ticks that many times on it */
		for (b = 0; b < burst && ticks < max_ticks; b++) {
			link_faults(&p);
			device_starved(&p);
			swell_ctl_tick(&p.c);
			if (p.c.n.faults != p.faults_seen) { /* a fault began: for the report */
				p.faults_seen = p.c.n.faults;
				p.fault_ns = now_ns();
				p.fault_sample_ns = p.sample_ns;
			}
			ticks++;
			flush_output(&p);
			/* the device declared lost (its zero force has just gone to it): a learned UDP device is
			 * let go, the next sender of this node's DEVICE_POS becomes the device (the old one still
			 * gets the zero force until then) */
			if (swell_ctl_device_lost(&p.c))
				p.releases += (uint32_t)swell_peers_release(&p.dev.peers);
			if (swell_ctl_bootloader_requested(&p.c)) /* zero force and the last heartbeat are out */
				break;
		}
		if (swell_ctl_bootloader_requested(&p.c))
			break;
		if (now_ns() - last_status > 1000000000) {
			int a;

			last_status = now_ns();
			/* once a second, outside the force path: the largest wave so far */
			for (a = 0; a < (int)o.cfg.nx * o.cfg.ny; a++) {
				int32_t h = swell_wave_h(&p.c.wave, (size_t)a);

				h = h < 0 ? -h : h;
				peak_h = h > peak_h ? h : peak_h;
			}
			if (!o.quiet)
				fprintf(stderr, "\rswell-ctl: %-7s tick %u, solver %u, force %+.2f N, overruns %u   ",
					swell_ctl_state_name(p.c.state), p.c.n.ticks, p.c.n.solver_steps,
					p.c.force_dev_uN[2] / 1e6, p.c.n.overruns);
		}
	}
	/* zero force first, then everything else. It is the last force the device gets: a full transmit
	 * queue (CAN TX queue, USB IN slots) must not drop it as it may drop a tick's, so it is tried
	 * again for up to 100 ms. */
	swell_ctl_zero_force(&p.c);
	{
		struct swell_msg m[SWELL_CTL_QUEUE];
		size_t n = swell_ctl_tx(&p.c, SWELL_LINK_DEVICE, m, SWELL_CTL_QUEUE);

		if (n && ctl_link_send_wait(&p.dev, m, n, 100) != 0)
			fprintf(stderr, "swell-ctl: warning: device link %s refused the zero force for 100 ms\n",
				p.dev.name);
	}
	flush_output(&p);
	if (!o.quiet)
		fputc('\n', stderr);
	if (swell_ctl_bootloader_requested(&p.c))
		fprintf(stderr,
			"swell-ctl: enter-bootloader accepted in state %s: force zeroed, last heartbeat "
			"sent; exiting with status 3 (no ROM bootloader on Linux: the supervisor flashes "
			"and starts the new image)\n",
			swell_ctl_state_name(p.c.state));

	report(&o, &p, &jit, ticks, (now_ns() - start) / 1e9, peak_h);
	ctl_link_close(&p.dev);
	if (p.have_host)
		ctl_link_close(&p.host);
	free(arena);
	return swell_ctl_bootloader_requested(&p.c) ? 3 : 0;
}
