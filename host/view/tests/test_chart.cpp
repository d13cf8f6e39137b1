// Strip charts and overlay pictures (GL-free): what the charts keep, where gaps are, the ranges and
// the limit line, the CSV rows, the colour legend; checked on the canvas pixels they draw.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>
#include <cstdlib>
#include <unistd.h>

extern "C" {
#include "canvas.h"
#include "chart.h"
#include "vm.h"
}

namespace {

// The layout of charts_draw at scale 1 (chart.c), from the font cell (6 x 9 px): a chart every
// 4 + 1 + 1/2 + 1/2 lines from half a line down; its plot 1.5 lines under its title, 4 lines tall,
// 6 cells in from the left, half a cell short of the right edge.
const int CW = 6, LH = 9;
struct plot_box {
	int x0, y0, w, h;
};
plot_box plot_of(int chart, int canvas_w)
{
	int top = LH / 2 + chart * (4 * LH + LH + LH / 2 + LH / 2);
	return {6 * CW, top + LH + LH / 2, canvas_w - 6 * CW - CW / 2, 4 * LH};
}

bool is_rgb(const canvas &c, int x, int y, int r, int g, int b)
{
	const uint8_t *p = c.rgba + (size_t(y) * size_t(c.w) + size_t(x)) * 4;
	return p[0] == r && p[1] == g && p[2] == b && p[3] == 255;
}

// Columns of a plot that hold a pixel of the given colour.
std::vector<bool> columns_with(const canvas &c, const plot_box &p, int r, int g, int b)
{
	std::vector<bool> has(size_t(p.w), false);
	for (int x = 0; x < p.w; x++)
		for (int y = p.y0; y < p.y0 + p.h; y++)
			if (is_rgb(c, p.x0 + x, y, r, g, b))
				has[size_t(x)] = true;
	return has;
}

struct fixture {
	charts ch;
	canvas cv;
	fixture()
	{
		REQUIRE(charts_init(&ch, 2.0f));
		int w, h;
		charts_size(1, &w, &h);
		REQUIRE(canvas_init(&cv, w, h, 1));
	}
	~fixture()
	{
		charts_free(&ch);
		canvas_free(&cv);
	}
};

} // namespace

TEST_CASE("charts_nice rounds up to 1, 2, 2.5 or 5 times a power of ten")
{
	const float in[] = {0.3f, 0.5f, 0.51f, 1.0f, 1.1f, 2.2f, 2.8f, 4.4f, 6.0f, 2400.0f};
	const float want[] = {0.5f, 0.5f, 1.0f, 1.0f, 2.0f, 2.5f, 5.0f, 5.0f, 10.0f, 2500.0f};
	for (size_t k = 0; k < sizeof(in) / sizeof(in[0]); k++) {
		INFO("nice(" << in[k] << ") = " << charts_nice(in[k]) << ", want " << want[k]);
		CHECK(std::fabs(charts_nice(in[k]) - want[k]) < 1e-4f * want[k]);
	}
}

TEST_CASE("a lost pose leaves a gap in the height line and is counted, consecutive poses are joined")
{
	fixture f;
	// 5 s of poses at 10 per second, seq 0..49, with seq 20..29 lost (one second)
	const uint64_t t0 = 100000000;
	for (int k = 0; k < 50; k++)
		if (k < 20 || k >= 30)
			charts_pose(&f.ch, t0 + uint64_t(k) * 100000, uint8_t(k), -5.0f + 0.1f * float(k), 0.0f, 10.0f);
	CHECK(f.ch.lost_poses == 10);
	uint64_t now = t0 + 49 * 100000;
	charts_draw(&f.ch, &f.cv, now);
	plot_box p = plot_of(1, f.cv.w);
	std::vector<bool> bottom = columns_with(f.cv, p, 255, 150, 30);
	auto col = [&](uint64_t t) { return int(std::lround((1.0 - double(now - t) / 10e6) * (p.w - 1))); };
	int lost0 = col(t0 + 19 * 100000) + 2, lost1 = col(t0 + 30 * 100000) - 2; // inside the lost second
	int seen0 = col(t0) + 2, seen1 = col(t0 + 19 * 100000) - 2; // inside the first 2 s
	int empty = 0, drawn = 0;
	for (int x = lost0; x <= lost1; x++)
		empty += !bottom[size_t(x)];
	for (int x = seen0; x <= seen1; x++)
		drawn += bottom[size_t(x)];
	INFO("columns of the lost second without a line: " << empty << " of " << lost1 - lost0 + 1
							   << "; columns of the received 2 s with one: " << drawn << " of "
							   << seen1 - seen0 + 1);
	CHECK(empty == lost1 - lost0 + 1);
	CHECK(drawn == seen1 - seen0 + 1);
}

TEST_CASE("a pose or force sequence jump beyond the window is one resynchronisation, not counted lost")
{
	fixture f;
	const uint64_t t0 = 100000000;
	for (int k = 0; k < 10; k++) {
		charts_pose(&f.ch, t0 + uint64_t(k) * 100000, uint8_t(k), -5.0f, 0.0f, 10.0f);
		charts_force(&f.ch, t0 + uint64_t(k) * 100000, uint8_t(k), 0.0f, 0.0f, 1.0f, 0);
	}
	/* a restarted controller (or another one) goes on at 110: 100 numbers away */
	for (int k = 10; k < 20; k++) {
		charts_pose(&f.ch, t0 + uint64_t(k) * 100000, uint8_t(k + 100), -5.0f, 0.0f, 10.0f);
		charts_force(&f.ch, t0 + uint64_t(k) * 100000, uint8_t(k + 100), 0.0f, 0.0f, 1.0f, 0);
	}
	/* and then loses 5 of each */
	charts_pose(&f.ch, t0 + 2000000, uint8_t(125), -5.0f, 0.0f, 10.0f);
	charts_force(&f.ch, t0 + 2000000, uint8_t(125), 0.0f, 0.0f, 1.0f, 0);
	INFO("lost poses " << f.ch.lost_poses << ", lost forces " << f.ch.lost_forces << ", resyncs " << f.ch.resyncs);
	CHECK(f.ch.lost_poses == 5u);
	CHECK(f.ch.lost_forces == 5u);
	CHECK(f.ch.resyncs == 2u);
}

TEST_CASE("silence longer than CHART_GAP_US breaks the line even without a sequence jump")
{
	fixture f;
	const uint64_t t0 = 50000000;
	charts_force(&f.ch, t0, 0, 0, 0, 1.0f, 0);
	charts_force(&f.ch, t0 + 3000000, 1, 0, 0, 1.0f, 0); // the next seq, 3 s later
	uint64_t now = t0 + 3000000;
	charts_draw(&f.ch, &f.cv, now);
	plot_box p = plot_of(0, f.cv.w);
	std::vector<bool> fz = columns_with(f.cv, p, 90, 200, 255);
	int n = 0;
	for (bool b : fz)
		n += b;
	INFO("columns with the fz line: " << n << " (two dots of a 1 px pen)");
	CHECK(n == 2);
	CHECK(f.ch.lost_forces == 0);
}

TEST_CASE("the force chart is symmetric, covers the peak |F|, and draws the limit where it is")
{
	fixture f; // limit 2 N
	const uint64_t t0 = 10000000;
	for (int k = 0; k < 100; k++) // |F| = sqrt(1.2^2 + 1.6^2) = 2.0 N at most... fz up to 1.6
		charts_force(&f.ch, t0 + uint64_t(k) * 20000, uint8_t(k), 1.2f, 0.0f, 1.6f * std::sin(0.1f * float(k)), 0);
	uint64_t now = t0 + 99 * 20000;
	float lo, hi, step;
	charts_range(&f.ch, 0, now, &lo, &hi, &step);
	INFO("force range " << lo << " .. " << hi << " N, step " << step);
	CHECK(hi == Approx(2.5f)); // 1.1 x 2.0 = 2.2 -> 2.5
	CHECK(lo == Approx(-2.5f));
	charts_draw(&f.ch, &f.cv, now);
	plot_box p = plot_of(0, f.cv.w);
	int row = p.y0 + int(std::lround((hi - 2.0f) / (hi - lo) * (p.h - 1)));
	int red = 0;
	for (int x = p.x0; x < p.x0 + p.w; x++)
		red += is_rgb(f.cv, x, row, 255, 70, 70);
	INFO("limit line pixels in row " << row << ": " << red << " of " << p.w << " (dashed: half)");
	CHECK(red > p.w * 4 / 10);
	CHECK(red < p.w * 6 / 10);
	// a limit off the scale is not drawn inside the plot
	f.ch.force_limit_N = 50;
	charts_draw(&f.ch, &f.cv, now);
	int any = 0;
	for (int y = p.y0; y < p.y0 + p.h; y++)
		for (int x = p.x0; x < p.x0 + p.w; x++)
			any += is_rgb(f.cv, x, y, 255, 70, 70);
	CHECK(any == 0);
}

TEST_CASE("samples older than the 10 s window leave the chart and its range")
{
	fixture f;
	charts_pose(&f.ch, 1000000, 0, -40.0f, 0.0f, 80.0f); // a deep dip, long ago
	for (int k = 1; k <= 100; k++)
		charts_pose(&f.ch, 20000000 + uint64_t(k) * 10000, uint8_t(k), -3.0f, 0.5f, 6.0f);
	float lo, hi, step;
	charts_range(&f.ch, 1, 21000000, &lo, &hi, &step);
	INFO("height range " << lo << " .. " << hi << " mm, step " << step);
	CHECK(lo > -5.0f);
	CHECK(hi >= 0.5f);
	CHECK(hi < 2.0f);
}

TEST_CASE("the water under the object is the mean of the cells whose centres the footprint covers")
{
	view_model m;
	vm_init(&m, 500000);
	view_scene s = {};
	s.nx = 16;
	s.ny = 16;
	s.dx_um = 10000;
	s.depth_um = 50000;
	s.tile_w = 8;
	s.tile_h = 8;
	s.scene_id = 1;
	REQUIRE(vm_scene(&m, &s, 1) == SWELL_OK);
	for (int j = 0; j < 16; j++)
		for (int i = 0; i < 16; i++)
			m.h_mm[j * 16 + i] = float(i) + 100.0f * float(j);
	// 28 x 20 mm at (50, 50) mm covers x 36..64 and y 40..60: the cell centres 45 and 55 mm both ways
	float w = charts_water_under(&m, 50000, 50000, 28000, 20000);
	float want = (4 + 5) / 2.0f + 100.0f * (4 + 5) / 2.0f;
	INFO("water under " << w << " mm, mean of cells i 4..5, j 4..5: " << want);
	CHECK(w == Approx(want));
	// a footprint narrower than a cell: the cell under its centre
	CHECK(charts_water_under(&m, 72000, 31000, 1000, 1000) == Approx(7.0f + 300.0f));
	vm_free(&m);
}

TEST_CASE("CSV rows carry each received sample with its receive time, empty where a message has none")
{
	fixture f;
	char path[] = "/tmp/swell-chart-csv-XXXXXX";
	int fd = mkstemp(path);
	REQUIRE(fd >= 0);
	close(fd);
	char err[128];
	REQUIRE(charts_csv_open(&f.ch, path, err, sizeof(err)));
	charts_pose(&f.ch, 1500000, 7, -12.5f, 0.25f, 25.0f);
	charts_force(&f.ch, 1500000, 7, 3.0f, 0.0f, 4.0f, 1);
	charts_pose(&f.ch, 1520000, 9, -12.0f, 0.25f, 24.0f); // seq 8 lost
	charts_latency(&f.ch, 1600000, 3.5f);
	charts_energy(&f.ch, 1700000, 1.25f, -0.5f, 1);
	charts_free(&f.ch); // closes the file
	REQUIRE(charts_init(&f.ch, 2.0f));
	std::ifstream in(path);
	std::vector<std::string> rows;
	for (std::string l; std::getline(in, l);)
		rows.push_back(l);
	std::remove(path);
	REQUIRE(rows.size() == 6);
	CHECK(rows[0] ==
	      "t_s,pose_seq,bottom_mm,water_mm,submersion_pct,fz_N,f_abs_N,limited,frame_hz,latency_ms,lost_poses,"
	      "created_mJ,balance_mJ");
	CHECK(rows[1] == "1.500000,7,-12.50,0.250,25.0,,,,,,0,,");
	CHECK(rows[2] == "1.500000,7,,,,4.00,5.000,1,,,,,");
	CHECK(rows[3] == "1.520000,9,-12.00,0.250,24.0,,,,,,1,,");
	CHECK(rows[4] == "1.600000,,,,,,,,,3.50,,,");
	CHECK(rows[5] == "1.700000,,,,,,,,,,,1.250,-0.50");
}

TEST_CASE("the legend's bar runs from the colour of -range at the bottom to +range at the top")
{
	canvas c;
	int w, h;
	canvas_legend_size(1, &w, &h);
	REQUIRE(canvas_init(&c, w, h, 1));
	canvas_legend(&c, 2.0f);
	// bar: x from one cell in, 3 cells wide; rows from 2 lines down, 16 lines tall (canvas.c)
	int x = CW + CW, top = 2 * LH, bottom = 2 * LH + 16 * LH - 1, mid = 2 * LH + 8 * LH;
	uint8_t hi[3], lo[3], zero[3];
	canvas_ramp(1.0f, hi);
	canvas_ramp(-1.0f, lo);
	canvas_ramp(0.0f, zero);
	auto near = [&](int yy, const uint8_t *want) {
		const uint8_t *p = c.rgba + (size_t(yy) * size_t(c.w) + size_t(x)) * 4;
		INFO("row " << yy << ": " << int(p[0]) << "," << int(p[1]) << "," << int(p[2]) << " want " << int(want[0]) << ","
			    << int(want[1]) << "," << int(want[2]));
		return std::abs(p[0] - want[0]) <= 4 && std::abs(p[1] - want[1]) <= 4 && std::abs(p[2] - want[2]) <= 4;
	};
	CHECK(near(top, hi));
	CHECK(near(bottom, lo));
	CHECK(near(mid, zero));
	CHECK(int(hi[0]) > int(hi[2]) + 150); // red at the top
	CHECK(int(lo[2]) > int(lo[0]) + 150); // blue at the bottom
	canvas_free(&c);
}

TEST_CASE("the energy chart plots the created energy and the balance D of ENERGY at their values, from 0 up or "
	  "symmetric when D goes below 0")
{
	fixture f;
	// 6 s of ENERGY at 10 Hz: created 0.5 mJ a second, D 2 mJ sin
	const uint64_t t0 = 50000000;
	for (int k = 0; k <= 60; k++) {
		const double t = k * 0.1;
		charts_energy(&f.ch, t0 + uint64_t(k) * 100000, float(0.5 * t), float(2.0 * std::sin(t)), 0);
	}
	const uint64_t now = t0 + 60 * 100000;
	float lo, hi, step;
	charts_range(&f.ch, 5, now, &lo, &hi, &step);
	CHECK(hi == Approx(5.0f)); // nice(1.1 x 3 mJ)
	CHECK(lo == Approx(-5.0f)); // D went below 0
	charts_draw(&f.ch, &f.cv, now);
	const plot_box p = plot_of(5, f.cv.w);
	const std::vector<bool> created = columns_with(f.cv, p, 255, 90, 200);
	// the last sample (3 mJ) at the right edge: the created line's pixel in the last column is there
	int y_found = -1;
	for (int y = p.y0; y < p.y0 + p.h; y++)
		if (is_rgb(f.cv, p.x0 + p.w - 1, y, 255, 90, 200))
			y_found = y;
	const int y_want = p.y0 + int(std::lround((hi - 3.0) / (hi - lo) * (p.h - 1)));
	INFO("created at the right edge: y " << y_found << ", want " << y_want);
	CHECK(std::abs(y_found - y_want) <= 1);
	// drawn over the 6 s received, nothing over the 4 s before
	int drawn = 0, before = 0;
	const int first = int(0.4 * (p.w - 1)); // the column of the first sample, 6 s back
	for (int x = 0; x < p.w; x++) {
		drawn += x >= first + 2 && created[size_t(x)];
		before += x < first - 2 && created[size_t(x)];
	}
	CHECK(drawn >= int(0.6 * (p.w - 1)) - 4);
	CHECK(before == 0);
	// a run without energy created keeps the axis from 0
	fixture g;
	charts_energy(&g.ch, t0, 0.0f, 1.5f, 0);
	charts_range(&g.ch, 5, t0, &lo, &hi, &step);
	CHECK(lo == 0.0f);
	CHECK(hi == Approx(2.0f));
}
