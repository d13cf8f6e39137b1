/* swell-view's parts (see main.c): the options and the window's state. view_args.c parses the
 * command line; view_hud.c draws the HUD, the charts and the legend, and the --timing figures. */
#ifndef SWELL_VIEW_MAIN_H
#define SWELL_VIEW_MAIN_H

#include <stdbool.h>
#include <stdint.h>

#include "canvas.h"
#include "chart.h"
#include "feed.h"
#include "render.h"
#include "sources.h"
#include "vm.h"

struct opts {
	const char *source, *faults, *record, *shot, *csv;
	int node, iface;
	bool headless, steady, charts, timing;
	float force_limit_N;
	long after, frames;
	double fps;
	uint32_t stale_ms;
	uint32_t obj_um[3];
	struct render_opts ro;
};

struct app {
	struct render r;
	struct view_model vm;
	struct charts ch;
	struct canvas chart_cv, legend_cv;
	bool paused, want_shot, quit, dragging;
	bool charts_on, frozen; /* frozen: the HUD and charts of the first paused frame are kept */
	float legend_range; /* what legend_cv shows (0: nothing yet) */
	float tile_hz; /* tiles uploaded a second (the tiles whose heights changed) */
	struct view_object shown_obj; /* the object as drawn (held while paused) */
	uint64_t tile_window_us, tile_window_start;
	double mx, my; /* the pointer as of the last cursor event handled */
	bool have_pointer; /* mx, my hold a cursor event's position */
	unsigned shots;
};

/* view_args.c: the options; exits 2 with one line on stderr when they are bad. */
void parse(int argc, char **argv, struct opts *o);

/* view_hud.c */
void hud(struct app *a, const struct view_feed *f, const struct source *src, uint64_t now);
bool overlays(struct app *a, uint64_t now, bool redraw);
void timing_report(float *ms, long n, double cpu_ms, const struct app *a);

#endif
