/* A 5 x 7 bitmap font for the HUD, drawn for swell: ASCII 32..95 (space, digits, punctuation, capitals);
 * lower-case letters print as capitals, anything else as a filled box. Each glyph cell is 6 x 9 pixels
 * (one column and two rows of spacing). */
#ifndef SWELL_VIEW_FONT_H
#define SWELL_VIEW_FONT_H

#include <stdint.h>

#define SWELL_FONT_W 5
#define SWELL_FONT_H 7
#define SWELL_FONT_CELL_W 6
#define SWELL_FONT_CELL_H 9

/* Row bits of a character, top row first; bit 4 is the leftmost column. */
const uint8_t *swell_font_glyph(char c);

/* Rasterise a string into an 8-bit coverage image (255 = ink) at pixel (x, y), scaled by `scale`;
 * '\n' starts a new line. Pixels outside w x h are clipped. Returns the width drawn in pixels. */
int swell_font_draw(uint8_t *img, int w, int h, int x, int y, int scale, const char *s);

#endif
