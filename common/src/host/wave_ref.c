#include "swell/wave_ref.h"

void swell_wave_ref_from_fixed(struct swell_wave_ref *r, const struct swell_wave *w, double *storage)
{
	int n = w->nx * w->ny, a;

	r->nx = w->nx;
	r->ny = w->ny;
	r->h = storage;
	r->hp = storage + n;
	r->next = storage + 2 * n;
	r->e_eff = (double)w->e_eff / (double)SWELL_Q30_ONE;
	r->q = (double)w->q / (double)SWELL_Q30_ONE;
	r->steps = 0;
	for (a = 0; a < n; a++) {
		r->h[a] = (double)swell_wave_h(w, (size_t)a) / SWELL_H_ONE_MM;
		/* h(n-1): the solver keeps no h(n) - h(n-1), its own change dh(u) instead (swell/wave.h) */
		r->hp[a] = r->h[a] - (double)swell_wave_dh(w, (size_t)a) / SWELL_H_ONE_MM;
	}
}

/* Height at (i, j) with mirrored ghost cells: h[-1] = h[0], h[n] = h[n-1]. */
static double at(const struct swell_wave_ref *r, int i, int j)
{
	i = i < 0 ? 0 : i >= r->nx ? r->nx - 1 : i;
	j = j < 0 ? 0 : j >= r->ny ? r->ny - 1 : j;
	return r->h[j * r->nx + i];
}

void swell_wave_ref_step(struct swell_wave_ref *r)
{
	int i, j;
	double *t;

	for (j = 0; j < r->ny; j++) {
		for (i = 0; i < r->nx; i++) {
			double c = at(r, i, j);
			double l9 = -6.0 * c + at(r, i - 1, j) + at(r, i + 1, j) + at(r, i, j - 1) + at(r, i, j + 1) +
				0.5 *
					(at(r, i - 1, j - 1) + at(r, i + 1, j - 1) + at(r, i - 1, j + 1) +
					 at(r, i + 1, j + 1));
			int a = j * r->nx + i;

			r->next[a] = c + r->q * (c - r->hp[a] + r->e_eff * l9);
		}
	}
	t = r->hp;
	r->hp = r->h;
	r->h = r->next;
	r->next = t;
	r->steps++;
}

double swell_wave_ref_volume(const struct swell_wave_ref *r)
{
	double s = 0;
	int a;

	for (a = 0; a < r->nx * r->ny; a++)
		s += r->h[a];
	return s;
}
