/* swell-bench measures; see measure.h. Host-only benchmark code. */
#include "measure.h"

#include <math.h>
#include <stdlib.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

void bench_mode_init(struct bench_mode *md, int nx, int ny, int m, int n)
{
	md->nx = nx;
	md->ny = ny;
	md->m = m;
	md->n = n;
	md->a = m * M_PI / nx;
	md->b = n * M_PI / ny;
	md->S = -8.0 + 2.0 * (1.0 + cos(md->a)) * (1.0 + cos(md->b));
}

double bench_mode_phi(const struct bench_mode *md, int i, int j)
{
	return cos(md->a * (i + 0.5)) * cos(md->b * (j + 0.5));
}

void bench_mode_field(const struct bench_mode *md, double amp, double *h_mm)
{
	int i, j;

	for (j = 0; j < md->ny; j++)
		for (i = 0; i < md->nx; i++)
			h_mm[j * md->nx + i] = amp * bench_mode_phi(md, i, j);
}

void bench_amp_init(struct bench_amp *am, double amp, double e_eff, double q, double S)
{
	am->s = amp;
	am->sp = amp;
	am->e_eff = e_eff;
	am->q = q;
	am->S = S;
	am->steps = 0;
}

void bench_amp_step(struct bench_amp *am)
{
	long double next = am->s + am->q * (am->s - am->sp + am->e_eff * am->S * am->s);

	am->sp = am->s;
	am->s = next;
	am->steps++;
}

double bench_amp_closed(double amp, double omega_dt, long k)
{
	return amp * cos(omega_dt * ((double)k + 0.5)) / cos(omega_dt / 2);
}

double bench_omega_discrete(double e_eff, double S)
{
	double c = 1.0 + e_eff * S / 2.0;

	return (c < -1.0 || c > 1.0) ? NAN : acos(c);
}

double bench_omega_seiche(double e, const struct bench_mode *md)
{
	double kx = (double)md->m / md->nx, ky = (double)md->n / md->ny;

	return M_PI * sqrt(e) * sqrt(kx * kx + ky * ky);
}

void bench_err(const double *x, const double *y, int n, double *linf, double *l2)
{
	double m = 0, s = 0;
	int k;

	for (k = 0; k < n; k++) {
		double d = x[k] - y[k];

		m = fmax(m, fabs(d));
		s += d * d;
	}
	*linf = m;
	*l2 = n > 0 ? sqrt(s / n) : 0;
}

void bench_rng_seed(struct bench_rng *r, uint64_t seed)
{
	r->s = seed ? seed : 0x9E3779B97F4A7C15ull;
}

uint64_t bench_rng_next(struct bench_rng *r)
{
	r->s ^= r->s >> 12;
	r->s ^= r->s << 25;
	r->s ^= r->s >> 27;
	return r->s * 0x2545F4914F6CDD1Dull;
}

double bench_rng_uniform(struct bench_rng *r)
{
	return (double)(bench_rng_next(r) >> 11) / 9007199254740992.0;
}

static int inside(const struct bench_field *f, int i, int j)
{
	return i >= 0 && j >= 0 && i < f->nx && j < f->ny;
}

void bench_push(struct bench_field *f, int i0, int j0, int k, int32_t depth)
{
	int i, j, cells = 0, ring = 0, r;
	int64_t moved, share, rest;

	for (j = j0; j < j0 + k; j++)
		for (i = i0; i < i0 + k; i++)
			if (inside(f, i, j)) {
				bench_field_add_lsb(f, i, j, depth);
				cells++;
			}
	for (j = j0 - 1; j <= j0 + k; j++)
		for (i = i0 - 1; i <= i0 + k; i++)
			if (inside(f, i, j) && (i < i0 || i >= i0 + k || j < j0 || j >= j0 + k))
				ring++;
	if (!ring)
		return;
	moved = -(int64_t)depth * cells;
	share = moved / ring; /* truncates toward zero; the rest goes one LSB at a time */
	rest = moved - share * ring;
	r = 0;
	for (j = j0 - 1; j <= j0 + k; j++)
		for (i = i0 - 1; i <= i0 + k; i++)
			if (inside(f, i, j) && (i < i0 || i >= i0 + k || j < j0 || j >= j0 + k)) {
				int32_t extra = r < llabs(rest) ? (rest > 0 ? 1 : -1) : 0;

				bench_field_add_lsb(f, i, j, (int32_t)share + extra);
				r++;
			}
}

int bench_bounded(struct bench_field *f, double amp_mm, long steps, double growth, uint64_t seed, double *gain)
{
	struct bench_rng rng;
	double *h, m_first = 0, m_last = 0, m0;
	int n = f->nx * f->ny, a, ok = 1;
	long k;

	h = malloc((size_t)n * sizeof(double));
	if (!h)
		return 0;
	bench_rng_seed(&rng, seed);
	for (a = 0; a < n; a++)
		h[a] = amp_mm * (2.0 * bench_rng_uniform(&rng) - 1.0);
	bench_field_set_mm(f, h);
	free(h);
	f->saturations = 0;
	if (f->impl == BENCH_EF32)
		f->ef.saturations = 0;
	m0 = bench_field_max_abs_lsb(f);
	for (k = 1; k <= steps; k++) {
		double m;

		bench_field_step(f);
		m = bench_field_max_abs_lsb(f);
		if (k <= steps / 4)
			m_first = fmax(m_first, m);
		if (k > steps - steps / 4)
			m_last = fmax(m_last, m);
		if (f->saturations || !isfinite(m) || m > 1e6 * m0) {
			ok = 0;
			m_last = isfinite(m) ? m : INFINITY;
			break;
		}
	}
	if (ok && m_last > growth * m_first)
		ok = 0;
	*gain = m_first > 0 ? m_last / m_first : 0;
	return ok;
}

double bench_e_limit(double q)
{
	return (1.0 + q) / (4.0 * q);
}
