/* swell-hm's pacing, figures and summary head, shared by both modes; see hm_main.h. */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <sched.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

#include "hm_client.h"
#include "hm_main.h"

#include "swell/body.h"
#include "swell/link.h"
#include "swell/param_table.h"

/* The watchdog without real-time scheduling: 20 ms of ticks (the default 2 trips on every late tick). */
#define SLOW_WATCHDOG_MS 20

/* SCHED_FIFO and mlockall when asked for. In real time without SCHED_FIFO the ticks are late by
 * milliseconds: unless --watchdog says otherwise the watchdog becomes SLOW_WATCHDOG_MS of ticks, said
 * on stderr. Lockstep needs neither. */
void setup_rt(struct opts *o, int watchdog_given)
{
	struct sched_param sp = { .sched_priority = 70 };
	const char *why = "no --rt";
	char buf[96];
	uint32_t slow;

	if (o->rt) {
		if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
			fprintf(stderr, "swell-hm: warning: mlockall: %s; running without locked memory\n",
				strerror(errno));
		if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0)
			return;
		snprintf(buf, sizeof(buf), "SCHED_FIFO refused: %s", strerror(errno));
		why = buf;
	}
	if (o->lockstep)
		return;
	slow = (uint32_t)llround(o->p.rate_hz * SLOW_WATCHDOG_MS / 1000.0);
	if (!watchdog_given && slow > o->p.watchdog_ticks) {
		fprintf(stderr,
			"swell-hm: real time without real-time scheduling (%s): watchdog %u ticks (%.1f ms) "
			"instead of %u; --watchdog N to choose\n",
			why, slow, slow * 1e3 / o->p.rate_hz, o->p.watchdog_ticks);
		o->p.watchdog_ticks = slow;
	}
}

volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
	(void)sig;
	stop_flag = 1;
}

int64_t now_ns(void)
{
	return (int64_t)swell_link_now_ns();
}

void setup_signals(void)
{
	const struct sigaction sa = { .sa_handler = on_signal };

	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);
}

void print_lateness(const struct run *r)
{
	printf("  tick lateness   p50 %.0f us, p99 %.0f us, max %.0f us; %llu periods lost\n",
	       hm_hist_pct(r->hist, HIST_US, r->ticks, 0.5), hm_hist_pct(r->hist, HIST_US, r->ticks, 0.99),
	       r->late_max_ns / 1e3, (unsigned long long)r->late_ticks);
}

/* Real time: sleep to the next absolute deadline; the lateness of the wake-up goes into r. */
void sleep_deadline(struct run *r, int64_t *next, int64_t period_ns)
{
	struct timespec dl;
	int64_t late;

	*next += period_ns;
	dl.tv_sec = (time_t)(*next / 1000000000);
	dl.tv_nsec = (long)(*next % 1000000000);
	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &dl, NULL) == EINTR && !stop_flag)
		;
	late = now_ns() - *next;
	r->hist[late < 0 ? 0 : late / 1000 > HIST_US ? HIST_US : late / 1000]++;
	if (late > r->late_max_ns)
		r->late_max_ns = late;
	if (late > period_ns) { /* a whole period lost: count it, start again from now */
		r->late_ticks++;
		*next = now_ns();
	}
}

/* The object's static energy at reference-frame z (its bottom, m): its weight m g z, the buoyancy
 * k s (k = rho g a b) whose submersion s is measured from the pool's mean level, which the displaced
 * water raises by a b s / A_pool (so s = -z / (1 - r), r = a b / A_pool, up to full submersion H, where
 * the force stays k H), and the floor's contact spring below -depth (the controller's constants). */
double static_energy_J(const struct opts *o, double z_m)
{
	const double g = 9.81, m = o->obj_mass_g * 1e-3, a = o->obj_a_mm * 1e-3, b = o->obj_b_mm * 1e-3;
	const double h = o->obj_h_mm * 1e-3, depth = o->depth_mm * 1e-3;
	const double k = RHO_KG_M3 * g * a * b, r = a * b / (o->pool_mm[0] * o->pool_mm[1] * 1e-6);
	const double kc = SWELL_BODY_FLOOR_K * 1e-3, fc_max = SWELL_BODY_FLOOR_F_MAX_UN * 1e-6, pc = fc_max / kc;
	double e = m * g * z_m, s = -z_m / (1.0 - r), p;

	if (s > h)
		e += (1.0 - r) * 0.5 * k * h * h + k * h * (-z_m - h * (1.0 - r));
	else if (s > 0)
		e += (1.0 - r) * 0.5 * k * s * s;
	p = -depth - z_m;
	if (p > pc)
		e += 0.5 * kc * pc * pc + fc_max * (p - pc);
	else if (p > 0)
		e += 0.5 * kc * p * p;
	return e;
}

void print_energy(const struct run *r)
{
	printf("  energy          created %.3f mJ at the device's port; W %.3f mJ, D %.3f mJ at the end (the force "
	       "applied times the device's own motion, against the object's static energy)\n",
	       r->d_min_J < 0 ? -r->d_min_J * 1e3 : 0.0, r->w_port_J * 1e3, r->d_port_J * 1e3);
}

/* After a tick: the figures of the summary (z in the reference frame, over the last second). */
void account(struct run *r, const struct opts *o, const struct hm_state *s, double t, int holding)
{
	double fc = sqrt(s->f_cmd_N[0] * s->f_cmd_N[0] + s->f_cmd_N[1] * s->f_cmd_N[1] + s->f_cmd_N[2] * s->f_cmd_N[2]);
	double ref[3], z;
	int k;

	/* the hand's work on what the device renders: the force applied over the tick times the way
	 * the device went (semi-implicit Euler: dx = v(n+1) dt) */
	for (k = 0; k < 3; k++)
		r->w_port_J -= s->f_cmd_N[k] * s->v[k] / o->p.rate_hz;
	frame_from_dev(o, s->x, ref);
	if (r->ticks == 0) {
		double x0[3];

		for (k = 0; k < 3; k++)
			x0[k] = s->x[k] - s->v[k] / o->p.rate_hz;
		frame_from_dev(o, x0, ref);
		r->s0_J = static_energy_J(o, ref[2]);
		frame_from_dev(o, s->x, ref);
	}
	r->d_port_J = r->w_port_J - (static_energy_J(o, ref[2]) - r->s0_J);
	r->d_min_J = r->d_port_J < r->d_min_J ? r->d_port_J : r->d_min_J;
	r->ticks++;
	r->zeroed_ticks += !s->applying && s->cmd_enable;
	r->peak_f_N = fc > r->peak_f_N ? fc : r->peak_f_N;
	if (t < (o->seconds > 1.0 ? o->seconds - 1.0 : 0.0))
		return;
	z = ref[2] * 1e3;
	r->z_min = r->z_n == 0 || z < r->z_min ? z : r->z_min;
	r->z_max = r->z_n == 0 || z > r->z_max ? z : r->z_max;
	r->z_sum += z;
	r->z_n++;
	r->held_late |= holding;
}

/* The summary's head: time run, final position, equilibrium against -m g/k and the level rise. */
/* ctl_faults: the controller's faults the swell-protocol device saw (0 with --serve). */
void summary_head(const struct opts *o, const struct hm_state *s, const struct run *r, uint32_t ctl_faults,
		  double wall_s)
{
	double dt = 1.0 / o->p.rate_hz;
	/* at rest the object floats with k delta = m g, k = rho g a b: delta = m / (rho a b); the water
	 * it displaces raises the pool's mean level by m / (rho A_pool), and delta is measured from it */
	double z_rest = -(o->obj_mass_g * 1e-3) / (RHO_KG_M3 * o->obj_a_mm * o->obj_b_mm * 1e-6) * 1e3;
	double z_level = (o->obj_mass_g * 1e-3 / RHO_KG_M3) / (o->pool_mm[0] * o->pool_mm[1] * 1e-6) * 1e3;

	printf("swell-hm summary\n");
	printf("  ran             %.4f s simulated, %llu ticks at %g Hz, %s, %.3f s wall\n", (double)r->ticks * dt,
	       (unsigned long long)r->ticks, o->p.rate_hz, o->lockstep ? "lockstep" : "real time", wall_s);
	printf("  final position  %+.3f %+.3f %+.3f mm (x y z), velocity %+.2f %+.2f %+.2f mm/s\n", s->x[0] * 1e3,
	       s->x[1] * 1e3, s->x[2] * 1e3, s->v[0] * 1e3, s->v[1] * 1e3, s->v[2] * 1e3);
	if (r->z_n > 0) {
		double zm = r->z_sum / (double)r->z_n;

		printf("  equilibrium z   %+.3f mm mean over the last %.3f s (min %+.3f, max %+.3f mm)\n", zm,
		       (double)r->z_n * dt, r->z_min, r->z_max);
		if (r->held_late) {
			printf("  expected z      none: the hand held the handle in that second\n");
		} else if (o->obj_mass_g * 1e-3 > RHO_KG_M3 * o->obj_a_mm * o->obj_b_mm * o->obj_h_mm * 1e-9) {
			/* heavier than the water it can displace: it sinks until the floor carries it */
			printf("  expected z      %+.3f mm on the floor: m %.0f g > rho a b H %.0f g (sinks); error "
			       "%+.3f mm\n",
			       -o->depth_mm, o->obj_mass_g, RHO_KG_M3 * o->obj_a_mm * o->obj_b_mm * o->obj_h_mm * 1e-6,
			       zm + o->depth_mm);
		} else {
			if (ctl_faults || s->watchdog_trips)
				printf("  NOT A CLEAN RUN the controller faulted %u times and the watchdog tripped %u "
				       "times: the figures below include those times without force\n",
				       ctl_faults, s->watchdog_trips);
			printf("  expected z      %+.3f mm = -m g/k; error %+.3f %%\n", z_rest,
			       (zm - z_rest) / -z_rest * 100.0);
			printf("  with level rise %+.3f mm (-m g/k + %.3f mm mean level rise); error %+.3f %%\n",
			       z_rest + z_level, z_level, (zm - z_rest - z_level) / -(z_rest + z_level) * 100.0);
		}
	}
	print_energy(r);
}

/* the reference frame's origin in the pool: the controller's default offset */
static const double ref_off_mm[3] = { SWELL_PARAM_DEF_FRAME_X0 * 1e-3, SWELL_PARAM_DEF_FRAME_Y0 * 1e-3,
				      SWELL_PARAM_DEF_FRAME_Z0 * 1e-3 };

void frame_from_dev(const struct opts *o, const double dev_m[3], double ref_m[3])
{
	int k;

	for (k = 0; k < 3; k++)
		ref_m[k] = (o->frame_off_mm[k] - ref_off_mm[k]) * 1e-3 +
			o->frame_sign[k] * o->frame_scale * dev_m[o->frame_axis[k]];
}

void frame_to_dev(const struct opts *o, const double ref_m[3], double dev_m[3])
{
	int k;

	for (k = 0; k < 3; k++)
		dev_m[o->frame_axis[k]] =
			(ref_m[k] - (o->frame_off_mm[k] - ref_off_mm[k]) * 1e-3) / (o->frame_sign[k] * o->frame_scale);
}

int frame_hand_force(struct opts *o, double t, const double x_dev[3], const double v_dev[3], double f_dev[3])
{
	double x[3], v[3], f[3];
	int k, holding;

	frame_from_dev(o, x_dev, x);
	for (k = 0; k < 3; k++)
		v[k] = o->frame_sign[k] * o->frame_scale * v_dev[o->frame_axis[k]];
	holding = hm_hand_force(&o->hand, t, x, v, f);
	for (k = 0; k < 3; k++)
		f_dev[o->frame_axis[k]] = o->frame_sign[k] * f[k];
	return holding;
}
