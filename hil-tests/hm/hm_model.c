/* The HapticMaster model; see hm_model.h. */
#include "hm_model.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "swell/pool.h"

void hm_params_default(struct hm_params *p)
{
	int k;

	memset(p, 0, sizeof(*p));
	p->rate_hz = SWELL_POOL_TICK_HZ;
	p->mass_kg = 2.0;
	p->damping_Ns_m = 2.0;
	for (k = 0; k < 3; k++)
		p->limit_m[k] = 0.200;
	p->wall_k_N_m = 50000.0;
	p->wall_b_Ns_m = 100.0;
	p->f_max_N = 250.0;
	p->watchdog_ticks = 2;
}

__attribute__((format(printf, 4, 5))) static enum swell_err refuse(enum swell_err e, char *why, size_t n,
								   const char *fmt, ...)
{
	va_list ap;

	if (why && n) {
		va_start(ap, fmt);
		vsnprintf(why, n, fmt, ap);
		va_end(ap);
	}
	return e;
}

enum swell_err hm_params_check(const struct hm_params *p, double stiff_extra_N_m, double damp_extra_Ns_m, char *why,
			       size_t n)
{
	double dt, k_max, w_dt, b_dt;
	int k;

	if (!p)
		return SWELL_EINVAL;
	if (!(p->rate_hz >= 100.0 && p->rate_hz <= 100000.0))
		return refuse(SWELL_ERANGE, why, n, "rate %g Hz outside [100, 100000] Hz", p->rate_hz);
	if (!(p->mass_kg >= 0.01 && p->mass_kg <= 1000.0))
		return refuse(SWELL_ERANGE, why, n, "virtual mass %g kg outside [0.01, 1000] kg", p->mass_kg);
	if (!(p->damping_Ns_m >= 0.0 && p->damping_Ns_m <= 10000.0))
		return refuse(SWELL_ERANGE, why, n, "virtual damping %g N s/m outside [0, 10000] N s/m",
			      p->damping_Ns_m);
	for (k = 0; k < 3; k++)
		if (!(p->limit_m[k] >= 0.001 && p->limit_m[k] <= 0.300)) /* the wire carries +-300 mm */
			return refuse(SWELL_ERANGE, why, n, "workspace limit %g mm outside [1, 300] mm",
				      p->limit_m[k] * 1e3);
	if (!(p->wall_k_N_m > 0.0 && p->wall_b_Ns_m >= 0.0))
		return refuse(SWELL_ERANGE, why, n, "wall stiffness %g N/m must be > 0, damping %g >= 0", p->wall_k_N_m,
			      p->wall_b_Ns_m);
	if (!(p->f_max_N > 0.0 && p->f_max_N <= 250.0)) /* FORCE_CMD carries +-250 N */
		return refuse(SWELL_ERANGE, why, n, "force limit %g N outside (0, 250] N", p->f_max_N);
	if (p->watchdog_ticks < 1 || p->watchdog_ticks > 100000)
		return refuse(SWELL_ERANGE, why, n, "watchdog %u ticks outside [1, 100000]",
			      (unsigned)p->watchdog_ticks);
	if (!(stiff_extra_N_m >= 0.0 && damp_extra_Ns_m >= 0.0))
		return refuse(SWELL_ERANGE, why, n, "hand stiffness %g N/m and damping %g N s/m must be >= 0",
			      stiff_extra_N_m, damp_extra_Ns_m);
	/* semi-implicit Euler on m x'' = -k x - b x': stable for w dt < 2; keep a wide margin so the
	 * stiffest spring (a wall, or the hand) is resolved, and the damping never overshoots a tick */
	dt = 1.0 / p->rate_hz;
	k_max = p->wall_k_N_m > stiff_extra_N_m ? p->wall_k_N_m : stiff_extra_N_m;
	w_dt = sqrt(k_max / p->mass_kg) * dt;
	if (w_dt > 0.5)
		return refuse(SWELL_EUNSTABLE, why, n,
			      "stiffest spring %g N/m on %g kg is not resolved at this rate (w dt > 0.5)", k_max,
			      p->mass_kg);
	b_dt = (p->damping_Ns_m + (p->wall_b_Ns_m > damp_extra_Ns_m ? p->wall_b_Ns_m : damp_extra_Ns_m)) * dt /
		p->mass_kg;
	if (b_dt > 0.5)
		return refuse(SWELL_EUNSTABLE, why, n,
			      "damping %g N s/m on %g kg is too strong for this rate (b dt / m > 0.5)",
			      b_dt * p->mass_kg / dt, p->mass_kg);
	if (why && n)
		why[0] = '\0';
	return SWELL_OK;
}

void hm_init(struct hm_state *s, const double x0_m[3])
{
	memset(s, 0, sizeof(*s));
	memcpy(s->x, x0_m, sizeof(s->x));
}

void hm_command(struct hm_state *s, const double f_N[3], int enable)
{
	memcpy(s->cmd_N, f_N, sizeof(s->cmd_N));
	s->cmd_enable = enable != 0;
	s->have_cmd = 1;
	s->cmd_age = 0;
	s->cmd_watchdog = 0;
}

void hm_command_for(struct hm_state *s, const double f_N[3], int enable, uint32_t watchdog_ticks)
{
	hm_command(s, f_N, enable);
	s->cmd_watchdog = watchdog_ticks;
}

uint32_t hm_cmd_watchdog(const struct hm_params *p, const struct hm_state *s)
{
	return s->cmd_watchdog ? s->cmd_watchdog : p->watchdog_ticks;
}

int hm_cmd_active(const struct hm_params *p, const struct hm_state *s)
{
	return s->have_cmd && s->cmd_enable && !s->estop && s->cmd_age < hm_cmd_watchdog(p, s);
}

static double clamp(double v, double lo, double hi)
{
	return v < lo ? lo : v > hi ? hi : v;
}

/* A face of the workspace: a stiff spring-damper that pushes back and never pulls. */
static double wall_force(const struct hm_params *p, int k, double x, double v)
{
	double lim = p->limit_m[k], f;

	if (x > lim) {
		f = -p->wall_k_N_m * (x - lim) - p->wall_b_Ns_m * v;
		return f < 0.0 ? f : 0.0;
	}
	if (x < -lim) {
		f = -p->wall_k_N_m * (x + lim) - p->wall_b_Ns_m * v;
		return f > 0.0 ? f : 0.0;
	}
	return 0.0;
}

void hm_step(const struct hm_params *p, struct hm_state *s, const double f_user_N[3])
{
	double dt = 1.0 / p->rate_hz;
	int active = hm_cmd_active(p, s), in_wall = 0, k;

	if (!active && s->applying && s->cmd_enable && !s->estop)
		s->watchdog_trips++; /* an enabled command stopped being applied: the controller went silent */
	for (k = 0; k < 3; k++) {
		double f;

		s->f_cmd_N[k] = active ? clamp(s->cmd_N[k] + s->effect_N[k], -p->f_max_N, p->f_max_N) : 0.0;
		s->f_wall_N[k] = wall_force(p, k, s->x[k], s->v[k]);
		in_wall |= s->f_wall_N[k] != 0.0;
		f = f_user_N[k] + s->f_cmd_N[k] + s->f_wall_N[k] - p->damping_Ns_m * s->v[k];
		s->v[k] += f / p->mass_kg * dt;
		s->x[k] += s->v[k] * dt;
	}
	s->applying = active;
	s->wall_ticks += in_wall != 0;
	if (s->cmd_age < UINT32_MAX)
		s->cmd_age++;
	s->ticks++;
}
