/* Live strip charts, see chart.h. */
#include "chart.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

/* Layout in font cells (canvas_char_w x canvas_line_h): CHART_COLS wide; each chart a title row
 * and CHART_PLOT_ROWS of plot, half a row apart; one row of time labels under the last. */
#define CHART_COLS 30
#define CHART_LABEL_COLS 6
#define CHART_PLOT_ROWS 4

static const uint8_t col_fz[3] = { 90, 200, 255 }, col_fabs[3] = { 255, 170, 60 }, col_limit[3] = { 255, 70, 70 };
static const uint8_t col_bottom[3] = { 255, 150, 30 }, col_water[3] = { 80, 150, 255 };
static const uint8_t col_subm[3] = { 110, 220, 130 }, col_rate[3] = { 220, 220, 230 }, col_lat[3] = { 240, 210, 80 };
static const uint8_t col_created[3] = { 255, 90, 200 }, col_balance[3] = { 120, 230, 230 };
static const uint8_t col_text[3] = { 200, 210, 220 }, col_grid[3] = { 70, 78, 88 }, col_axis[3] = { 120, 128, 140 };

bool charts_init(struct charts *c, float force_limit_N)
{
	memset(c, 0, sizeof(*c));
	c->force_limit_N = force_limit_N;
	for (int k = 0; k < CHART_SERIES; k++) {
		c->ring[k].s = calloc(CHART_CAP, sizeof(struct chart_sample));
		if (!c->ring[k].s) {
			charts_free(c);
			return false;
		}
	}
	return true;
}

void charts_free(struct charts *c)
{
	for (int k = 0; k < CHART_SERIES; k++)
		free(c->ring[k].s);
	if (c->csv)
		fclose(c->csv);
	memset(c, 0, sizeof(*c));
}

bool charts_csv_open(struct charts *c, const char *path, char *err, size_t errlen)
{
	c->csv = fopen(path, "w");
	if (!c->csv) {
		snprintf(err, errlen, "--csv %s: %s", path, strerror(errno));
		return false;
	}
	/* one row a received sample; a column is empty when the row's message does not carry it */
	fputs("t_s,pose_seq,bottom_mm,water_mm,submersion_pct,fz_N,f_abs_N,limited,frame_hz,latency_ms,lost_poses,"
	      "created_mJ,balance_mJ\n",
	      c->csv);
	return true;
}

static void push(struct charts *c, enum chart_series k, uint64_t t_us, float v, bool gap)
{
	struct chart_ring *r = &c->ring[k];
	r->s[r->head] = (struct chart_sample){ .t_us = t_us, .v = v, .gap = gap };
	r->head = (r->head + 1u) % CHART_CAP;
	if (r->n < CHART_CAP)
		r->n++;
}

/* One CSV row, when a file is open. */
static void csv_row(struct charts *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void csv_row(struct charts *c, const char *fmt, ...)
{
	va_list ap;

	if (!c->csv)
		return;
	va_start(ap, fmt);
	vfprintf(c->csv, fmt, ap);
	va_end(ap);
	c->csv_rows++;
}

/* A pose's or force's sequence number after *last: whether its sample starts a new line (the first,
 * or one after a loss), the loss counted into *lost. */
static bool seq_gap(struct charts *c, bool *have, uint8_t *last, uint8_t seq, uint32_t *lost)
{
	uint8_t d = (uint8_t)(seq - *last);
	bool gap = !*have || d != 1;
	if (*have && d > 1 && d < 128)
		*lost += swell_seq_loss(d - 1u, &c->resyncs);
	*have = true;
	*last = seq;
	return gap;
}

void charts_restart(struct charts *c)
{
	c->have_pose = c->have_force = false;
}

void charts_pose(struct charts *c, uint64_t t_us, uint8_t seq, float bottom_mm, float water_mm, float submersion_pct)
{
	bool gap = seq_gap(c, &c->have_pose, &c->pose_seq, seq, &c->lost_poses);
	push(c, CHART_BOTTOM, t_us, bottom_mm, gap);
	push(c, CHART_WATER, t_us, water_mm, gap);
	push(c, CHART_SUBMERSION, t_us, submersion_pct, gap);
	csv_row(c, "%.6f,%u,%.2f,%.3f,%.1f,,,,,,%u,,\n", (double)t_us * 1e-6, seq, (double)bottom_mm, (double)water_mm,
		(double)submersion_pct, c->lost_poses);
}

void charts_force(struct charts *c, uint64_t t_us, uint8_t seq, float fx_N, float fy_N, float fz_N, unsigned limited)
{
	bool gap = seq_gap(c, &c->have_force, &c->force_seq, seq, &c->lost_forces);
	float fabs_N = sqrtf(fx_N * fx_N + fy_N * fy_N + fz_N * fz_N);
	push(c, CHART_FZ, t_us, fz_N, gap);
	push(c, CHART_FABS, t_us, fabs_N, gap);
	csv_row(c, "%.6f,%u,,,,%.2f,%.3f,%u,,,,,\n", (double)t_us * 1e-6, seq, (double)fz_N, (double)fabs_N, limited);
}

void charts_latency(struct charts *c, uint64_t t_us, float ms)
{
	const struct chart_ring *r = &c->ring[CHART_LATENCY];
	bool gap = r->n == 0 || t_us - r->s[(r->head + CHART_CAP - 1u) % CHART_CAP].t_us > CHART_GAP_US;
	push(c, CHART_LATENCY, t_us, ms, gap);
	csv_row(c, "%.6f,,,,,,,,,%.2f,,,\n", (double)t_us * 1e-6, (double)ms);
}

void charts_energy(struct charts *c, uint64_t t_us, float created_mJ, float balance_mJ, unsigned acting)
{
	const struct chart_ring *r = &c->ring[CHART_CREATED];
	/* 10 Hz: joined unless silence came between */
	bool gap = r->n == 0 || t_us - r->s[(r->head + CHART_CAP - 1u) % CHART_CAP].t_us > CHART_GAP_US;
	(void)acting;
	push(c, CHART_CREATED, t_us, created_mJ, gap);
	push(c, CHART_BALANCE, t_us, balance_mJ, gap);
	csv_row(c, "%.6f,,,,,,,,,,,%.3f,%.2f\n", (double)t_us * 1e-6, (double)created_mJ, (double)balance_mJ);
}

void charts_tick(struct charts *c, uint64_t now_us, uint32_t frames_total)
{
	if (!c->have_rate) {
		c->have_rate = true;
		c->rate_t_us = now_us;
		c->rate_frames = frames_total;
		return;
	}
	if (now_us - c->rate_t_us < CHART_RATE_BIN_US)
		return;
	float hz = (float)(frames_total - c->rate_frames) * 1e6f / (float)(now_us - c->rate_t_us);
	/* a rate is a count over a bin, joined to the bin before it unless the display stalled */
	push(c, CHART_RATE, now_us, hz, now_us - c->rate_t_us > 2 * CHART_RATE_BIN_US);
	csv_row(c, "%.6f,,,,,,,,%.1f,,,,\n", (double)now_us * 1e-6, (double)hz);
	c->rate_t_us = now_us;
	c->rate_frames = frames_total;
}

float charts_water_under(const struct view_model *m, int32_t x_um, int32_t y_um, uint32_t a_um, uint32_t b_um)
{
	if (!m->have_scene || !m->h_mm || m->scene.dx_um == 0)
		return 0;
	int nx = m->scene.nx, ny = m->scene.ny;
	double dx = m->scene.dx_um;
	/* cells whose centres lie under the footprint */
	int i0 = (int)ceil(((double)x_um - a_um / 2.0) / dx - 0.5),
	    i1 = (int)floor(((double)x_um + a_um / 2.0) / dx - 0.5);
	int j0 = (int)ceil(((double)y_um - b_um / 2.0) / dx - 0.5),
	    j1 = (int)floor(((double)y_um + b_um / 2.0) / dx - 0.5);
	i0 = i0 < 0 ? 0 : i0;
	j0 = j0 < 0 ? 0 : j0;
	i1 = i1 >= nx ? nx - 1 : i1;
	j1 = j1 >= ny ? ny - 1 : j1;
	if (i0 > i1 || j0 > j1) {
		int i = (int)floor((double)x_um / dx), j = (int)floor((double)y_um / dx);
		i = i < 0 ? 0 : i >= nx ? nx - 1 : i;
		j = j < 0 ? 0 : j >= ny ? ny - 1 : j;
		return m->h_mm[(size_t)j * (size_t)nx + (size_t)i];
	}
	double s = 0;
	for (int j = j0; j <= j1; j++)
		for (int i = i0; i <= i1; i++)
			s += m->h_mm[(size_t)j * (size_t)nx + (size_t)i];
	return (float)(s / ((double)(i1 - i0 + 1) * (j1 - j0 + 1)));
}

float charts_nice(float x)
{
	static const float mant[] = { 1.0f, 2.0f, 2.5f, 5.0f, 10.0f };
	if (!(x > 0))
		return 1;
	float p = powf(10.0f, floorf(log10f(x)));
	for (unsigned k = 0; k < sizeof(mant) / sizeof(mant[0]); k++)
		if (mant[k] * p >= x * (1 - 1e-6f))
			return mant[k] * p;
	return 10 * p;
}

/* Smallest and largest value of series k inside the window ending at now_us; false if none. */
static bool extent(const struct charts *c, enum chart_series k, uint64_t now_us, float *mn, float *mx)
{
	const struct chart_ring *r = &c->ring[k];
	bool any = false;
	for (uint32_t n = 0; n < r->n; n++) {
		const struct chart_sample *s = &r->s[(r->head + CHART_CAP - r->n + n) % CHART_CAP];
		if (s->t_us > now_us || now_us - s->t_us > CHART_WINDOW_US)
			continue;
		if (!any || s->v < *mn)
			*mn = s->v;
		if (!any || s->v > *mx)
			*mx = s->v;
		any = true;
	}
	return any;
}

void charts_range(const struct charts *c, int chart, uint64_t now_us, float *lo, float *hi, float *step)
{
	float mn = 0, mx = 0, a, b;
	switch (chart) {
	case 0: { /* force: symmetric about 0, the peak of |Fz| and |F| plus 10 %, at least 0.5 N */
		float peak = 0;
		if (extent(c, CHART_FZ, now_us, &a, &b))
			peak = fmaxf(fabsf(a), fabsf(b));
		if (extent(c, CHART_FABS, now_us, &a, &b))
			peak = fmaxf(peak, b);
		*hi = charts_nice(fmaxf(1.1f * peak, 0.5f));
		*lo = -*hi;
		*step = *hi / 2;
		return;
	}
	case 1: { /* heights: both series, 5 % margin, whole grid steps of a quarter of the span */
		bool any = extent(c, CHART_BOTTOM, now_us, &mn, &mx);
		if (extent(c, CHART_WATER, now_us, &a, &b)) {
			mn = any ? fminf(mn, a) : a;
			mx = any ? fmaxf(mx, b) : b;
		}
		float m = 0.05f * fmaxf(mx - mn, 1.0f);
		*step = charts_nice((mx - mn + 2 * m) / 4);
		*lo = *step * floorf((mn - m) / *step);
		*hi = *step * ceilf((mx + m) / *step);
		return;
	}
	case 2:
		*lo = 0;
		*hi = 100;
		*step = 25;
		return;
	case 5: { /* energy: from 0 (or the least D below it) to the peak plus 10 %, at least 1 mJ */
		bool any = extent(c, CHART_CREATED, now_us, &mn, &mx);
		if (extent(c, CHART_BALANCE, now_us, &a, &b)) {
			mn = any ? fminf(mn, a) : a;
			mx = any ? fmaxf(mx, b) : b;
		}
		*hi = charts_nice(fmaxf(1.1f * fmaxf(mx, -mn), 1.0f));
		*lo = mn < 0 ? -*hi : 0;
		*step = *hi / 2;
		return;
	}
	default: { /* rate, latency: from 0 to the peak plus 15 %, at least 10 */
		float peak = 0;
		if (extent(c, chart == 3 ? CHART_RATE : CHART_LATENCY, now_us, &a, &b))
			peak = b;
		*lo = 0;
		*hi = charts_nice(fmaxf(1.15f * peak, 10.0f));
		*step = *hi / 4;
		return;
	}
	}
}

void charts_size(int scale, int *w, int *h)
{
	int cw = 6 * scale, lh = 9 * scale; /* the font's cell */
	*w = CHART_COLS * cw;
	*h = CHART_COUNT * (CHART_PLOT_ROWS * lh + lh + lh / 2) + (CHART_COUNT - 1) * lh / 2 + lh + lh / 2;
}

struct plot {
	int x0, y0, w, h; /* plot area, pixels */
	float lo, hi;
	uint64_t now_us;
};

/* x of the time back_us before now */
static int px_back(const struct plot *p, uint64_t back_us)
{
	double back = (double)back_us / CHART_WINDOW_US;
	return p->x0 + (int)lround((1.0 - back) * (p->w - 1));
}

static int py_of_v(const struct plot *p, float v)
{
	float f = (p->hi - v) / (p->hi - p->lo);
	f = fminf(fmaxf(f, 0), 1);
	return p->y0 + (int)lroundf(f * (float)(p->h - 1));
}

static void draw_series(const struct charts *c, struct canvas *cv, const struct plot *p, enum chart_series k,
			const uint8_t col[3])
{
	const struct chart_ring *r = &c->ring[k];
	bool have_prev = false;
	uint64_t prev_t = 0;
	int px = 0, py = 0;
	for (uint32_t n = 0; n < r->n; n++) {
		const struct chart_sample *s = &r->s[(r->head + CHART_CAP - r->n + n) % CHART_CAP];
		if (s->t_us > p->now_us || p->now_us - s->t_us > CHART_WINDOW_US) {
			have_prev = false;
			continue;
		}
		int x = px_back(p, p->now_us - s->t_us), y = py_of_v(p, s->v);
		if (have_prev && !s->gap && s->t_us - prev_t <= CHART_GAP_US)
			canvas_line(cv, px, py, x, y, cv->scale, 0, col);
		else
			canvas_line(cv, x, y, x, y, cv->scale, 0, col);
		have_prev = true;
		prev_t = s->t_us;
		px = x;
		py = y;
	}
}

static void label(struct canvas *cv, const struct plot *p, float v)
{
	char s[16];
	int lh = canvas_line_h(cv);
	snprintf(s, sizeof(s), fabsf(v) >= 100 ? "%.0f" : "%.3g", (double)v);
	int w = (int)strlen(s) * canvas_char_w(cv);
	canvas_text(cv, p->x0 - w - canvas_char_w(cv) / 2, py_of_v(p, v) - lh * 7 / 18, col_text, s);
}

void charts_draw(const struct charts *c, struct canvas *cv, uint64_t now_us)
{
	static const uint8_t panel[4] = { 8, 8, 8, 180 }, plot_bg[4] = { 16, 20, 26, 220 };
	/* each chart's title, and its series in drawing order (named in the title last first) */
	static const struct {
		const char *title;
		enum chart_series s[2];
		const char *name[2];
		const uint8_t *col[2];
	} defs[CHART_COUNT] = {
		{ "FORCE N", { CHART_FABS, CHART_FZ }, { "NORM", "Z" }, { col_fabs, col_fz } },
		{ "HEIGHT MM", { CHART_WATER, CHART_BOTTOM }, { "WATER", "BOTTOM" }, { col_water, col_bottom } },
		{ "SUBMERGED %", { CHART_SUBMERSION }, { NULL }, { col_subm } },
		{ "FRAMES /S", { CHART_RATE }, { NULL }, { col_rate } },
		{ "LATENCY MS", { CHART_LATENCY }, { NULL }, { col_lat } },
		{ "ENERGY MJ", { CHART_BALANCE, CHART_CREATED }, { "D", "CREATED" }, { col_balance, col_created } },
	};
	int cw = canvas_char_w(cv), lh = canvas_line_h(cv);

	canvas_clear(cv);
	canvas_fill(cv, 0, 0, cv->w, cv->h, panel);
	for (int k = 0; k < CHART_COUNT; k++) {
		int top = lh / 2 + k * (CHART_PLOT_ROWS * lh + lh + lh / 2 + lh / 2);
		struct plot p = { .x0 = CHART_LABEL_COLS * cw,
				  .y0 = top + lh + lh / 2,
				  .w = cv->w - CHART_LABEL_COLS * cw - cw / 2,
				  .h = CHART_PLOT_ROWS * lh,
				  .now_us = now_us };
		float step;
		charts_range(c, k, now_us, &p.lo, &p.hi, &step);

		/* title and the series' names in their colours */
		int x = cw + canvas_text(cv, cw, top, col_text, defs[k].title) + cw;
		for (int s = 2; s-- > 0;)
			if (defs[k].name[s])
				x += canvas_text(cv, x, top, defs[k].col[s], defs[k].name[s]) + cw;
		if (k == 0) {
			char lim[32];
			snprintf(lim, sizeof(lim), c->force_limit_N <= p.hi ? "LIMIT %g" : "LIMIT %g OFF",
				 (double)c->force_limit_N);
			canvas_text(cv, x, top, col_limit, lim);
		}

		canvas_fill(cv, p.x0, p.y0, p.w, p.h, plot_bg);
		for (float v = p.lo; v <= p.hi + step * 0.01f; v += step)
			canvas_line(cv, p.x0, py_of_v(&p, v), p.x0 + p.w - 1, py_of_v(&p, v), 1, 0,
				    fabsf(v) < step * 0.01f ? col_axis : col_grid);
		for (int s = 2; s < 10; s += 2) /* a line every 2 s */
			canvas_line(cv, px_back(&p, (uint64_t)s * 1000000u), p.y0, px_back(&p, (uint64_t)s * 1000000u),
				    p.y0 + p.h - 1, 1, 2 * cv->scale, col_grid);
		label(cv, &p, p.hi);
		label(cv, &p, p.lo);
		if (p.lo < 0 && p.hi > 0 && py_of_v(&p, 0) - p.y0 >= lh && p.y0 + p.h - py_of_v(&p, 0) >= lh)
			label(cv, &p, 0); /* where it does not cover the end labels */

		if (k == 0 && c->force_limit_N <= p.hi)
			for (int sign = 1; sign >= -1; sign -= 2)
				canvas_line(cv, p.x0, py_of_v(&p, sign * c->force_limit_N), p.x0 + p.w - 1,
					    py_of_v(&p, sign * c->force_limit_N), cv->scale, 3 * cv->scale, col_limit);
		for (int s = 0; s < 2 && defs[k].col[s]; s++)
			draw_series(c, cv, &p, defs[k].s[s], defs[k].col[s]);
		if (k == CHART_COUNT - 1)
			for (int s = 0; s <= 10; s += 2) {
				char t[8];
				snprintf(t, sizeof(t), s ? "-%d" : "0 S", s);
				int tx = px_back(&p, (uint64_t)s * 1000000u) - (int)strlen(t) * cw / 2;
				if (tx + (int)strlen(t) * cw > cv->w)
					tx = cv->w - (int)strlen(t) * cw;
				canvas_text(cv, tx, p.y0 + p.h + lh / 4, col_text, t);
			}
	}
}
