/* swell-hm --serve: the HapticMaster's own TCP command interface instead of the swell protocol; see
 * hm_main.h and hm_serve.h. */
#include <math.h>
#include <poll.h>
#include <string.h>

#include "hm_client.h"
#include "hm_cmd.h"
#include "hm_main.h"
#include "hm_serve.h"

static void serve_wait(struct hm_serve *srv, struct hm_dev *dev, const struct opts *o, struct run *r)
{
	uint32_t before = srv->st.requests;
	int64_t deadline = now_ns() + (int64_t)o->timeout_ms * 1000000;

	for (;;) {
		struct pollfd pf[HM_SERVE_CLIENTS + 1];
		int n = 0, k;
		int64_t left;

		hm_serve_poll(srv, dev, now_ns());
		if (srv->st.requests != before || stop_flag)
			return;
		left = deadline - now_ns();
		if (left <= 0)
			break;
		pf[n++] = (struct pollfd){ srv->lfd, POLLIN, 0 };
		for (k = 0; k < HM_SERVE_CLIENTS; k++)
			if (srv->c[k].fd >= 0)
				pf[n++] = (struct pollfd){ srv->c[k].fd, POLLIN, 0 };
		poll(pf, (nfds_t)n, (int)((left + 999999) / 1000000));
	}
	r->timeouts++;
}

static void serve_summary(const struct opts *o, const struct hm_serve *srv, const struct hm_dev *dev,
			  const struct hm_state *s, const struct run *r, double wall_s)
{
	const struct hm_serve_stats *st = &srv->st;

	summary_head(o, s, r, 0, wall_s);
	printf("  peak force      %.3f N (|F| of the effects applied)\n", r->peak_f_N);
	printf("  server          %s: %u clients accepted, %u refused (table full), %u requests, %u commands, "
	       "%u error answers, %u replies\n",
	       srv->name, st->accepted, st->refused_full, st->requests, dev->commands, dev->errors, st->replies);
	printf("  bad clients     %u bad headers (closed), %u binary garbage (answered), %u stalled mid-request "
	       "(dropped), %u not reading (dropped), %u vanished, %u ticks with requests left for the next\n",
	       st->drop_header, st->garbage, st->drop_stalled, st->drop_not_reading, st->vanished, st->deferred_ticks);
	if (o->n_inj)
		printf("  injected        %u connection resets, %u garbage bursts, %u replies delayed\n",
		       st->injected_resets, st->injected_garbage, st->delayed_replies);
	printf("  bytes           %llu in, %llu out\n", (unsigned long long)st->bytes_in,
	       (unsigned long long)st->bytes_out);
	printf("  request age     p50 %.0f us, p99 %.0f us, max %.0f us at application (kernel arrival to the end "
	       "of the step that applies it; %llu ticks)\n",
	       hm_hist_pct(st->age_hist, HM_SERVE_AGE_US, st->ages, 0.5),
	       hm_hist_pct(st->age_hist, HM_SERVE_AGE_US, st->ages, 0.99), st->age_max_ns / 1e3,
	       (unsigned long long)st->ages);
	if (o->lockstep)
		printf("  timeouts        %llu (lockstep waits of %u ms without a request)\n",
		       (unsigned long long)r->timeouts, o->timeout_ms);
	else
		print_lateness(r);
	printf("  device          state %s, %u effects stopped by the watchdog (bias forces zeroed, springs and "
	       "dampers disabled; %u ticks), %u by a vanished client, %u e-stops\n",
	       hm_dev_state_name(dev->state), dev->watchdog_trips, dev->watchdog_ticks, dev->vanished_zeroed,
	       dev->estop_stops);
	printf("  walls           %u ticks in a workspace wall\n", s->wall_ticks);
}

/* --inject: the bench's TCP faults at their simulated times, each announced on stderr. */
static void inject(struct opts *o, struct hm_serve *srv, struct hm_dev *dev, double t)
{
	const char *what;
	int k;

	srv->reply_delay_ns = 0;
	for (k = 0; k < o->n_inj; k++) {
		struct inject *j = &o->inj[k];

		if (j->kind == 'd' && t >= j->at_s && t < j->at_s + j->for_s)
			srv->reply_delay_ns = (int64_t)(j->ms * 1e6);
		if (j->done || t < j->at_s)
			continue;
		j->done = 1;
		what = j->kind == 'd' ? "delay" : j->kind == 'g' ? "garbage" : j->kind == 'r' ? "reset" : "stop";
		fprintf(stderr, "swell-hm: inject %s at %.4f s\n", what, t);
		if (j->kind == 'g')
			hm_serve_inject_garbage(srv);
		else if (j->kind == 'r')
			hm_serve_inject_reset(srv, dev);
		else if (j->kind == 's') {
			char reply[64];

			hm_dev_request(dev, -1, "set state stop", 14, reply, sizeof(reply));
		}
	}
}

/* The device loop with the HapticMaster's TCP interface: each tick, run what the clients sent
 * (answers describe the state before this tick's step), then render the effects and integrate. */
int serve_main(struct opts *o, FILE *log, const double x0[3])
{
	static struct hm_serve srv;
	static struct hm_dev dev;
	static struct run r;
	struct hm_state s;
	char err[160];
	double dt = 1.0 / o->p.rate_hz;
	int64_t start, next, period_ns = (int64_t)llround(1e9 / o->p.rate_hz), last_status;
	uint64_t n, total = (uint64_t)llround(o->seconds * o->p.rate_hz);
	uint32_t requests_seen = 0, req_age = 0;

	if (hm_serve_open(&srv, o->serve, err, sizeof(err)) < 0) {
		fprintf(stderr, "swell-hm: --serve: %s\n", err);
		return 1;
	}
	hm_dev_init(&dev, o->p.rate_hz, o->p.f_max_N);
	dev.inertia_kg = o->p.mass_kg;
	dev.init_fails_calibration = o->uncalibrated;
	dev.watchdog_ticks = (uint32_t)llround(o->bias_watchdog_ms * 1e-3 * o->p.rate_hz);
	if (o->bias_watchdog_ms > 0 && dev.watchdog_ticks == 0)
		dev.watchdog_ticks = 1;
	hm_init(&s, x0);
	fprintf(stderr,
		"swell-hm: serving the HapticMaster interface on %s, %s at %g Hz, hand %s, inertia %g kg, "
		"bias watchdog %u ms\n",
		srv.name, o->lockstep ? "lockstep" : "real time", o->p.rate_hz, hm_hand_name(o->hand.kind),
		dev.inertia_kg, o->bias_watchdog_ms);
	start = next = last_status = now_ns();
	for (n = 0; n < total && !stop_flag; n++) {
		double t = (double)n * dt, f_hand[3], f_fx[3], *x = dev.x_m, *v = dev.v_m_s;
		int holding, k;

		hm_dev_set_estop(&dev, t >= o->estop_s[0] && t < o->estop_s[1]);
		inject(o, &srv, &dev, t);
		/* the state before this tick's step: what the requests read, the log's x and v */
		memcpy(dev.x_m, s.x, sizeof(dev.x_m));
		memcpy(dev.v_m_s, s.v, sizeof(dev.v_m_s));
		holding = frame_hand_force(o, t, s.x, s.v, f_hand);
		memcpy(dev.fmeas_N, f_hand, sizeof(dev.fmeas_N));
		if (o->lockstep)
			serve_wait(&srv, &dev, o, &r);
		else {
			sleep_deadline(&r, &next, period_ns);
			hm_serve_poll(&srv, &dev, now_ns());
		}
		hm_dev_tick(&dev, s.x, s.v, f_fx);
		hm_command(&s, f_fx, 1);
		o->p.mass_kg = dev.inertia_kg;
		hm_step(&o->p, &s, f_hand);
		hm_serve_applied(&srv);
		/* ticks since a request was last run: a silent client shows in the log as a silent
		 * controller does in the swell protocol's command age */
		req_age = srv.st.requests != requests_seen ? 0 : req_age + 1;
		requests_seen = srv.st.requests;
		for (k = 0; k < 3; k++)
			dev.a_m_s2[k] = (s.v[k] - v[k]) / dt;
		account(&r, o, &s, t, holding);
		if (log)
			fprintf(log,
				"%.4f,%.3f,%.3f,%.3f,%.2f,%.2f,%.2f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%d,%d,%d,%d,%d,%."
				"4f\n",
				t, x[0] * 1e3, x[1] * 1e3, x[2] * 1e3, v[0] * 1e3, v[1] * 1e3, v[2] * 1e3, s.f_cmd_N[0],
				s.f_cmd_N[1], s.f_cmd_N[2], f_hand[0], f_hand[1], f_hand[2], (int)req_age,
				hm_serve_clients(&srv), s.applying, (int)dev.state, holding, r.d_port_J * 1e3);
		if (!o->quiet && now_ns() - last_status > 1000000000) {
			last_status = now_ns();
			fprintf(stderr, "\rswell-hm: t %.1f s, z %+.2f mm, F %+.3f N, state %s, %d clients   ", t,
				s.x[2] * 1e3, s.f_cmd_N[2], hm_dev_state_name(dev.state), hm_serve_clients(&srv));
		}
	}
	if (!o->quiet && now_ns() - start > 1000000000)
		fputc('\n', stderr);
	if (log && fclose(log) != 0)
		fprintf(stderr, "swell-hm: writing %s failed\n", o->log);
	serve_summary(o, &srv, &dev, &s, &r, (now_ns() - start) / 1e9);
	hm_serve_close(&srv, &dev);
	return 0;
}
