// HUD font: every printable glyph has ink and is distinct, lower case prints as capitals, drawing
// clips at the image edge (checked under ASan).
#include <catch2/catch.hpp>

#include <cstring>
#include <set>
#include <string>
#include <vector>

extern "C" {
#include "font.h"
}

TEST_CASE("every glyph from '!' to '_' has ink and no two glyphs are the same")
{
	std::set<std::string> seen;
	for (char c = '!'; c <= '_'; c++) {
		const uint8_t *g = swell_font_glyph(c);
		int ink = 0;
		for (int r = 0; r < SWELL_FONT_H; r++) {
			CHECK((g[r] & ~0x1fu) == 0);
			for (int k = 0; k < SWELL_FONT_W; k++)
				ink += g[r] >> k & 1;
		}
		INFO("glyph '" << c << "' has " << ink << " ink pixels");
		CHECK(ink >= 2);
		seen.insert(std::string(reinterpret_cast<const char *>(g), SWELL_FONT_H));
	}
	CHECK(seen.size() == size_t('_' - '!' + 1));
	const uint8_t *space = swell_font_glyph(' ');
	for (int r = 0; r < SWELL_FONT_H; r++)
		CHECK(space[r] == 0);
}

TEST_CASE("lower case prints as capitals, other bytes print as a box")
{
	for (char c = 'a'; c <= 'z'; c++)
		CHECK(memcmp(swell_font_glyph(c), swell_font_glyph(char(c - 'a' + 'A')), SWELL_FONT_H) == 0);
	CHECK(memcmp(swell_font_glyph('~'), swell_font_glyph('\x01'), SWELL_FONT_H) == 0);
}

TEST_CASE("drawing a string inks the expected pixels and clips at every edge")
{
	const int w = 40, h = 20;
	std::vector<uint8_t> img(w * h, 0);
	int width = swell_font_draw(img.data(), w, h, 1, 1, 1, "L");
	CHECK(width == SWELL_FONT_CELL_W);
	// 'L': the left column of 7 and the bottom row of 5, sharing one pixel
	int ink = 0;
	for (uint8_t v : img)
		ink += v == 255;
	CHECK(ink == 11);
	CHECK(img[1 * w + 1] == 255);
	CHECK(img[7 * w + 5] == 255);
	CHECK(img[1 * w + 2] == 0);
	// scaled, multi-line and clipped: must not write outside the image (ASan checks)
	width = swell_font_draw(img.data(), w, h, -7, -5, 3, "WWWWWWWW\nMM");
	CHECK(width == 8 * SWELL_FONT_CELL_W * 3);
	swell_font_draw(img.data(), w, h, w - 2, h - 2, 4, "#");
	CHECK(swell_font_draw(img.data(), w, h, 0, 0, 0, "x") == 0);
}
