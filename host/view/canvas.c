/* CPU-drawn overlay pictures, see canvas.h. */
#include "canvas.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "font.h"

const float canvas_ramp_low[3] = { 0.08f, 0.25f, 0.85f };
const float canvas_ramp_mid[3] = { 0.85f, 0.88f, 0.92f };
const float canvas_ramp_high[3] = { 0.85f, 0.12f, 0.08f };

void canvas_ramp(float t, uint8_t rgb[3])
{
	t = fminf(fmaxf(t, -1.0f), 1.0f);
	const float *end = t < 0 ? canvas_ramp_low : canvas_ramp_high;
	float a = fabsf(t);
	for (int k = 0; k < 3; k++)
		rgb[k] = (uint8_t)lroundf(255.0f * (canvas_ramp_mid[k] + (end[k] - canvas_ramp_mid[k]) * a));
}

bool canvas_init(struct canvas *c, int w, int h, int scale)
{
	memset(c, 0, sizeof(*c));
	if (w < 1 || h < 1 || scale < 1)
		return false;
	c->rgba = calloc((size_t)w * (size_t)h, 4);
	c->ink = calloc((size_t)w * (size_t)h, 1);
	if (!c->rgba || !c->ink) {
		canvas_free(c);
		return false;
	}
	c->w = w;
	c->h = h;
	c->scale = scale;
	return true;
}

void canvas_free(struct canvas *c)
{
	free(c->rgba);
	free(c->ink);
	memset(c, 0, sizeof(*c));
}

void canvas_clear(struct canvas *c)
{
	memset(c->rgba, 0, (size_t)c->w * (size_t)c->h * 4);
}

void canvas_fill(struct canvas *c, int x, int y, int w, int h, const uint8_t rgba[4])
{
	int x0 = x < 0 ? 0 : x, y0 = y < 0 ? 0 : y;
	int x1 = x + w > c->w ? c->w : x + w, y1 = y + h > c->h ? c->h : y + h;
	for (int py = y0; py < y1; py++)
		for (int px = x0; px < x1; px++)
			memcpy(c->rgba + ((size_t)py * (size_t)c->w + (size_t)px) * 4, rgba, 4);
}

static void dot(struct canvas *c, int x, int y, int thick, const uint8_t rgb[3])
{
	const uint8_t p[4] = { rgb[0], rgb[1], rgb[2], 255 };
	canvas_fill(c, x - (thick - 1) / 2, y - (thick - 1) / 2, thick, thick, p);
}

void canvas_line(struct canvas *c, int x0, int y0, int x1, int y1, int thick, int dash, const uint8_t rgb[3])
{
	/* Bresenham: every step moves one pixel along the major axis */
	int dx = abs(x1 - x0), dy = -abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
	int err = dx + dy;
	for (int k = 0;; k++) {
		if (dash <= 0 || (k / dash) % 2 == 0)
			dot(c, x0, y0, thick, rgb);
		if (x0 == x1 && y0 == y1)
			break;
		int e2 = 2 * err;
		if (e2 >= dy) {
			err += dy;
			x0 += sx;
		}
		if (e2 <= dx) {
			err += dx;
			y0 += sy;
		}
	}
}

int canvas_char_w(const struct canvas *c)
{
	return SWELL_FONT_CELL_W * c->scale;
}

int canvas_line_h(const struct canvas *c)
{
	return SWELL_FONT_CELL_H * c->scale;
}

void canvas_text_size(const struct canvas *c, const char *s, int *w, int *h)
{
	int lines = 1, longest = 0, cur = 0;
	for (const char *p = s; *p; p++) {
		cur = *p == '\n' ? 0 : cur + 1;
		lines += *p == '\n';
		longest = cur > longest ? cur : longest;
	}
	*w = longest * canvas_char_w(c);
	*h = lines * canvas_line_h(c);
}

int canvas_text(struct canvas *c, int x, int y, const uint8_t rgb[3], const char *s)
{
	int x0 = x < 0 ? 0 : x, y0 = y < 0 ? 0 : y, x1, y1;
	canvas_text_size(c, s, &x1, &y1);
	x1 = x + x1 > c->w ? c->w : x + x1;
	y1 = y + y1 > c->h ? c->h : y + y1;
	for (int py = y0; py < y1; py++)
		if (x1 > x0)
			memset(c->ink + (size_t)py * (size_t)c->w + (size_t)x0, 0, (size_t)(x1 - x0));
	int wdt = swell_font_draw(c->ink, c->w, c->h, x, y, c->scale, s);
	const uint8_t opaque[4] = { rgb[0], rgb[1], rgb[2], 255 };
	for (int py = y0; py < y1; py++)
		for (int px = x0; px < x1; px++)
			if (c->ink[(size_t)py * (size_t)c->w + (size_t)px])
				memcpy(c->rgba + ((size_t)py * (size_t)c->w + (size_t)px) * 4, opaque, 4);
	return wdt;
}

/* Legend layout, in font cells: a title row, the bar beside five labels ("+2.00 MM"). */
#define LEGEND_BAR_ROWS 16
void canvas_legend_size(int scale, int *w, int *h)
{
	*w = (4 + 2 + 9 + 1) * SWELL_FONT_CELL_W * scale;
	*h = (2 + LEGEND_BAR_ROWS + 1) * SWELL_FONT_CELL_H * scale;
}

void canvas_legend(struct canvas *c, float range_mm)
{
	static const uint8_t panel[4] = { 8, 8, 8, 165 }, text[3] = { 225, 232, 240 }, tick[3] = { 225, 232, 240 };
	int cw = canvas_char_w(c), lh = canvas_line_h(c);
	int bar_x = cw, bar_w = 3 * cw, bar_y = 2 * lh, bar_h = LEGEND_BAR_ROWS * lh;

	canvas_clear(c);
	canvas_fill(c, 0, 0, c->w, c->h, panel);
	canvas_text(c, cw, lh / 2, text, "HEIGHT");
	for (int py = 0; py < bar_h; py++) {
		/* top row +range, bottom row -range; each row the colour of its centre */
		float t = 1.0f - 2.0f * ((float)py + 0.5f) / (float)bar_h;
		uint8_t p[4] = { 0, 0, 0, 255 };
		canvas_ramp(t, p);
		canvas_fill(c, bar_x, bar_y + py, bar_w, 1, p);
	}
	for (int k = 0; k <= 4; k++) {
		float v = range_mm * (1.0f - 0.5f * (float)k);
		int y = bar_y + (bar_h - 1) * k / 4;
		char s[24];
		snprintf(s, sizeof(s), v == 0 ? "0 MM" : "%+.2f MM", (double)v);
		canvas_line(c, bar_x + bar_w, y, bar_x + bar_w + cw, y, c->scale, 0, tick);
		canvas_text(c, bar_x + bar_w + 2 * cw, y - lh * 7 / 18, text, s);
	}
}
