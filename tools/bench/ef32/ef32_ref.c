/* ef32's reference kernel: the definition, one edge at a time (ef32.h; ef32_priv.h has flow_ref,
 * the rule for one edge). */
#include "ef32_priv.h"

/* The reference: one edge at a time, the E edges of the row, then the N, NE and NW edges up to the
 * next row; each flow added to its cell and taken from its neighbour at once. */
int32_t ef32_kernel_ref(struct ef32 *w, int j, int i0, int i1, int damp)
{
	const int nx = w->nx;
	const q30_t ce = (j == 0 || j == w->ny - 1) ? w->c_wall : w->c_1;
	const int32_t *h = w->h + j * nx, *hu = h + nx;
	int32_t *v = w->acc + j * nx, *vu = v + nx;
	uint32_t sat = 0;
	int32_t f, any = 0, *fp;
	int i;

	for (i = i0; i < i1 && i + 1 < nx; i++) {
		fp = flows_at(w, i, j);
		fp[FE] = f = flow_ref(fp[FE], h[i + 1] - h[i], ce, w->q, damp, &sat);
		any |= f;
		v[i] += f;
		v[i + 1] -= f;
	}
	for (i = i0; i < i1 && j + 1 < w->ny; i++) {
		fp = flows_at(w, i, j);
		fp[FN] = f =
			flow_ref(fp[FN], hu[i] - h[i], (i == 0 || i == nx - 1) ? w->c_wall : w->c_1, w->q, damp, &sat);
		any |= f;
		v[i] += f;
		vu[i] -= f;
		if (i + 1 < nx) {
			fp[FNE] = f = flow_ref(fp[FNE], hu[i + 1] - h[i], w->c_half, w->q, damp, &sat);
			any |= f;
			v[i] += f;
			vu[i + 1] -= f;
		}
		if (i > 0) {
			fp[FNW] = f = flow_ref(fp[FNW], hu[i - 1] - h[i], w->c_half, w->q, damp, &sat);
			any |= f;
			v[i] += f;
			vu[i - 1] -= f;
		}
	}
	w->saturations += sat;
	return any;
}
