/* ef32's reference kernel: the definition, one edge at a time (ef32.h; ef32_priv.h has flow_ref,
 * the rule for one edge). */
#include "ef32_priv.h"

/* One edge: its new flow f (from the flow in *fl and the height difference dh), added to the cell's
 * change *va and taken from its neighbour's *vb. */
static void edge(const struct ef32 *w, int32_t *fl, int32_t dh, q30_t c, int damp, int32_t *va, int32_t *vb,
		 uint32_t *sat, int32_t *any)
{
	const int32_t f = *fl = flow_ref(*fl, dh, c, w->q, damp, sat);

	*any |= f;
	*va += f;
	*vb -= f;
}

/* The reference: one edge at a time, the E edges of the row, then the N, NE and NW edges up to the
 * next row; each flow added to its cell and taken from its neighbour at once. */
int32_t ef32_kernel_ref(struct ef32 *w, int j, int i0, int i1, int damp)
{
	const int nx = w->nx;
	const q30_t ce = (j == 0 || j == w->ny - 1) ? w->c_wall : w->c_1;
	const int32_t *h = w->h + j * nx, *hu = h + nx;
	int32_t *v = w->acc + j * nx, *vu = v + nx;
	uint32_t sat = 0;
	int32_t any = 0, *fp;
	int i;

	for (i = i0; i < i1 && i + 1 < nx; i++)
		edge(w, flows_at(w, i, j) + FE, h[i + 1] - h[i], ce, damp, &v[i], &v[i + 1], &sat, &any);
	for (i = i0; i < i1 && j + 1 < w->ny; i++) {
		fp = flows_at(w, i, j);
		edge(w, fp + FN, hu[i] - h[i], (i == 0 || i == nx - 1) ? w->c_wall : w->c_1, damp, &v[i], &vu[i], &sat,
		     &any);
		if (i + 1 < nx)
			edge(w, fp + FNE, hu[i + 1] - h[i], w->c_half, damp, &v[i], &vu[i + 1], &sat, &any);
		if (i > 0)
			edge(w, fp + FNW, hu[i - 1] - h[i], w->c_half, damp, &v[i], &vu[i - 1], &sat, &any);
	}
	w->saturations += sat;
	return any;
}
