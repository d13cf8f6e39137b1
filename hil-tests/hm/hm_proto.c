/* swell-hm's device side of the swell protocol over the host links (UDP, SocketCAN, USB): a sample
 * out and the controller's commands in every tick; see hm_main.h. */
#include <errno.h>
#include <math.h>
#include <string.h>
#include <time.h>

#include "hm_client.h"
#include "hm_main.h"
#include "swell/effect.h"
#include "swell/force_safety.h"
#include "swell/link.h"
#include "swell/proto.h"
#include "swell/transport.h"

/* v rounded (half up) and saturated to +-lim for the wire: never a NaN (the checked parameters keep
 * the model finite) */
static int16_t sat(double v, double lim)
{
	double r = floor(v + 0.5);

	return r != r ? 0 : (int16_t)(r > lim ? lim : r < -lim ? -lim : r);
}

#define sat16(v) sat((v), 30000.0)

/* ---- link ---- */

/* State -> force command latency at the device: wall time from sending a sample (DEVICE_POS) to the
 * first FORCE_CMD that arrives after it: both carriers, the controller's wake-up and its tick. 1 us bins
 * up to 50 ms, later in the last. */
#define LAT_US 50000
static struct latency {
	uint32_t hist[LAT_US + 1];
	uint64_t n;
	int64_t max_ns, sent_ns;
	int pending;
} lat;

static void latency_answer(void)
{
	const int64_t d = now_ns() - lat.sent_ns;

	if (!lat.pending)
		return;
	lat.pending = 0;
	lat.hist[d / 1000 > LAT_US ? LAT_US : d / 1000]++;
	lat.n++;
	if (d > lat.max_ns)
		lat.max_ns = d;
}

/* --link-delay: up to 1 s of a controller's traffic at 2500 Hz (a FORCE_CMD a tick, heartbeats) */
#define DELAY_HELD 4096

struct dev {
	struct swell_link *l;
	enum swell_carrier carrier;
	uint8_t node;
	struct swell_proto_stats st;
	struct swell_seq force_seq;
	uint32_t commands, heartbeats, ignored, send_errors;
	int ctl_state; /* last HEARTBEAT state, -1 before the first */
	uint32_t ctl_faults; /* heartbeats that showed the controller entering FAULT */
	uint32_t fault_beats; /* heartbeats in FAULT */
	int ctl_err; /* the last error of the last heartbeat in FAULT */
	uint8_t force_seq_last;
	/* effect mode: the last complete set, its age in ticks, the limit stage on its force */
	struct swell_effect_rx erx;
	struct swell_effect eff;
	int have_eff;
	uint32_t eff_age, eff_fresh_ticks;
	uint32_t eff_sets, eff_ticks, eff_stale; /* sets taken, ticks rendered, times one went stale */
	uint32_t eff_step_max_uN; /* largest change an update made to the effects' force, before the limits */
	uint32_t eff_settle_ticks; /* steps counted once this many ticks have been rendered (1 s) */
	struct swell_fsafety eff_safety;
	/* arrival side (before the delay): sets are coming (a complete one came, no disabled FORCE_CMD
	 * since), the receiver that tells, and the last sample's tick */
	struct swell_effect_rx arrive_rx;
	int sets_coming, answer_set;
	uint8_t set_seq; /* the last set's seq, its arrival tick, the spacing before it */
	uint64_t set_tick;
	uint32_t set_spacing, set_agree, learned; /* learned: three spacings in a row agreed (lockstep) */
	int waiting, set_on_time; /* in a lockstep wait now; the last set came as the answer to a sample */
	uint64_t tick, last_sample, samples;
	/* --link-delay: what arrived, acted on at tick due */
	struct held {
		struct swell_msg m;
		uint64_t due;
	} held[DELAY_HELD];
	uint32_t held_head, held_n, held_dropped, delay_ticks;
	uint32_t rx_type[256], tx_type[256]; /* messages by type over the run (one classic CAN frame each) */
};

static void dev_send(struct dev *d, const struct swell_msg *m, size_t n, uint8_t seq)
{
	size_t k;

	for (k = 0; k < n; k++)
		d->tx_type[m[k].type]++;
	d->send_errors += hm_node_send(d->l, d->node, seq, m, n);
}

/* Acts on one message from the controller (after the link delay). */
static void act(struct dev *d, struct hm_state *s, const struct swell_msg *m)
{
	static const double none[3] = { 0.0, 0.0, 0.0 };
	struct swell_effect next;
	int er;

	if (m->type == SWELL_MSG_FORCE_CMD) {
		const struct swell_msg_force_cmd *c = &m->u.force_cmd;
		double fN[3] = { c->fx_cN * 0.01, c->fy_cN * 0.01, c->fz_cN * 0.01 };

		swell_seq_track(&d->force_seq, c->seq);
		d->force_seq_last = c->seq;
		hm_command(s, fN, c->enable);
		if (!c->enable)
			d->have_eff = 0; /* not running (fault, stop, mode change): the effects go at once */
		d->commands++;
	} else if ((er = swell_effect_recv(&d->erx, m, &next)) >= 0) {
		if (er == 1) { /* the three parts of one update are in: the set is the command, its freshness
				* limit the watchdog (the controller sends no FORCE_CMD while sets come) */
			/* the step the update makes at the device's state, once sets have been rendered for a
			 * second (the first sets of a run start from a water at rest under a placed object) */
			if (d->have_eff && d->eff_age < d->eff_fresh_ticks && d->eff_ticks >= d->eff_settle_ticks) {
				const int16_t z = sat16(s->x[2] * 1e5), v = sat16(s->v[2] * 1e4);
				const int64_t step = (int64_t)swell_effect_force_uN(&next, z, v) -
					swell_effect_force_uN(&d->eff, z, v);
				const uint32_t mag = (uint32_t)(step < 0 ? -step : step);

				d->eff_step_max_uN = mag > d->eff_step_max_uN ? mag : d->eff_step_max_uN;
			}
			d->eff = next;
			d->have_eff = 1;
			d->eff_age = 0;
			d->eff_sets++;
			hm_command_for(s, none, 1, d->eff_fresh_ticks);
		}
	} else if (m->type == SWELL_MSG_HEARTBEAT) {
		if (m->u.heartbeat.state == 4) {
			d->ctl_faults += d->ctl_state != 4;
			d->fault_beats++;
			d->ctl_err = m->u.heartbeat.err;
		}
		d->ctl_state = m->u.heartbeat.state;
		d->heartbeats++;
	} else {
		d->ignored++;
	}
}

/* Acts on what the link delay has held until this tick. */
static void deliver(struct dev *d, struct hm_state *s)
{
	while (d->held_n && d->held[d->held_head].due <= d->tick) {
		act(d, s, &d->held[d->held_head].m);
		d->held_head = (d->held_head + 1) % DELAY_HELD;
		d->held_n--;
	}
}

/* Takes one frame if one comes within timeout_ms; returns the number of answers in it (FORCE_CMDs and
 * completed effect sets), -1 when nothing came. What came is acted on at once, or with --link-delay
 * held until its tick (deliver). */
static int dev_recv(struct dev *d, struct hm_state *s, int timeout_ms)
{
	struct swell_frame f;
	struct swell_msg m[SWELL_CANFD_MSGS_MAX];
	struct swell_effect set;
	size_t n = 0, k;
	int answers = 0;

	if (swell_link_recv(d->l, &f, timeout_ms) < 0)
		return -1;
	if (swell_link_decode(d->carrier, &f, m, SWELL_CANFD_MSGS_MAX, &n, NULL, &d->st) != SWELL_OK)
		return 0; /* counted in st, never acted on */
	for (k = 0; k < n; k++) {
		if (m[k].node != d->node) {
			d->ignored++;
			continue;
		}
		d->rx_type[m[k].type]++;
		if (m[k].type == SWELL_MSG_FORCE_CMD) {
			latency_answer();
			answers++;
			d->answer_set = 0;
			if (!m[k].u.force_cmd.enable)
				d->sets_coming = 0;
		} else if (swell_effect_recv(&d->arrive_rx, &m[k], &set) == 1) {
			/* the spacing of two sets that both came on time (as the answer to a sample; a late
			 * one, after a timeout, would make it longer) and with consecutive seqs */
			if (d->waiting && d->set_on_time && d->sets_coming && set.seq == (uint8_t)(d->set_seq + 1u) &&
			    !d->learned) {
				const uint32_t sp = (uint32_t)(d->tick - d->set_tick);

				d->set_agree = sp > 0 && sp == d->set_spacing ? d->set_agree + 1u : 0u;
				if (d->set_agree >= 2) /* three in a row; kept from then on */
					d->learned = sp;
				d->set_spacing = sp;
			}
			d->set_seq = set.seq;
			d->set_tick = d->tick;
			d->set_on_time = d->waiting;
			answers++;
			d->answer_set = 1;
			d->sets_coming = 1;
		}
		if (d->delay_ticks == 0) {
			act(d, s, &m[k]);
		} else if (d->held_n == DELAY_HELD) {
			d->held_dropped++;
		} else {
			struct held *h = &d->held[(d->held_head + d->held_n) % DELAY_HELD];

			h->m = m[k];
			h->due = d->tick + d->delay_ticks;
			d->held_n++;
		}
	}
	return answers;
}

/* Effect mode, every tick before the model steps: the force the last effect set produces at the
 * position and velocity the device reports (0.01 mm, 0.1 mm/s, as on the wire), through the device's
 * own limit stage (the set's F_max and rate). Rendered only while the set is fresh (eff_age below
 * the freshness limit) and the controller's FORCE_CMD enables it; the model then applies it under the
 * command's watchdog and e-stop (hm_model.h). Otherwise the stage drops to zero at once. */
static void effect_tick(struct dev *d, struct hm_state *s, const struct hm_params *p)
{
	int32_t f_uN = 0;
	int on = d->have_eff && d->eff_age < d->eff_fresh_ticks && s->cmd_enable;

	if (d->have_eff && d->eff_age == d->eff_fresh_ticks)
		d->eff_stale++;
	if (on) {
		const struct swell_fsafety_params sp = { SWELL_Q16_ONE, d->eff.fmax_cN * 10000u,
							 d->eff.rate_100mN_s * 100000u, (uint32_t)p->rate_hz };

		if (swell_fsafety_set(&d->eff_safety, &sp) != SWELL_OK)
			on = 0;
		else
			f_uN = swell_effect_force_uN(&d->eff, sat16(s->x[2] * 1e5), sat16(s->v[2] * 1e4));
	}
	s->effect_N[0] = s->effect_N[1] = 0.0;
	s->effect_N[2] = swell_fsafety_apply(&d->eff_safety, f_uN, on) * 1e-6;
	d->eff_ticks += on != 0;
	if (d->have_eff && d->eff_age < UINT32_MAX)
		d->eff_age++;
}

/* DEVICE_VEL, DEVICE_FORCE (the force sensor under the handle: what the hand pushes) and DEVICE_POS
 * every tick, POS last: swell-ctl --clock device ticks on POS, so the rest of the sample is in by
 * then. DEVICE_FORCE only where the carrier has room, i.e. not on classic CAN at 2500 Hz. */
static void sample(struct dev *d, const struct hm_state *s, const double f_hand_N[3], uint8_t seq)
{
	struct swell_msg m[3];
	const int with_force = d->carrier == SWELL_CARRIER_PKT;

	memset(m, 0, sizeof(m));
	m[0].type = SWELL_MSG_DEVICE_VEL;
	m[0].node = d->node;
	m[0].u.device_vel.vx_100ums = sat16(s->v[0] * 1e4);
	m[0].u.device_vel.vy_100ums = sat16(s->v[1] * 1e4);
	m[0].u.device_vel.vz_100ums = sat16(s->v[2] * 1e4);
	m[0].u.device_vel.seq = seq;
	m[1].type = SWELL_MSG_DEVICE_FORCE;
	m[1].node = d->node;
	m[1].u.device_force.fx_cN = sat(f_hand_N[0] * 100.0, 25000.0);
	m[1].u.device_force.fy_cN = sat(f_hand_N[1] * 100.0, 25000.0);
	m[1].u.device_force.fz_cN = sat(f_hand_N[2] * 100.0, 25000.0);
	m[1].u.device_force.seq = seq;
	m[2].type = SWELL_MSG_DEVICE_POS;
	m[2].node = d->node;
	m[2].u.device_pos.x_10um = sat16(s->x[0] * 1e5);
	m[2].u.device_pos.y_10um = sat16(s->x[1] * 1e5);
	m[2].u.device_pos.z_10um = sat16(s->x[2] * 1e5);
	m[2].u.device_pos.seq = seq;
	m[2].u.device_pos.status = SWELL_DEV_POWERED | (s->estop ? SWELL_DEV_ESTOP : SWELL_DEV_FORCE_ON);
	if (!with_force)
		m[1] = m[2];
	lat.sent_ns = now_ns();
	lat.pending = 1;
	d->samples++;
	d->last_sample = d->tick;
	dev_send(d, m, with_force ? 3 : 2, seq);
}

/* Lockstep: the answer to sample n is the first FORCE_CMD or complete effect set after it. Once the
 * controller is lost (the watchdog, or the set's freshness, has dropped its force, and LOST_WAITS
 * waits in a row went unanswered) wait only 1 ms a tick, so that simulated time goes on. A
 * controller that a loaded machine has not scheduled for a while is not lost: it answers within a
 * few waits, and meanwhile the device ticks once a wait, not a thousand times a second. */
#define LOST_WAITS 10u
static void wait_answer(struct dev *d, struct hm_state *s, const struct opts *o, struct run *r, uint64_t n)
{
	int lost = s->cmd_age > hm_cmd_watchdog(&o->p, s) && r->timeouts_in_row >= LOST_WAITS, got = 0;
	int64_t deadline = now_ns() + (int64_t)(lost ? 1 : o->timeout_ms) * 1000000;
	uint8_t off;

	while (!got && !stop_flag) {
		int64_t left = deadline - now_ns();

		if (left <= 0)
			break;
		d->waiting = 1;
		got = dev_recv(d, s, (int)((left + 999999) / 1000000)) > 0;
		d->waiting = 0;
	}
	if (!got) {
		r->timeouts++;
		if (r->timeouts_in_row < UINT32_MAX)
			r->timeouts_in_row++;
		return;
	}
	r->timeouts_in_row = 0;
	if (d->answer_set || d->sets_coming) { /* no FORCE_CMD while sets come: count again after them */
		r->have_offset = 0;
		return;
	}
	/* the controller's FORCE_CMD seq against ours moves only when it ticked without a sample */
	off = (uint8_t)(d->force_seq_last - (uint8_t)n);
	if (!r->have_offset)
		r->offset0 = off;
	else if (off != r->offset)
		r->own_ticks += (uint8_t)(off - r->offset);
	r->offset = off;
	r->have_offset = 1;
}

/* Ticks between samples while effect sets come: --sample-every, or by default every tick in real
 * time and in lockstep the sets' spacing once learned (from sets that came on time; a loop whose
 * answers time out, as on an emulated bus, should be given --sample-every). */
static uint32_t sample_every(const struct opts *o, const struct dev *d)
{
	if (o->sample_every)
		return o->sample_every;
	return o->lockstep && d->learned ? d->learned : 1u;
}

static void summary(const struct opts *o, const struct dev *d, const struct hm_state *s, const struct run *r,
		    double wall_s)
{
	int k;

	summary_head(o, s, r, d->ctl_faults, wall_s);
	printf("  peak force      %.3f N (|F_cmd| applied)\n", r->peak_f_N);
	printf("  commands        %u received, %u lost, %u repeated, %u bad frames, %u send errors, %u other "
	       "messages ignored, %u resyncs\n",
	       d->commands, d->force_seq.lost, d->force_seq.repeated, swell_proto_rejected_total(&d->st),
	       d->send_errors, d->ignored, d->force_seq.resyncs);
	if (o->lockstep)
		printf("  timeouts        %llu (lockstep waits of %u ms without an answer); %llu controller ticks "
		       "between samples, %u before the first (mod 256)\n",
		       (unsigned long long)r->timeouts, o->timeout_ms, (unsigned long long)r->own_ticks, r->offset0);
	else
		print_lateness(r);
	printf("  latency         sample -> command p50 %.0f us, p99 %.0f us, max %.0f us (%llu answers: the first "
	       "FORCE_CMD after each DEVICE_POS, wall clock)\n",
	       hm_hist_pct(lat.hist, LAT_US, lat.n, 0.5), hm_hist_pct(lat.hist, LAT_US, lat.n, 0.99), lat.max_ns / 1e3,
	       (unsigned long long)lat.n);
	printf("  watchdog        %u trips (%u ticks), %llu ticks with an enabled command not applied\n",
	       s->watchdog_trips, o->p.watchdog_ticks, (unsigned long long)r->zeroed_ticks);
	printf("  effects         %u sets, %u ticks rendered, %u went stale (freshness %u ticks); largest step at "
	       "an update %.3f N (the new set against the old at the device's state, before the limits, after the "
	       "first second of sets)\n",
	       d->eff_sets, d->eff_ticks, d->eff_stale, d->eff_fresh_ticks, d->eff_step_max_uN * 1e-6);
	printf("  device link     %llu samples (every %u ticks while sets come), delay %u ticks (%u held messages "
	       "dropped)\n",
	       (unsigned long long)d->samples, sample_every(o, d), d->delay_ticks, d->held_dropped);
	printf("  frames          by type, one classic CAN frame each:");
	for (k = 0; k < 256; k++)
		if (d->rx_type[k] || d->tx_type[k])
			printf(" 0x%02x in %u out %u;", k, d->rx_type[k], d->tx_type[k]);
	printf("\n");
	printf("  walls           %u ticks in a workspace wall\n", s->wall_ticks);
	printf("  controller      last state %d (0 boot, 1 idle, 2 armed, 3 running, 4 fault), %u heartbeats\n",
	       d->ctl_state, d->heartbeats);
	if (d->ctl_faults)
		printf("  FAULTED         the controller faulted %u times (%u heartbeats in FAULT, last error: %s)\n",
		       d->ctl_faults, d->fault_beats, swell_err_str((enum swell_err)d->ctl_err));
}

/* The device loop of the swell protocol: a sample a tick, paced by the controller's answers
 * (--lockstep) or by the clock; the summary at the end. */
int proto_main(struct opts *o, FILE *log, const double x0[3])
{
	static struct run r;
	struct dev d;
	struct hm_state s;
	int rc = 0;
	double dt;
	int64_t start, next, period_ns, last_status;
	uint64_t n, total;

	memset(&d, 0, sizeof(d));
	d.node = (uint8_t)o->node;
	d.ctl_state = -1;
	d.l = hm_node_open(&o->ls, o->port, o->iface, o->host, o->bind_port, "swell-hm", o->link);
	if (!d.l)
		return 1;
	d.carrier = swell_link_carrier(d.l);
	d.eff_fresh_ticks = (uint32_t)lround(o->effect_fresh_ms * 1e-3 * o->p.rate_hz);
	if (d.eff_fresh_ticks < 1)
		d.eff_fresh_ticks = 1;
	d.delay_ticks = (uint32_t)lround(o->link_delay_ms * 1e-3 * o->p.rate_hz);
	d.eff_settle_ticks = (uint32_t)lround(o->p.rate_hz);

	hm_init(&s, x0);
	dt = 1.0 / o->p.rate_hz;
	period_ns = (int64_t)llround(1e9 / o->p.rate_hz);
	total = (uint64_t)llround(o->seconds * o->p.rate_hz);
	fprintf(stderr, "swell-hm: %s, %s at %g Hz, hand %s, m_v %g kg, b_v %g N s/m, watchdog %u ticks\n",
		swell_link_name(d.l), o->lockstep ? "lockstep" : "real time", o->p.rate_hz, hm_hand_name(o->hand.kind),
		o->p.mass_kg, o->p.damping_Ns_m, o->p.watchdog_ticks);
	start = next = last_status = now_ns();
	for (n = 0; n < total && !stop_flag; n++) {
		double t = (double)n * dt, f_hand[3], x[3], v[3];
		uint32_t age;
		int holding;

		s.estop = t >= o->estop_s[0] && t < o->estop_s[1];
		d.tick = n;
		/* commands that came in since the last tick (stale ones included: the latest wins) */
		while (dev_recv(&d, &s, 0) >= 0)
			;
		deliver(&d, &s);
		/* the hand acts on the state of this tick, which the wait below does not change */
		holding = frame_hand_force(o, t, s.x, s.v, f_hand);
		if (!d.sets_coming || n == 0 || n - d.last_sample >= sample_every(o, &d)) {
			sample(&d, &s, f_hand, (uint8_t)n);
			if (o->lockstep)
				wait_answer(&d, &s, o, &r, n);
		}
		if (!o->lockstep) { /* real time: sleep to the next absolute deadline, then take what arrived */
			sleep_deadline(&r, &next, period_ns);
			while (dev_recv(&d, &s, 0) >= 0)
				;
		}
		deliver(&d, &s);
		age = s.cmd_age;
		memcpy(x, s.x, sizeof(x));
		memcpy(v, s.v, sizeof(v));
		effect_tick(&d, &s, &o->p);
		hm_step(&o->p, &s, f_hand);
		account(&r, o, &s, t, holding);
		if (log)
			fprintf(log,
				"%.4f,%.3f,%.3f,%.3f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%.3f,%.3f,%.3f,%d,%u,%d,%d,%d,%."
				"4f\n",
				t, x[0] * 1e3, x[1] * 1e3, x[2] * 1e3, v[0] * 1e3, v[1] * 1e3, v[2] * 1e3, s.f_cmd_N[0],
				s.f_cmd_N[1], s.f_cmd_N[2], f_hand[0], f_hand[1], f_hand[2], s.cmd_enable, age,
				s.applying, d.ctl_state, holding, r.d_port_J * 1e3);
		if (!o->quiet && now_ns() - last_status > 1000000000) {
			last_status = now_ns();
			fprintf(stderr, "\rswell-hm: t %.1f s, z %+.2f mm, F_cmd %+.3f N, ctl %d   ", t, s.x[2] * 1e3,
				s.f_cmd_N[2], d.ctl_state);
		}
	}
	if (!o->quiet && now_ns() - start > 1000000000)
		fputc('\n', stderr);
	if (log && (ferror(log) | fclose(log)) != 0) {
		fprintf(stderr, "swell-hm: writing %s failed: %s\n", o->log, strerror(errno));
		rc = 1;
	}
	summary(o, &d, &s, &r, (now_ns() - start) / 1e9);
	if (d.commands == 0 && d.heartbeats == 0) {
		fprintf(stderr, "swell-hm: no controller answered on %s in %.1f s (no FORCE_CMD, no HEARTBEAT)\n",
			swell_link_name(d.l), (now_ns() - start) / 1e9);
		rc = 1;
	}
	swell_link_close(d.l);
	return rc;
}
