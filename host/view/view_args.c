/* swell-view's command line; see view_main.h. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "swell/cli.h"
#include "swell/pool.h"
#include "view_main.h"

static const char usage[] =
	"usage: swell-view [options]\n"
	"Shows the water, object and force a swell controller sends; no solver inside.\n"
	"\n"
	"  --source SRC        udp[:PORT]        datagrams on 127.0.0.1 (default udp:47801, as swell-ctl sends)\n"
	"                      can:IFACE, canfd:IFACE  SocketCAN (classic, FD); usb[:VID:PID]  libusb bulk\n"
	"                      replay:FILE       a recording, at recorded speed; replay-fast:FILE at full speed\n"
	"                      pattern:bump|bump2|ripple|bob|wake|still[:N]  a known scene through the real\n"
	"                      encoders (labelled on screen; bob: the object bobs, its force follows; wake:\n"
	"                      bob with rings running out from it; still: bob on still water; N x N cells)\n"
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
	"  --shading water|flat  how the water is lit: water (default: normals from the received heights,\n"
	"                      sun highlight, sky reflection by Fresnel's law, the tiled floor seen through\n"
	"                      the water and its caustics, a ring and shadow where the object meets it) or\n"
	"                      flat (one body colour, sun and sky only: the older, quieter look)\n"
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
	"C colour scale, W water shading (water, flat), G charts, V view (orbit, map), H HUD, Q or Esc quit.\n"
	"Exit status: 0 done, 1 GL/window/file failure, 2 bad arguments.\n";

static int size_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	int w, h;
	char tail;

	if (sscanf(v, "%dx%d%c", &w, &h, &tail) != 2 || w < 64 || h < 64 || w > 8192 || h > 8192)
		return swell_cli_refuse(c, "%s '%s' is not WxH with sides in 64..8192 pixels (see --help)", opt, v);
	o->ro.w = w;
	o->ro.h = h;
	return 0;
}

static int object_opt(struct swell_cli *c, const char *opt, const char *v)
{
	struct opts *o = c->ctx;
	double x, y, z;
	char tail;

	if (sscanf(v, "%lfx%lfx%lf%c", &x, &y, &z, &tail) != 3 || !(x >= 1 && x <= 500) || !(y >= 1 && y <= 500) ||
	    !(z >= 1 && z <= 500))
		return swell_cli_refuse(c, "%s '%s' is not AxBxH in mm, each 1..500 (see --help)", opt, v);
	o->obj_um[0] = (uint32_t)lround(x * 1000);
	o->obj_um[1] = (uint32_t)lround(y * 1000);
	o->obj_um[2] = (uint32_t)lround(z * 1000);
	return 0;
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
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_STR("--source", o->source),
		SWELL_CLI_STR("--faults", o->faults),
		SWELL_CLI_WHOLE("--node", o->node, 0, 15, ""),
		SWELL_CLI_WHOLE("--iface", o->iface, 0, 255, ""),
		SWELL_CLI_STR("--record", o->record),
		SWELL_CLI_FLAG("--headless", o->headless),
		SWELL_CLI_FLAG("--steady", o->steady),
		SWELL_CLI_HOOK("--size", size_opt, 1),
		SWELL_CLI_STR("--screenshot", o->shot),
		SWELL_CLI_WHOLE("--after", o->after, 1, 1e7, "frames"),
		SWELL_CLI_WHOLE("--frames", o->frames, 1, 1e9, ""),
		SWELL_CLI_CHOICE("--view", o->ro.view, "orbit|top|map"),
		SWELL_CLI_FLAG("--charts", o->charts),
		SWELL_CLI_FLAG("--timing", o->timing),
		SWELL_CLI_STR("--csv", o->csv),
		SWELL_CLI_NUM("--force-limit", o->force_limit_N, 0.01, 250, "N"),
		SWELL_CLI_CHOICE("--shading", o->ro.shading, "water|flat"),
		SWELL_CLI_FLAG("--colour", o->ro.colour_scale),
		SWELL_CLI_FLAG("--color", o->ro.colour_scale),
		SWELL_CLI_NUM("--range", o->ro.h_range_mm, 0.01, 100, "mm"),
		SWELL_CLI_NUM("--zscale", o->ro.zscale, 0.1, 100, ""),
		SWELL_CLI_NUM("--force-scale", o->ro.force_mm_per_N, 0, 10000, "mm/N"),
		SWELL_CLI_HOOK("--object", object_opt, 1),
		SWELL_CLI_WHOLE("--stale-ms", o->stale_ms, 10, 60000, "ms"),
		SWELL_CLI_WHOLE("--msaa", o->ro.msaa, 0, 16, ""),
		SWELL_CLI_SET("--no-hud", o->ro.hud, false),
		SWELL_CLI_NUM("--fps", o->fps, 1, 1000, ""),
	};
	struct swell_cli cli = {
		.prog = "swell-view", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts), .ctx = o
	};

	swell_cli_parse(&cli, argc, argv);
	if (o->faults && strncmp(o->source, "pattern:", 8) != 0)
		swell_cli_die("swell-view", "--faults applies to pattern sources only, not '%s' (see --help)",
			      o->source);
}
