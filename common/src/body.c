/* Floating object, force law and coupling; see body.h for units, the model and the invariant. */
#include "swell/body.h"

#include <string.h>

#include "swell/pool.h"

#define FP_SHIFT 11 /* Q11 cell units */
#define AREA_SHIFT (2 * FP_SHIFT)
#define FINE_SHIFT 24 /* spring forces: uN * 2^-24 = k_q8 (2^-8) * LSB (2^-16 mm) */
#define Z_LIMIT_LSB ((int32_t)1 << 30)
#define FORCE_LIMIT_UN ((int64_t)1 << 30)

/* Floor division for den > 0. When both fit in int32 the same quotient comes from a 32-bit division
 * (one SDIV on the Cortex-M4, where a 64-bit one is a library call of some hundred instructions). */
static int64_t div_floor(int64_t num, int64_t den)
{
	int64_t q;

	if (num >= INT32_MIN && num <= INT32_MAX && den <= INT32_MAX) {
		const int32_t n = (int32_t)num, d = (int32_t)den, q32 = n / d;

		return (n % d != 0 && n < 0) ? (int64_t)q32 - 1 : q32;
	}
	q = num / den;
	return (num % den != 0 && num < 0) ? q - 1 : q;
}

/* num / den rounded to nearest, ties toward +inf, den > 0. */
static int64_t div_rn(int64_t num, int64_t den)
{
	return div_floor(num + den / 2, den);
}

int32_t swell_um_to_lsb(int64_t um)
{
	/* 2^16 / 1000 = 8192 / 125 */
	if (um > ((int64_t)1 << 40))
		um = (int64_t)1 << 40;
	if (um < -((int64_t)1 << 40))
		um = -((int64_t)1 << 40);
	return swell_sat_i64(div_rn(um * 8192, 125));
}

int32_t swell_lsb_to_um(int64_t lsb)
{
	if (lsb > ((int64_t)1 << 50))
		lsb = (int64_t)1 << 50;
	if (lsb < -((int64_t)1 << 50))
		lsb = -((int64_t)1 << 50);
	return swell_sat_i64(div_rn(lsb * 125, 8192));
}

enum swell_err swell_body_stiffness(const struct swell_body_params *p, int32_t *k_q8)
{
	uint64_t k;

	if (!p || !k_q8)
		return SWELL_EINVAL;
	/* k [uN/mm] = rho [kg/m^3] g [mm/s^2] a [um] b [um] * 1e-12; times 2^8 for Q24.8 */
	if (!swell_muldiv_u64((uint64_t)p->rho_kg_m3 * p->g_mm_s2, (uint64_t)p->a_um * p->b_um * 256u, 1000000000000ull,
			      &k))
		return SWELL_ERANGE;
	if (k == 0 || k > INT32_MAX)
		return SWELL_ERANGE;
	*k_q8 = (int32_t)k;
	return SWELL_OK;
}

static enum swell_err check_scene(const struct swell_body_scene *sc)
{
	if (!sc)
		return SWELL_EINVAL;
	if (sc->dx_um < 100 || sc->dx_um > 1000000)
		return SWELL_ERANGE;
	if (sc->tick_hz < SWELL_TICK_HZ_MIN || sc->tick_hz > SWELL_TICK_HZ_MAX || sc->solver_hz < 1 ||
	    sc->solver_hz > sc->tick_hz)
		return SWELL_ERANGE;
	if (sc->tick_hz % sc->solver_hz != 0 || sc->tick_hz / sc->solver_hz > SWELL_BODY_MAX_K)
		return SWELL_ERANGE;
	return SWELL_OK;
}

static enum swell_err check_params(const struct swell_body_params *p, const struct swell_body_scene *sc)
{
	uint64_t max_side = (uint64_t)SWELL_BODY_MAX_CELLS * sc->dx_um;
	int32_t k_q8;
	enum swell_err err;

	if (!p)
		return SWELL_EINVAL;
	if (p->a_um < SWELL_BODY_MIN_SIDE_UM || p->b_um < SWELL_BODY_MIN_SIDE_UM || p->a_um > max_side ||
	    p->b_um > max_side)
		return SWELL_ERANGE;
	if (p->h_um < SWELL_BODY_MIN_SIDE_UM || p->h_um > SWELL_BODY_MAX_H_UM)
		return SWELL_ERANGE;
	if (p->mass_g < 1 || p->mass_g > SWELL_BODY_MAX_MASS_G)
		return SWELL_ERANGE;
	if (p->rho_kg_m3 < 1 || p->rho_kg_m3 > 20000 || p->g_mm_s2 < 1 || p->g_mm_s2 > 100000)
		return SWELL_ERANGE;
	if (p->damper_uN_per_mm_s > SWELL_BODY_MAX_DAMPER || p->deadband_um > SWELL_BODY_MAX_DEADBAND_UM)
		return SWELL_ERANGE;
	if ((int64_t)p->mass_g * p->g_mm_s2 > FORCE_LIMIT_UN)
		return SWELL_ERANGE;
	err = swell_body_stiffness(p, &k_q8);
	if (err != SWELL_OK)
		return err;
	/* k H in uN: k_q8 * H_lsb / 2^24 */
	if ((((int64_t)k_q8 * swell_um_to_lsb(p->h_um)) >> FINE_SHIFT) > FORCE_LIMIT_UN)
		return SWELL_ERANGE;
	return SWELL_OK;
}

static enum swell_err check_xform(const struct swell_body_xform *xf)
{
	int seen = 0, k;

	if (!xf)
		return SWELL_EINVAL;
	for (k = 0; k < 3; k++) {
		if (xf->axis[k] > 2 || (xf->sign[k] != 1 && xf->sign[k] != -1))
			return SWELL_EINVAL;
		seen |= 1 << xf->axis[k];
	}
	if (seen != 7)
		return SWELL_EINVAL;
	if (xf->scale <= 0 || xf->scale > 16 * SWELL_Q16_ONE)
		return SWELL_ERANGE;
	return SWELL_OK;
}

enum swell_err swell_body_check(const struct swell_body_params *p, const struct swell_body_xform *xf,
				const struct swell_body_scene *sc)
{
	enum swell_err err = check_scene(sc);

	if (err != SWELL_OK)
		return err;
	err = check_params(p, sc);
	if (err != SWELL_OK)
		return err;
	return check_xform(xf);
}

/* The low-pass gain alpha = w / (tick_hz + w), w = 2 pi f_c with 2 pi as 710 / 113 (8e-8 off), Q16
 * rounded to nearest: backward Euler of the RC filter, stable and monotone for every rate. */
static int32_t uw_alpha(uint32_t tick_hz)
{
	const int64_t w = 710 * (int64_t)SWELL_BODY_UW_CORNER_HZ;

	return (int32_t)div_rn(w << 16, 113 * (int64_t)tick_hz + w);
}

/* The floor -d, d = e dx^2 solver_hz^2 / g (eq. 2 solved for the depth), in LSB: e dx^2 2^16 first
 * (um^2 * 2^16, to 2^-16 um^2), then times f^2 / (g 10^6); both 128-bit products, rounded to nearest.
 * Out of the height range: the floor is at -Z_LIMIT (no floor). Runs at init and when e or g change. */
static void floor_update(struct swell_body *b, const struct swell_wave *w)
{
	uint64_t t, d;

	if (w->p.e == b->floor_e && b->p.g_mm_s2 == b->floor_g)
		return;
	b->floor_e = w->p.e;
	b->floor_g = b->p.g_mm_s2;
	b->floor_lsb = -Z_LIMIT_LSB;
	if (w->p.e <= 0 || b->p.g_mm_s2 == 0)
		return;
	if (!swell_muldiv_u64((uint64_t)w->p.e, (uint64_t)b->sc.dx_um * b->sc.dx_um, 1u << 14, &t))
		return;
	if (!swell_muldiv_u64(t, (uint64_t)b->sc.solver_hz * b->sc.solver_hz, (uint64_t)b->p.g_mm_s2 * 1000000u, &d))
		return;
	if (d < (uint64_t)Z_LIMIT_LSB)
		b->floor_lsb = -(int32_t)d;
}

static void apply_params(struct swell_body *b, const struct swell_body_params *p, const struct swell_body_xform *xf)
{
	b->p = *p;
	b->xf = *xf;
	(void)swell_body_stiffness(p, &b->k_q8); /* checked before */
	b->h_lsb = swell_um_to_lsb(p->h_um);
	b->deadband_lsb = swell_um_to_lsb(p->deadband_um);
	b->gravity_uN = -(int32_t)((int64_t)p->mass_g * p->g_mm_s2);
}

static void scan_reset(struct swell_body *b, const struct swell_wave *w)
{
	b->scan_steps = w->steps;
	b->scan_row = 0;
	b->scan_top = INT32_MIN;
	b->scan_sum = 0;
	b->scan_ok = 1;
}

static void scan_adopt(struct swell_body *b, int32_t top, int64_t sum)
{
	b->ceiling_lsb = top;
	b->water_sum = sum;
	b->ceiling_ok = 1;
	b->scans++;
}

/* One pass over the field: the highest surface any interpolation between h(n-1) = h - dh(u)
 * (wave.h) and h(n) = h can show, and sum(h) for the mean level. */
static void scan_field(struct swell_body *b, const struct swell_wave *w)
{
	int32_t top = INT32_MIN;
	int64_t sum = 0;

	swell_wave_ceiling(w, 0, w->ny, &top, &sum);
	scan_adopt(b, top, sum);
}

enum swell_err swell_body_init(struct swell_body *b, const struct swell_body_params *p,
			       const struct swell_body_xform *xf, const struct swell_body_scene *sc,
			       const struct swell_wave *w)
{
	enum swell_err err;

	if (!b || !w)
		return SWELL_EINVAL;
	err = swell_body_check(p, xf, sc);
	if (err != SWELL_OK)
		return err;
	memset(b, 0, sizeof(*b));
	b->sc = *sc;
	b->nx = w->nx;
	b->ny = w->ny;
	b->ticks_per_step = sc->tick_hz / sc->solver_hz;
	b->uw_alpha_q16 = uw_alpha(sc->tick_hz);
	apply_params(b, p, xf);
	floor_update(b, w);
	scan_field(b, w);
	scan_reset(b, w);
	return SWELL_OK;
}

enum swell_err swell_body_set_params(struct swell_body *b, const struct swell_body_params *p,
				     const struct swell_body_xform *xf)
{
	enum swell_err err;

	if (!b)
		return SWELL_EINVAL;
	err = swell_body_check(p, xf, &b->sc);
	if (err != SWELL_OK)
		return err;
	if (b->applied.delta_lsb != 0)
		return SWELL_ESTATE;
	apply_params(b, p, xf);
	return SWELL_OK;
}

void swell_body_solver_stepped(struct swell_body *b, const struct swell_wave *w)
{
	const int64_t area = (int64_t)(b->applied.x1 - b->applied.x0) * (b->applied.y1 - b->applied.y0);

	b->phase = 0;
	b->u_prev = b->u_last;
	/* the water the object wrote in the period just ended: its part of h(n) - h(n-1) from now on */
	b->dep_v = b->dep_sv && area > 0 ? swell_sat_i64(div_rn(b->dep_sv, area)) : 0;
	b->dep_sv = 0;
	/* In the water the ceiling is not needed (and the solver conserves sum(h)): the scan is paid
	 * only in periods when the force law is idle. */
	if (b->wet) {
		b->ceiling_ok = 0;
	} else if (!b->scan_ahead) {
		scan_field(b, w);
	} else if (b->scan_ok && b->scan_steps + 1 == w->steps) {
		/* the rows scanned ahead hold the same h(n+1) and h(n) as now; the rest now */
		swell_wave_ceiling(w, b->scan_row, w->ny, &b->scan_top, &b->scan_sum);
		scan_adopt(b, b->scan_top, b->scan_sum);
	} else {
		b->ceiling_ok = 0; /* in the water during the period: no whole scan in one tick */
	}
	scan_reset(b, w);
}

void swell_body_scan_ahead(struct swell_body *b, const struct swell_wave *w)
{
	b->scan_ahead = 1;
	if (b->scan_steps != w->steps || b->scan_row > w->done_row) /* stepped without us, or started over */
		scan_reset(b, w);
	if (b->wet)
		b->scan_ok = 0;
	if (!b->scan_ok || b->scan_row >= w->done_row)
		return;
	swell_wave_ceiling(w, b->scan_row, w->done_row, &b->scan_top, &b->scan_sum);
	b->scan_row = w->done_row;
}

void swell_body_rescan(struct swell_body *b, const struct swell_wave *w)
{
	scan_field(b, w);
}

void swell_body_springs(int32_t k_q8, int32_t w_lsb, int32_t z_lsb, int32_t h_lsb, int32_t deadband_lsb,
			struct swell_springs *s)
{
	int64_t pull_stretch = (int64_t)w_lsb - z_lsb - deadband_lsb;
	int64_t push_stretch = (int64_t)w_lsb - h_lsb - z_lsb - deadband_lsb;

	s->origin_pull_lsb = w_lsb;
	s->origin_push_lsb = swell_sat_i64((int64_t)w_lsb - h_lsb);
	/* the pulling spring draws the object up toward its origin, from first contact */
	s->pull_fine = pull_stretch > 0 ? (int64_t)k_q8 * pull_stretch : 0;
	/* the pushing spring pushes it away from its origin (down), from full submersion */
	s->push_fine = push_stretch > 0 ? -(int64_t)k_q8 * push_stretch : 0;
}

/* Pose: pool[k] = offset[k] + sign[k] * scale * dev[axis[k]], rounded to nearest um. */
static int32_t map_axis(const struct swell_body_xform *xf, int k, const int32_t dev[3], int offset)
{
	int64_t s = ((int64_t)xf->scale * dev[xf->axis[k]] + (1 << 15)) >> 16;

	return swell_sat_i64((offset ? xf->offset_um[k] : 0) + xf->sign[k] * s);
}

/* Footprint of an object centred at (x, y), clipped to the pool; empty when x0 >= x1 or y0 >= y1. */
static void footprint(const struct swell_body *b, int32_t x_um, int32_t y_um, struct swell_body_fp *f)
{
	int64_t dx = b->sc.dx_um;
	int64_t xa = (int64_t)x_um - b->p.a_um / 2, ya = (int64_t)y_um - b->p.b_um / 2;
	int64_t x0 = div_rn(xa * SWELL_BODY_FP_ONE, dx), x1 = div_rn((xa + b->p.a_um) * SWELL_BODY_FP_ONE, dx);
	int64_t y0 = div_rn(ya * SWELL_BODY_FP_ONE, dx), y1 = div_rn((ya + b->p.b_um) * SWELL_BODY_FP_ONE, dx);
	int64_t xmax = (int64_t)b->nx << FP_SHIFT, ymax = (int64_t)b->ny << FP_SHIFT;

	f->x0 = (int32_t)(x0 < 0 ? 0 : (x0 > xmax ? xmax : x0));
	f->x1 = (int32_t)(x1 < 0 ? 0 : (x1 > xmax ? xmax : x1));
	f->y0 = (int32_t)(y0 < 0 ? 0 : (y0 > ymax ? ymax : y0));
	f->y1 = (int32_t)(y1 < 0 ? 0 : (y1 > ymax ? ymax : y1));
	f->delta_lsb = 0;
}

static int fp_empty(const struct swell_body_fp *f)
{
	return f->x0 >= f->x1 || f->y0 >= f->y1;
}

/* Covered length of cell index c by the interval [e0, e1), Q11. */
static int32_t overlap(int32_t c, int32_t e0, int32_t e1)
{
	int32_t lo = c * (1 << FP_SHIFT), hi = (c + 1) * (1 << FP_SHIFT); /* defined for any sign of c */

	lo = e0 > lo ? e0 : lo;
	hi = e1 < hi ? e1 : hi;
	return hi - lo;
}

/* Area-weighted sums of h(n) and v (the solver's change) under a non-empty footprint
 * (swell_wave_footprint): the two end cells of a row and of a column weighted by their covered
 * length (Q11), the cells between whole. */
static void fp_sums(const struct swell_wave *w, const struct swell_body_fp *f, int64_t *sh, int64_t *sv)
{
	const int32_t i0 = f->x0 >> FP_SHIFT, i1 = (f->x1 - 1) >> FP_SHIFT;
	const int32_t j0 = f->y0 >> FP_SHIFT, j1 = (f->y1 - 1) >> FP_SHIFT;
	const struct swell_wave_area a = { i0,
					   i1,
					   j0,
					   j1,
					   overlap(i0, f->x0, f->x1),
					   overlap(i1, f->x0, f->x1),
					   overlap(j0, f->y0, f->y1),
					   overlap(j1, f->y0, f->y1),
					   1 << FP_SHIFT };

	swell_wave_footprint(w, &a, sh, sv);
}

/* D_c = round(delta * area_c) of the cell whose area weight (Q22) is a: delta <= H < 2^26 and
 * a <= 2^22, so D_c < 2^26. */
static int32_t deposit_of(int32_t delta_lsb, int64_t a)
{
	return (int32_t)(((int64_t)delta_lsb * a + ((int64_t)1 << (AREA_SHIFT - 1))) >> AREA_SHIFT);
}

static int same_rect(const struct swell_body_fp *a, const struct swell_body_fp *b)
{
	return a->x0 == b->x0 && a->x1 == b->x1 && a->y0 == b->y0 && a->y1 == b->y1;
}

/* The weight of cell (i, j) in footprint r (fp_sums' units): 0 outside it. */
static int64_t fp_weight(const struct swell_body_fp *r, int32_t i, int32_t j)
{
	const int32_t oy = overlap(j, r->y0, r->y1), ox = overlap(i, r->x0, r->x1);

	return oy > 0 && ox > 0 ? (int64_t)oy * ox : 0;
}

/* Add D_c(new_delta) - D_c(old_delta) to every cell under f through swell_wave_add (into h at once,
 * the momentum untouched): old_delta 0 puts the water in, new_delta 0 takes it out. Returns the volume
 * added. The water written is also summed with the weights of footprint r (the one the object holds
 * after this coupling), for the object's part of h(n) - h(n-1) (dep_sv). */
static int64_t deposit(struct swell_body *b, struct swell_wave *w, const struct swell_body_fp *f, int32_t new_delta,
		       int32_t old_delta, const struct swell_body_fp *r)
{
	const int same = same_rect(f, r);
	const int32_t scanned = b->scan_ok && b->scan_steps == w->steps ? b->scan_row : 0;
	const int32_t i0 = f->x0 >> FP_SHIFT, i1 = (f->x1 - 1) >> FP_SHIFT;
	const int32_t j0 = f->y0 >> FP_SHIFT, j1 = (f->y1 - 1) >> FP_SHIFT;
	int64_t added = 0;
	int32_t i, j;

	for (j = j0; j <= j1; j++) {
		const int64_t oy = overlap(j, f->y0, f->y1);
		int64_t row = 0;

		for (i = i0; i <= i1; i++) {
			const int64_t a = oy * overlap(i, f->x0, f->x1);
			const int32_t d = deposit_of(new_delta, a) - deposit_of(old_delta, a);

			if (i > i0 && i < i1) { /* the inner cells are wholly covered: one d for all of them */
				swell_wave_add_span(w, i, i1, j, d);
				row += (int64_t)d * (i1 - i);
				for (; d && !same && i < i1; i++)
					b->dep_sv += fp_weight(r, i, j) * d;
				if (same)
					b->dep_sv += a * d * (i1 - i);
				i = i1 - 1;
				continue;
			}
			if (d == 0)
				continue;
			swell_wave_add(w, i, j, d);
			row += d;
			b->dep_sv += (same ? a : fp_weight(r, i, j)) * d;
		}
		added += row;
		if (j < scanned) { /* a row scanned ahead (so finished ahead): the water arrived in h(n+1) at once */
			const size_t a0 = (size_t)j * b->nx;

			b->scan_sum += row; /* exact unless a height saturated (+-1024 mm) */
			for (i = i0; new_delta > 0 && i <= i1; i++) {
				const int32_t next = swell_wave_h(w, a0 + (size_t)i) + swell_wave_dh(w, a0 + (size_t)i);

				b->scan_top = next > b->scan_top ? next : b->scan_top;
			}
		}
	}
	return added;
}

/* The volume a row of f adds when its depth goes from old_delta to new_delta: deposit()'s row sum
 * without the writes. A row's cells have at most three weights: the two end cells and the wholly
 * covered ones between. */
static int64_t row_volume(const struct swell_body_fp *f, int64_t oy, int32_t i0, int32_t i1, int32_t new_delta,
			  int32_t old_delta)
{
	const int64_t a0 = oy * overlap(i0, f->x0, f->x1), a1 = oy * overlap(i1, f->x0, f->x1);
	const int64_t inner = oy * (1 << FP_SHIFT);
	int64_t row = deposit_of(new_delta, a0) - deposit_of(old_delta, a0);

	if (i1 > i0)
		row += deposit_of(new_delta, a1) - deposit_of(old_delta, a1);
	if (i1 > i0 + 1)
		row += (int64_t)(deposit_of(new_delta, inner) - deposit_of(old_delta, inner)) * (i1 - i0 - 1);
	return row;
}

/* deposit()'s volume without the writes: the rows have at most three row sums (the two end rows and
 * the wholly covered ones between), so a few products instead of a pass over the footprint. */
static int64_t deposit_volume(const struct swell_body_fp *f, int32_t new_delta, int32_t old_delta)
{
	const int32_t i0 = f->x0 >> FP_SHIFT, i1 = (f->x1 - 1) >> FP_SHIFT;
	const int32_t j0 = f->y0 >> FP_SHIFT, j1 = (f->y1 - 1) >> FP_SHIFT;
	int64_t v = row_volume(f, overlap(j0, f->y0, f->y1), i0, i1, new_delta, old_delta);

	if (j1 > j0)
		v += row_volume(f, overlap(j1, f->y0, f->y1), i0, i1, new_delta, old_delta);
	if (j1 > j0 + 1)
		v += row_volume(f, 1 << FP_SHIFT, i0, i1, new_delta, old_delta) * (j1 - j0 - 1);
	return v;
}

/* The water the object holds goes from `from` to `to` (delta_lsb 0: nothing); write: into the cells
 * (returns the volume added), else only the volume. Over the same footprint one pass adds the
 * difference of the two deposits to each cell (half the adds of taking the old out and putting the new
 * in; the same water, unless an accumulator saturates at +-2^29). */
static int64_t move_water(struct swell_body *b, struct swell_wave *w, const struct swell_body_fp *from,
			  const struct swell_body_fp *to, int write)
{
	int64_t moved = 0;

	if (from->delta_lsb == 0 && to->delta_lsb == 0)
		return 0;
	if (from->delta_lsb == to->delta_lsb && same_rect(from, to))
		return 0;
	if (from->delta_lsb != 0 && to->delta_lsb != 0 && same_rect(from, to))
		return write ? deposit(b, w, to, to->delta_lsb, from->delta_lsb, to)
			     : deposit_volume(to, to->delta_lsb, from->delta_lsb);
	if (from->delta_lsb != 0)
		moved += write ? deposit(b, w, from, 0, from->delta_lsb, to) : deposit_volume(from, 0, from->delta_lsb);
	if (to->delta_lsb != 0)
		moved += write ? deposit(b, w, to, to->delta_lsb, 0, to) : deposit_volume(to, to->delta_lsb, 0);
	return moved;
}

/* Replace what the object holds in the water by f (f->delta_lsb 0: nothing). later: count the volume
 * and leave the cells for swell_body_place; else the cells get everything not yet placed at once (the
 * same cells as the couplings one by one: the differences telescope). */
static void couple(struct swell_body *b, struct swell_wave *w, const struct swell_body_fp *f, int later)
{
	const struct swell_body_fp *o = &b->applied;
	int64_t gained;

	if ((o->delta_lsb != 0 || f->delta_lsb != 0) && (o->delta_lsb != f->delta_lsb || !same_rect(o, f))) {
		if (later) {
			gained = move_water(b, w, o, f, 0);
			b->v_unplaced += gained;
		} else {
			gained = move_water(b, w, &b->placed, f, 1) - b->v_unplaced;
			b->v_unplaced = 0;
			b->placed = *f;
		}
		b->v_displaced += gained;
		b->water_sum += gained;
		b->applied = *f;
		b->coupled++;
	}
	if (!later)
		swell_body_place(b, w); /* what an earlier coupling kept back, when this one changed nothing */
}

/* The force is vertical in the pool; it goes back to the device axis that drives pool z. */
static void device_force(const struct swell_body *b, struct swell_body_out *out)
{
	out->f_dev_uN[0] = out->f_dev_uN[1] = out->f_dev_uN[2] = 0;
	out->f_dev_uN[b->xf.axis[2]] = swell_sat_i64((int64_t)b->xf.sign[2] * out->f.total_uN);
}

/* u_w through the low-pass, two equal first-order stages (critically damped second order):
 * y += alpha (x - y) for each, in LSB per step * 2^16, rounded to nearest. |u| <= 2^28 (a mean of v,
 * |v| <= 2^28), so every |x - y| < 2^45 and every product < 2^61. At rest each stage stops within
 * 2^15 / alpha of its input (20 for 10 Hz at 2500 Hz), so the output ends below 41 * 2^-16 LSB a
 * step: exactly 0 um/s. */
static int64_t uw_filter(struct swell_body *b, int64_t u)
{
	b->uw1_q16 += swell_shr_rn((u * 65536 - b->uw1_q16) * b->uw_alpha_q16, 16);
	b->uw2_q16 += swell_shr_rn((b->uw1_q16 - b->uw2_q16) * b->uw_alpha_q16, 16);
	return b->uw2_q16;
}

/* LSB per solver step * 2^q -> um/s: 2^-16 mm * solver_hz = solver_hz * 125 / 8192 um/s. */
static int32_t lsb_step_to_um_s(const struct swell_body *b, int64_t u, int q)
{
	return swell_sat_i64(swell_shr_rn(u * (int64_t)b->sc.solver_hz * 125, 13 + q));
}

/* Contact with the floor at penetration p > 0 (LSB) and velocity v (um/s, up): a spring k_c p and a
 * damper b_c (-v) that comes in over the first p_r, so the force is continuous in z; it pushes and
 * never pulls, and never exceeds F_c_max. k_c p: p < 2^31, k_c < 2^24, < 2^55; the damper: |v| < 2^31,
 * b_c < 2^16, min(p, p_r) <= 2^16: < 2^63. */
static int32_t floor_force(int32_t p, int32_t v_um_s)
{
	const int64_t ramp = ((int64_t)SWELL_BODY_FLOOR_RAMP_UM << 16) / 1000; /* um -> LSB, exact for 1000 */
	const int64_t pr = p < ramp ? p : ramp;
	int64_t f = swell_shr_rn((int64_t)SWELL_BODY_FLOOR_K * p, 16);

	f -= div_rn((int64_t)SWELL_BODY_FLOOR_DAMPER * v_um_s * pr, ramp * 1000);
	return (int32_t)(f < 0 ? 0 : (f > SWELL_BODY_FLOOR_F_MAX_UN ? SWELL_BODY_FLOOR_F_MAX_UN : f));
}

static int32_t total_force(const struct swell_body_forces *f)
{
	/* symmetric saturation: a force and its negation are both representable */
	return swell_clamp(swell_sat_i64((int64_t)f->gravity_uN + f->up_uN + f->viscous_uN + f->floor_uN), -INT32_MAX,
			   INT32_MAX);
}

void swell_body_tick(struct swell_body *b, struct swell_wave *w, const int32_t pos_dev_um[3],
		     const int32_t vel_dev_um_s[3], struct swell_body_out *out)
{
	swell_body_tick_force(b, w, pos_dev_um, vel_dev_um_s, out);
	swell_body_couple(b, w);
}

void swell_body_couple(struct swell_body *b, struct swell_wave *w)
{
	if (!b->pending_set)
		return;
	b->pending_set = 0;
	couple(b, w, &b->pending, 0);
	b->wet = b->pending_wet || b->applied.delta_lsb != 0;
}

void swell_body_couple_later(struct swell_body *b, struct swell_wave *w)
{
	/* deposit()'s rows scanned ahead: water there must arrive now, for the scan's sum and ceiling */
	const int scanned = b->scan_ok && b->scan_steps == w->steps && b->scan_row > 0;

	if (!b->pending_set)
		return;
	b->pending_set = 0;
	couple(b, w, &b->pending, (b->pending_wet || b->pending.delta_lsb != 0) && !scanned);
	b->wet = b->pending_wet || b->applied.delta_lsb != 0;
}

void swell_body_place(struct swell_body *b, struct swell_wave *w)
{
	if (b->placed.delta_lsb == b->applied.delta_lsb && same_rect(&b->placed, &b->applied))
		return;
	b->v_unplaced -= move_water(b, w, &b->placed, &b->applied, 1); /* 0 now: the same volume */
	b->placed = b->applied;
}

void swell_body_tick_force(struct swell_body *b, const struct swell_wave *w, const int32_t pos_dev_um[3],
			   const int32_t vel_dev_um_s[3], struct swell_body_out *out)
{
	const uint32_t kk = b->ticks_per_step, k = b->phase;
	struct swell_body_fp f;
	struct swell_springs s;
	int64_t sh, sv, area, u, dv, bs;
	int32_t z, zw, wl, wv, delta, mean;

	memset(out, 0, sizeof(*out));
	out->x_um = map_axis(&b->xf, 0, pos_dev_um, 1);
	out->y_um = map_axis(&b->xf, 1, pos_dev_um, 1);
	out->z_um = map_axis(&b->xf, 2, pos_dev_um, 1);
	out->vz_um_s = map_axis(&b->xf, 2, vel_dev_um_s, 0);
	z = swell_clamp(swell_um_to_lsb(out->z_um), -Z_LIMIT_LSB, Z_LIMIT_LSB);
	b->ticks++;
	if (b->phase < kk)
		b->phase++;
	floor_update(b, w);
	out->floor_lsb = b->floor_lsb;
	out->f.gravity_uN = b->gravity_uN;
	out->f.total_uN = b->gravity_uN;

	footprint(b, out->x_um, out->y_um, &f);
	if (b->applied.delta_lsb == 0 && (fp_empty(&f) || (b->ceiling_ok && z >= b->ceiling_lsb))) {
		/* clear of the water and holding nothing: no surface read, no coupling */
		b->skipped++;
		b->u_last = 0;
		b->uw1_q16 = b->uw2_q16 = 0;
		out->skipped = 1;
		device_force(b, out);
		return;
	}
	if (fp_empty(&f)) {
		/* wholly outside the pool: let go of what it held (no floor out there) */
		b->u_last = 0;
		b->uw1_q16 = b->uw2_q16 = 0;
		b->pending = f; /* empty: delta 0 */
		b->pending_wet = 0;
		b->pending_set = 1;
		device_force(b, out);
		return;
	}

	/* the floor: the water sees the bottom at most down to it, the contact force takes the rest */
	zw = z;
	if (z < b->floor_lsb) {
		zw = b->floor_lsb;
		out->penetration_lsb = b->floor_lsb - z; /* both within +-2^30 */
		out->f.floor_uN = floor_force(out->penetration_lsb, out->vz_um_s);
		b->floor_ticks++;
	}

	/* surface under the footprint, between h(n-1) and h(n) */
	fp_sums(w, &f, &sh, &sv);
	area = (int64_t)(f.x1 - f.x0) * (f.y1 - f.y0);
	wv = swell_sat_i64(div_rn(sv, area) + b->dep_v); /* dep_v: the velocity form's, else 0 */
	wl = swell_sat_i64(div_rn(sh, area) - div_rn((int64_t)wv * (int64_t)(kk - k), kk));
	b->u_last = wv;
	u = (int64_t)b->u_prev + div_rn(((int64_t)wv - b->u_prev) * (int64_t)k, kk);
	out->surface_lsb = wl;
	out->surface_raw_um_s = lsb_step_to_um_s(b, u, 0);
	/* the damper's u_w: low-passed, 2^8 finer than a LSB per step into the conversion */
	out->surface_um_s = lsb_step_to_um_s(b, swell_shr_rn(uw_filter(b, u), 8), 8);

	delta = swell_clamp(swell_sat_i64((int64_t)wl - zw), 0, b->h_lsb);
	out->delta_lsb = delta;

	swell_body_springs(b->k_q8, wl, zw, b->h_lsb, b->deadband_lsb, &s);
	out->origin_pull_lsb = s.origin_pull_lsb;
	out->origin_push_lsb = s.origin_push_lsb;
	out->f.pull_uN = swell_sat_i64((s.pull_fine + ((int64_t)1 << (FINE_SHIFT - 1))) >> FINE_SHIFT);
	out->f.push_uN = swell_sat_i64(-((-s.push_fine + ((int64_t)1 << (FINE_SHIFT - 1))) >> FINE_SHIFT));
	out->f.up_uN = swell_sat_i64((s.pull_fine + s.push_fine + ((int64_t)1 << (FINE_SHIFT - 1))) >> FINE_SHIFT);

	/* damper b_max s (v - u_w), s = delta / H */
	bs = div_rn((int64_t)b->p.damper_uN_per_mm_s * delta, b->h_lsb);
	dv = (int64_t)out->vz_um_s - out->surface_um_s;
	out->f.viscous_uN = swell_clamp(swell_sat_i64(-div_rn(bs * dv, 1000)), -INT32_MAX, INT32_MAX);
	out->f.total_uN = total_force(&out->f);
	device_force(b, out);

	/* coupling: the depth below the mean level of the pool (see body.h), the water column at most */
	mean = swell_sat_i64(div_rn(b->water_sum, (int64_t)b->nx * b->ny));
	f.delta_lsb = swell_clamp(swell_sat_i64((int64_t)mean - zw), 0, b->h_lsb);
	b->pending = f;
	b->pending_wet = delta > 0;
	b->pending_set = 1;
}

int64_t swell_body_invariant(const struct swell_body *b, const struct swell_wave *w)
{
	/* water added goes into h at once: the volume holds it */
	return swell_wave_volume(w) - (b->v_displaced - b->v_unplaced);
}
