/* swell-view's command line; see view_main.h. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "swell/pool.h"
#include "view_main.h"

static const char usage[] =
	"usage: swell-view [options]\n"
	"Shows the water, object and force a swell controller sends; no solver inside.\n"
	"\n"
	"  --source SRC        udp[:PORT]        datagrams on 127.0.0.1 (default udp:47801, as swell-ctl sends)\n"
	"                      can:IFACE, canfd:IFACE  SocketCAN (classic, FD); usb[:VID:PID]  libusb bulk\n"
	"                      replay:FILE       a recording, at recorded speed; replay-fast:FILE at full speed\n"
	"                      pattern:bump|ripple|bob[:N]  a known scene through the real encoders (labelled\n"
	"                      on screen; bob: the object bobs, its force follows; N x N cells, 8..256)\n"
	"  --faults LIST       inject into a pattern: garbage,truncate,corrupt,reorder,drop,noscene,restart\n"
	"  --node N            show only controller node N (0..15; default: any)\n"
	"  --iface N           USB interface of the controller's host link (0..255; default 0; 1 when\n"
	"                      the controller has both its links on USB, swell-ctl --host usb:@FFS2@)\n"
	"  --record FILE       record every received frame of a link (replay with --source replay:FILE)\n"
	"  --headless          render without a visible window (still needs an X display, e.g. Xvfb)\n"
	"  --size WxH          framebuffer size in pixels (default 1024x768)\n"
	"  --screenshot FILE   write a PNG of frame N (see --after) and exit\n"
	"  --after N           frames before the screenshot (default 30)\n"
	"  --frames N          exit after N frames\n"
	"  --view orbit|top|map  camera: orbit (default; mouse), top (straight down, pool fitted) or map\n"
	"                      (straight down: a height map in the colour scale, the object's footprint)\n"
	"  --colour            colour the water by height (blue low, red high), with a legend in mm\n"
	"  --charts            strip charts of the last 10 s: force z and |F| against the limit, the\n"
	"                      object's bottom and the water under it, submersion, frame rate, latency\n"
	"  --csv FILE          write the charts' samples to FILE as they arrive (CSV, one row a sample)\n"
	"  --force-limit N     the controller's force limit drawn on the force chart (default 10 N, the\n"
	"                      controller's default; it is not on the wire)\n"
	"  --timing            print frame-time figures at exit: median, 95th percentile and mean wall\n"
	"                      time, and CPU time (all threads), ms a frame\n"
	"  --range MM          height of full colour and of the water tint (default 2 mm)\n"
	"  --zscale X          vertical exaggeration of the water (default 3; the object keeps its true\n"
	"                      submersion, riding the exaggerated surface)\n"
	"  --force-scale MM    force arrow length per newton (default 40 mm/N)\n"
	"  --object AxBxH      object size in mm until the controller's CTL_INFO gives it (default 50x50x50,\n"
	"                      the controller's default); the HUD and the exit summary say which is used\n"
	"  --stale-ms N        silence after which data is called stale (default 500 ms)\n"
	"  --no-hud            no text overlay\n"
	"  --msaa N            antialiasing samples a pixel (default 4 on a GPU, 0 on llvmpipe/softpipe)\n"
	"  --fps N             frame rate limit (default 60)\n"
	"  --steady            time advances 20 ms per rendered frame, not by the clock: patterns and\n"
	"                      replays give the same pictures on every run (tests)\n"
	"  -h, --help          this text\n"
	"\n"
	"Mouse: left drag orbits, wheel zooms. Keys: R reset view, S screenshot, P or space pause,\n"
	"C colour scale, G charts, V view (orbit, map), H HUD, Q or Esc quit.\n"
	"Exit status: 0 done, 1 GL/window/file failure, 2 bad arguments.\n";

static void bad(const char *fmt, const char *a)
{
	fprintf(stderr, "swell-view: ");
	fprintf(stderr, fmt, a);
	fprintf(stderr, " (see --help)\n");
	exit(2);
}

static double num(const char *opt, const char *v, double lo, double hi)
{
	char *end;
	errno = 0;
	double x = strtod(v, &end);
	if (errno || *v == 0 || *end || !(x >= lo && x <= hi)) {
		fprintf(stderr, "swell-view: %s '%s' is not a number in [%g, %g]\n", opt, v, lo, hi);
		exit(2);
	}
	return x;
}

void parse(int argc, char **argv, struct opts *o)
{
	memset(o, 0, sizeof(*o));
	o->source = "udp";
	o->node = -1;
	o->after = 30;
	o->frames = -1;
	o->fps = 60;
	o->stale_ms = 500;
	o->obj_um[0] = o->obj_um[1] = o->obj_um[2] = SWELL_POOL_BOX_UM; /* the controller's default body */
	o->ro.w = 1024;
	o->ro.h = 768;
	o->ro.view = RENDER_ORBIT;
	o->ro.h_range_mm = 2;
	o->ro.hud = true;
	o->ro.zscale = 3;
	o->ro.force_mm_per_N = 40;
	o->ro.msaa = -1;
	o->force_limit_N = 10; /* the controller's default f_max */
	for (int k = 1; k < argc; k++) {
		const char *a = argv[k];
		const char *v = k + 1 < argc ? argv[k + 1] : NULL;
#define NEED()                                      \
	do {                                        \
		if (!v)                             \
			bad("%s needs a value", a); \
		k++;                                \
	} while (0)
		if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
			fputs(usage, stdout);
			exit(0);
		} else if (!strcmp(a, "--source")) {
			NEED();
			o->source = v;
		} else if (!strcmp(a, "--faults")) {
			NEED();
			o->faults = v;
		} else if (!strcmp(a, "--node")) {
			NEED();
			o->node = (int)num(a, v, 0, 15);
		} else if (!strcmp(a, "--iface")) {
			NEED();
			o->iface = (int)num(a, v, 0, 255);
		} else if (!strcmp(a, "--record")) {
			NEED();
			o->record = v;
		} else if (!strcmp(a, "--headless")) {
			o->headless = true;
		} else if (!strcmp(a, "--steady")) {
			o->steady = true;
		} else if (!strcmp(a, "--size")) {
			NEED();
			int w, h;
			char c;
			if (sscanf(v, "%dx%d%c", &w, &h, &c) != 2 || w < 64 || h < 64 || w > 8192 || h > 8192)
				bad("--size '%s' is not WxH with sides in 64..8192 pixels", v);
			o->ro.w = w;
			o->ro.h = h;
		} else if (!strcmp(a, "--screenshot")) {
			NEED();
			o->shot = v;
		} else if (!strcmp(a, "--after")) {
			NEED();
			o->after = (long)num(a, v, 1, 1e7);
		} else if (!strcmp(a, "--frames")) {
			NEED();
			o->frames = (long)num(a, v, 1, 1e9);
		} else if (!strcmp(a, "--view")) {
			NEED();
			if (!strcmp(v, "orbit"))
				o->ro.view = RENDER_ORBIT;
			else if (!strcmp(v, "top"))
				o->ro.view = RENDER_TOP;
			else if (!strcmp(v, "map"))
				o->ro.view = RENDER_MAP;
			else
				bad("--view '%s' is not orbit, top or map", v);
		} else if (!strcmp(a, "--charts")) {
			o->charts = true;
		} else if (!strcmp(a, "--timing")) {
			o->timing = true;
		} else if (!strcmp(a, "--csv")) {
			NEED();
			o->csv = v;
		} else if (!strcmp(a, "--force-limit")) {
			NEED();
			o->force_limit_N = (float)num(a, v, 0.01, 250);
		} else if (!strcmp(a, "--colour") || !strcmp(a, "--color")) {
			o->ro.colour_scale = true;
		} else if (!strcmp(a, "--range")) {
			NEED();
			o->ro.h_range_mm = (float)num(a, v, 0.01, 100);
		} else if (!strcmp(a, "--zscale")) {
			NEED();
			o->ro.zscale = (float)num(a, v, 0.1, 100);
		} else if (!strcmp(a, "--force-scale")) {
			NEED();
			o->ro.force_mm_per_N = (float)num(a, v, 0, 10000);
		} else if (!strcmp(a, "--object")) {
			NEED();
			double x, y, z;
			char c;
			if (sscanf(v, "%lfx%lfx%lf%c", &x, &y, &z, &c) != 3 || !(x >= 1 && x <= 500) ||
			    !(y >= 1 && y <= 500) || !(z >= 1 && z <= 500))
				bad("--object '%s' is not AxBxH in mm, each 1..500", v);
			o->obj_um[0] = (uint32_t)lround(x * 1000);
			o->obj_um[1] = (uint32_t)lround(y * 1000);
			o->obj_um[2] = (uint32_t)lround(z * 1000);
		} else if (!strcmp(a, "--stale-ms")) {
			NEED();
			o->stale_ms = (uint32_t)num(a, v, 10, 60000);
		} else if (!strcmp(a, "--msaa")) {
			NEED();
			o->ro.msaa = (int)num(a, v, 0, 16);
		} else if (!strcmp(a, "--no-hud")) {
			o->ro.hud = false;
		} else if (!strcmp(a, "--fps")) {
			NEED();
			o->fps = num(a, v, 1, 1000);
		} else {
			bad("unknown option '%s'", a);
		}
#undef NEED
	}
	if (o->faults && strncmp(o->source, "pattern:", 8) != 0)
		bad("--faults applies to pattern sources only, not '%s'", o->source);
}
