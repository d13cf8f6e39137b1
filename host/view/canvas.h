/* An RGBA picture drawn on the CPU for swell-view's overlays (strip charts, the colour-scale legend):
 * rectangles, lines, text in the HUD font. GL-free, so the unit tests check what it draws pixel by
 * pixel; the renderer uploads the finished picture as a texture. Row 0 is the top row. */
#ifndef SWELL_VIEW_CANVAS_H
#define SWELL_VIEW_CANVAS_H

#include <stdbool.h>
#include <stdint.h>

struct canvas {
	int w, h; /* pixels */
	int scale; /* text and line scale: 1, or 2 on screens 700 pixels high or more */
	uint8_t *rgba; /* w * h * 4, straight (not premultiplied) alpha */
	uint8_t *ink; /* w * h coverage scratch for the font */
};

/* The colour scale of the water, shared by the water shader and the legend: blue for -range, a
 * pale neutral for 0, red for +range, linear in between. */
extern const float canvas_ramp_low[3], canvas_ramp_mid[3], canvas_ramp_high[3];
/* t = height / range, clamped to [-1, 1], to 8-bit RGB. */
void canvas_ramp(float t, uint8_t rgb[3]);

/* Allocate a w x h canvas, cleared (transparent). False when out of memory. */
bool canvas_init(struct canvas *c, int w, int h, int scale);
void canvas_free(struct canvas *c);
void canvas_clear(struct canvas *c);

/* A filled rectangle, clipped; rgba[3] is its opacity. */
void canvas_fill(struct canvas *c, int x, int y, int w, int h, const uint8_t rgba[4]);
/* A line of `thick` pixels (a square pen) from (x0, y0) to (x1, y1), opaque; dashed when dash > 0
 * (dash pixels on, dash off). */
void canvas_line(struct canvas *c, int x0, int y0, int x1, int y1, int thick, int dash, const uint8_t rgb[3]);
/* Text in the HUD font at the canvas scale, opaque; returns its width in pixels. */
int canvas_text(struct canvas *c, int x, int y, const uint8_t rgb[3], const char *s);
/* The box text s takes at the canvas scale: its longest line and its lines, in pixels. */
void canvas_text_size(const struct canvas *c, const char *s, int *w, int *h);
/* Width in pixels of one character at the canvas scale, and of a line of text. */
int canvas_char_w(const struct canvas *c);
int canvas_line_h(const struct canvas *c);

/* The colour-scale legend: a vertical colour bar from -range_mm (bottom) to +range_mm (top) with
 * mm labels at both ends, a quarter and the middle, on a dark panel filling the canvas. */
void canvas_legend(struct canvas *c, float range_mm);
/* The canvas size canvas_legend needs at `scale`. */
void canvas_legend_size(int scale, int *w, int *h);

#endif
