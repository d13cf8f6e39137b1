/* swell-view: shows the heights, object pose, force and controller state it receives; it has no
 * solver and invents nothing. See render.h for the GL side, vm.h for the robustness rules. */
#define _GNU_SOURCE
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "canvas.h"
#include "chart.h"
#include "feed.h"
#include "png.h"
#include "render.h"
#include "swell/pool.h"
#include "sources.h"
#include "vm.h"

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

static void parse(int argc, char **argv, struct opts *o)
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

static double cpu_ms(void)
{
	struct timespec t;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
	return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

static uint64_t now_us(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (uint64_t)t.tv_sec * 1000000u + (uint64_t)t.tv_nsec / 1000u;
}

/* ---- window input ---- */
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
	double mx, my;
	unsigned shots;
};

static void on_key(GLFWwindow *w, int key, int sc, int action, int mods)
{
	(void)sc;
	(void)mods;
	struct app *a = glfwGetWindowUserPointer(w);
	if (action != GLFW_PRESS)
		return;
	switch (key) {
	case GLFW_KEY_R:
		render_cam_reset(&a->r, &a->vm);
		break;
	case GLFW_KEY_S:
		a->want_shot = true;
		break;
	case GLFW_KEY_P:
	case GLFW_KEY_SPACE:
		a->paused = !a->paused;
		break;
	case GLFW_KEY_C:
		a->r.o.colour_scale = !a->r.o.colour_scale;
		break;
	case GLFW_KEY_G:
		a->charts_on = !a->charts_on;
		a->frozen = false; /* draw them once even while paused */
		break;
	case GLFW_KEY_V:
		a->r.o.view = a->r.o.view == RENDER_MAP ? RENDER_ORBIT : RENDER_MAP;
		break;
	case GLFW_KEY_H:
		a->r.o.hud = !a->r.o.hud;
		break;
	case GLFW_KEY_Q:
	case GLFW_KEY_ESCAPE:
		a->quit = true;
		break;
	default:
		break;
	}
}

static void on_button(GLFWwindow *w, int button, int action, int mods)
{
	(void)mods;
	struct app *a = glfwGetWindowUserPointer(w);
	if (button == GLFW_MOUSE_BUTTON_LEFT) {
		a->dragging = action == GLFW_PRESS;
		glfwGetCursorPos(w, &a->mx, &a->my);
	}
}

static void on_cursor(GLFWwindow *w, double x, double y)
{
	struct app *a = glfwGetWindowUserPointer(w);
	if (a->dragging)
		render_cam_orbit(&a->r, (float)(a->mx - x) * 0.008f, (float)(y - a->my) * 0.008f);
	a->mx = x;
	a->my = y;
}

static void on_scroll(GLFWwindow *w, double dx, double dy)
{
	(void)dx;
	struct app *a = glfwGetWindowUserPointer(w);
	render_cam_zoom(&a->r, powf(0.9f, (float)dy));
}

static void on_glfw_error(int code, const char *what)
{
	fprintf(stderr, "swell-view: GLFW error %d: %s\n", code, what);
}

/* ---- HUD ---- */
static void status_colour(enum view_status s, uint8_t *c)
{
	static const uint8_t cols[][3] = { [VIEW_LINK_DOWN] = { 255, 80, 70 },
					   [VIEW_WAIT_SCENE] = { 255, 200, 60 },
					   [VIEW_RESTARTED] = { 255, 150, 40 },
					   [VIEW_STALE] = { 255, 200, 60 },
					   [VIEW_LIVE] = { 90, 230, 120 } };
	memcpy(c, cols[s], 3);
}

static void hud(struct app *a, const struct view_feed *f, const struct source *src, uint64_t now)
{
	const struct view_model *m = &a->vm;
	const struct view_stats *st = &m->st;
	char buf[512], lat[48], fw[16] = "?";
	uint8_t c[3];

	render_text_clear(&a->r);
	if (m->have_info)
		snprintf(fw, sizeof(fw), "%u.%u.%u", m->fw_version[0], m->fw_version[1], m->fw_version[2]);
	if (st->latency_valid)
		snprintf(lat, sizeof(lat), "+%.1f MS OVER BEST (HEARTBEATS%s)", (double)st->latency_ms,
			 f->rec_clock ? ", AS RECORDED" : "");
	else
		snprintf(lat, sizeof(lat), "-");
	snprintf(buf, sizeof(buf),
		 "SWELL-VIEW\n"
		 "LINK   %s\n"
		 "FRAMES %6.0f /S  QUADS %6.0f /S  TILES %5.0f /S\n"
		 "LATENCY %s\n"
		 "DROPPED %u  BAD %u  LATE %u\n"
		 "CONTROLLER %s  LAST ERROR %s  FIRMWARE %s\n"
		 "CTL BAD %u  OVERRUNS %u  RESTARTS %u",
		 src->desc, (double)st->frame_hz, (double)st->piece_hz, (double)a->tile_hz, lat, st->dropped, st->bad,
		 st->late, m->ctrl_state, m->ctrl_error ? swell_err_str((enum swell_err)m->ctrl_error) : "NONE", fw,
		 m->ctrl_bad, m->ctrl_overruns, st->restarts);
	render_text_add(&a->r, 8, 8, 225, 232, 240, true, buf);

	if (m->have_scene) {
		char obj[160] = "OBJECT -";
		if (m->obj.valid)
			snprintf(obj, sizeof(obj),
				 "OBJECT X %.1f Y %.1f Z %.1f MM  SUBMERGED %.1f %%\n"
				 "FORCE  %+.2f %+.2f %+.2f N%s",
				 m->obj.x_um * 1e-3, m->obj.y_um * 1e-3, m->obj.z_um * 1e-3,
				 f->submersion_halfpct * 0.5, m->obj.fx_cN * 0.01, m->obj.fy_cN * 0.01,
				 m->obj.fz_cN * 0.01, f->force_limits ? "  LIMITED" : "");
		snprintf(buf, sizeof(buf),
			 "POOL %u X %u CELLS  DX %.2f MM  DEPTH %.1f MM  SCENE %u\n"
			 "HEIGHTS Z X%.0f  UPLOADED %u TILES\n"
			 "BOX %.1f X %.1f X %.1f MM %s\n%s",
			 m->scene.nx, m->scene.ny, m->scene.dx_um * 1e-3, m->scene.depth_um * 1e-3, m->scene.scene_id,
			 (double)a->r.o.zscale, a->r.tiles_uploaded_last, f->obj_a_um * 1e-3, f->obj_b_um * 1e-3,
			 f->obj_h_um * 1e-3, f->obj_from_wire ? "(FROM CONTROLLER)" : "(--OBJECT, NO CTL_INFO YET)",
			 obj);
		render_text_add(&a->r, 8, -8, 200, 210, 220, true, buf);
	}

	status_colour(m->status, c);
	const char *s = vm_status_str(m->status);
	if (m->status == VIEW_STALE)
		snprintf(buf, sizeof(buf), "NO DATA FOR %.1f S", (double)(now - m->last_rx_us) * 1e-6);
	else if (m->status == VIEW_LINK_DOWN && src->ended)
		snprintf(buf, sizeof(buf), src->rec_damaged ? "END OF RECORDING (DAMAGED)" : "END OF RECORDING");
	else if (m->status == VIEW_LIVE && src->kind == SOURCE_LINK && src->ls.kind == SWELL_LINK_REPLAY)
		snprintf(buf, sizeof(buf), "REPLAY"); /* recorded, not live */
	else if (m->status == VIEW_LINK_DOWN && src->kind == SOURCE_LINK && src->ls.kind == SWELL_LINK_USB)
		snprintf(buf, sizeof(buf), "USB DEVICE NOT THERE - WAITING FOR IT");
	else
		snprintf(buf, sizeof(buf), "%s", s);
	if (a->paused)
		snprintf(buf + strlen(buf), sizeof(buf) - strlen(buf), "  [PAUSED]");
	if (f->st.rejected[SWELL_EVERSION])
		snprintf(buf + strlen(buf), sizeof(buf) - strlen(buf), "\nPROTOCOL VERSION MISMATCH");
	if (m->restart_us && m->status != VIEW_RESTARTED && now - m->restart_us < VIEW_RESTART_SHOW_US)
		snprintf(buf + strlen(buf), sizeof(buf) - strlen(buf), "\nCONTROLLER RESTARTED");
	render_text_add(&a->r, -8, 8, c[0], c[1], c[2], true, buf);

	if (!m->have_scene && m->status != VIEW_LINK_DOWN) {
		/* say it where the pool would be */
		render_text_add(&a->r, a->r.o.w / 2 / (a->r.o.h >= 700 ? 2 : 1) - 87,
				a->r.o.h / 2 / (a->r.o.h >= 700 ? 2 : 1), c[0], c[1], c[2], true,
				"WAITING FOR SCENE DESCRIPTION");
	}
}

/* The charts at the right edge (the scene keeps the rest) and the colour legend at the left, drawn
 * on the CPU and shown as overlays. redraw: false while paused (the picture is frozen). */
static bool overlays(struct app *a, uint64_t now, bool redraw)
{
	int scale = a->r.o.h >= 700 ? 2 : 1, w, h;
	if (a->charts_on) {
		charts_size(scale, &w, &h);
		if (a->chart_cv.w != w || a->chart_cv.h != h) {
			canvas_free(&a->chart_cv);
			if (!canvas_init(&a->chart_cv, w, h, scale))
				return false;
			redraw = true;
		}
		if (redraw) {
			charts_draw(&a->ch, &a->chart_cv, now);
			render_overlay(&a->r, 0, a->chart_cv.rgba, w, h, a->r.o.w - w - 8 * scale, 36 * scale);
		}
		a->r.scene_right = w + 8 * scale;
	} else {
		render_overlay_off(&a->r, 0);
		a->r.scene_right = 0;
	}
	if (a->r.o.colour_scale || a->r.o.view == RENDER_MAP) {
		canvas_legend_size(scale, &w, &h);
		if (a->legend_cv.w != w || a->legend_cv.h != h) {
			canvas_free(&a->legend_cv);
			if (!canvas_init(&a->legend_cv, w, h, scale))
				return false;
			a->legend_range = 0;
		}
		if (a->legend_range != a->r.o.h_range_mm) {
			canvas_legend(&a->legend_cv, a->r.o.h_range_mm);
			a->legend_range = a->r.o.h_range_mm;
		}
		/* below the HUD's top panel (7 lines) */
		render_overlay(&a->r, 1, a->legend_cv.rgba, w, h, 8 * scale, 8 * scale + 8 * 9 * scale + 4 * scale);
	} else {
		render_overlay_off(&a->r, 1);
	}
	return true;
}

static int cmp_float(const void *x, const void *y)
{
	float a = *(const float *)x, b = *(const float *)y;
	return (a > b) - (a < b);
}

/* Frame-time figures of --timing: median, 95th percentile and mean of the frames measured. */
static void timing_report(float *ms, long n, double cpu_ms, const struct app *a)
{
	if (n < 1)
		return;
	double sum = 0;
	for (long k = 0; k < n; k++)
		sum += ms[k];
	qsort(ms, (size_t)n, sizeof(ms[0]), cmp_float);
	printf("swell-view: frame time median %.2f ms, p95 %.2f ms, mean %.2f ms wall, %.2f ms CPU (all threads) "
	       "over %ld frames (%d x %d pixels, pool %u x %u, charts %s, msaa %d)\n",
	       (double)ms[n / 2], (double)ms[(long)((double)(n - 1) * 0.95)], sum / (double)n, cpu_ms / (double)n, n,
	       a->r.o.w, a->r.o.h, a->vm.scene.nx, a->vm.scene.ny, a->charts_on ? "on" : "off", a->r.samples);
}

/* SIGINT, SIGTERM: leave the frame loop, print the summary as on any other end. */
static volatile sig_atomic_t stop_signal;

static void on_stop_signal(int sig)
{
	stop_signal = sig;
}

static int screenshot(struct app *a, const char *path)
{
	size_t n = (size_t)a->r.o.w * (size_t)a->r.o.h * 3;
	uint8_t *rgb = malloc(n);
	if (!rgb)
		return 1;
	render_read(&a->r, rgb);
	errno = 0;
	enum swell_err e = swell_png_write(path, rgb, (uint32_t)a->r.o.w, (uint32_t)a->r.o.h, 3, (size_t)a->r.o.w * 3);
	const int os_err = errno; /* the file's reason, when the system gave one */
	free(rgb);
	if (e != SWELL_OK) {
		fprintf(stderr, "swell-view: cannot write %s: %s\n", path,
			e == SWELL_ESTATE && os_err ? strerror(os_err) : swell_err_str(e));
		return 1;
	}
	printf("swell-view: wrote %s (%d x %d pixels)\n", path, a->r.o.w, a->r.o.h);
	fflush(stdout); /* whoever waits for the picture reads this line */
	return 0;
}

int main(int argc, char **argv)
{
	static struct app app;
	struct opts o;
	struct source src;
	struct view_feed feed;
	char err[256];
	int rc = 0;

	parse(argc, argv, &o);
	if (!source_open(&src, o.source, o.record, o.iface, err, sizeof(err))) {
		fprintf(stderr, "swell-view: %s\n", err);
		return 2;
	}
	if (o.faults && !source_faults(&src, o.faults, err, sizeof(err))) {
		fprintf(stderr, "swell-view: %s\n", err);
		return 2;
	}
	vm_init(&app.vm, (uint64_t)o.stale_ms * 1000u);
	feed_init(&feed, &app.vm, o.node < 0 ? FEED_NODE_ANY : (uint8_t)o.node);
	feed.obj_a_um = o.obj_um[0];
	feed.obj_b_um = o.obj_um[1];
	feed.obj_h_um = o.obj_um[2];
	if (!charts_init(&app.ch, o.force_limit_N)) {
		fprintf(stderr, "swell-view: out of memory for the charts\n");
		vm_free(&app.vm);
		source_close(&src);
		return 1;
	}
	if (o.csv && !charts_csv_open(&app.ch, o.csv, err, sizeof(err))) {
		fprintf(stderr, "swell-view: %s\n", err);
		charts_free(&app.ch);
		vm_free(&app.vm);
		source_close(&src);
		return 1;
	}
	feed.charts = &app.ch;
	app.charts_on = o.charts;

	/* before the window: a Ctrl-C while it opens also ends with the summary */
	struct sigaction sa;
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_stop_signal; /* no SA_RESTART: the frame pacing sleep ends at once */
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);

	glfwSetErrorCallback(on_glfw_error);
	if (!glfwInit()) {
		fprintf(stderr, "swell-view: no display (set DISPLAY, or run under xvfb-run)\n");
		charts_free(&app.ch);
		vm_free(&app.vm);
		source_close(&src);
		return 1;
	}
	glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
	glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
	glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
	glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
	glfwWindowHint(GLFW_VISIBLE, o.headless ? GLFW_FALSE : GLFW_TRUE);
	GLFWwindow *win =
		glfwCreateWindow(o.headless ? 64 : o.ro.w, o.headless ? 64 : o.ro.h, "swell-view", NULL, NULL);
	if (!win) {
		fprintf(stderr, "swell-view: no OpenGL 3.3 core context\n");
		glfwTerminate();
		charts_free(&app.ch);
		vm_free(&app.vm);
		source_close(&src);
		return 1;
	}
	glfwMakeContextCurrent(win);
	glfwSwapInterval(o.headless ? 0 : 1);
	glfwSetWindowUserPointer(win, &app);
	glfwSetKeyCallback(win, on_key);
	glfwSetMouseButtonCallback(win, on_button);
	glfwSetCursorPosCallback(win, on_cursor);
	glfwSetScrollCallback(win, on_scroll);
	if (!render_init(&app.r, &o.ro)) {
		glfwTerminate();
		charts_free(&app.ch);
		vm_free(&app.vm);
		source_close(&src);
		return 1;
	}

	float *frame_ms = o.timing ? malloc(sizeof(float) * 65536u) : NULL;
	long timed = 0;
	double cpu_frames_ms = 0;
	uint64_t period = (uint64_t)(1e6 / o.fps), next = now_us();
	for (long frame = 1; !app.quit && !stop_signal && !glfwWindowShouldClose(win); frame++) {
		uint64_t t = o.steady ? 1000000u + (uint64_t)frame * 20000u : now_us(), t_start = now_us();
		double cpu_start = frame_ms ? cpu_ms() : 0;
		source_poll(&src, &feed, t);
		vm_tick(&app.vm, t);
		charts_tick(&app.ch, t, app.vm.st.frames);
		if (!o.headless) {
			int fw, fh;
			glfwGetFramebufferSize(win, &fw, &fh);
			if (!render_resize(&app.r, fw, fh))
				break;
		}
		if (t - app.tile_window_us >= 1000000u) {
			app.tile_hz = (float)(app.r.tiles_uploaded - app.tile_window_start) * 1e6f /
				(float)(t - app.tile_window_us);
			app.tile_window_start = app.r.tiles_uploaded;
			app.tile_window_us = t;
		}
		/* pause freezes the whole picture: heights (no uploads), the object as it was, the HUD and
		 * charts of the first paused frame (reception, recording and the charts' data go on) */
		if (!app.frozen)
			hud(&app, &feed, &src, t);
		if (!overlays(&app, t, !app.frozen)) {
			fprintf(stderr, "swell-view: out of memory for the overlays\n");
			rc = 1;
			break;
		}
		app.frozen = app.paused;
		if (!app.paused)
			app.shown_obj = app.vm.obj;
		struct view_object live_obj = app.vm.obj;
		app.vm.obj = app.shown_obj;
		render_frame(&app.r, &app.vm, app.paused);
		app.vm.obj = live_obj;
		if (!o.headless) {
			int fw, fh;
			glfwGetFramebufferSize(win, &fw, &fh);
			render_blit(&app.r, fw, fh);
			glfwSwapBuffers(win);
		}
		if (frame_ms && timed < 65536) {
			render_finish(&app.r); /* the frame's GPU work counts */
			frame_ms[timed++] = (float)(now_us() - t_start) * 1e-3f;
			cpu_frames_ms += cpu_ms() - cpu_start;
		}
		glfwPollEvents();
		if (app.want_shot) {
			char name[64];
			snprintf(name, sizeof(name), "swell-view-%04u.png", app.shots++);
			screenshot(&app, name);
			app.want_shot = false;
		}
		if (o.shot && frame >= o.after) {
			rc = screenshot(&app, o.shot);
			break;
		}
		if (o.frames > 0 && frame >= o.frames)
			break;
		/* headless, a replay that has ended has nothing more to show (unless a screenshot of a later
		 * frame is asked for): the last state is drawn, the run ends */
		if (o.headless && src.ended && !o.shot)
			break;
		/* pace the loop (the window's vsync does it too when there is one) */
		if (o.steady && o.headless)
			continue;
		next += period;
		uint64_t after = now_us();
		if (next > after) {
			struct timespec d = { (time_t)((next - after) / 1000000u),
					      (long)((next - after) % 1000000u) * 1000 };
			nanosleep(&d, NULL);
		} else {
			next = after;
		}
	}

	if (stop_signal)
		printf("swell-view: stopped by %s\n", stop_signal == SIGINT ? "SIGINT" : "SIGTERM");
	if (src.rec_damaged) {
		/* what was shown is what came before the damage; the run did not do what was asked */
		fprintf(stderr,
			"swell-view: the recording is damaged: the replay stopped at a damaged record after "
			"%u frames\n",
			app.vm.st.frames);
		rc = 1;
	}
	printf("swell-view: %u frames, %u bad, %u dropped, %u late, %u quads, %u restarts, %u resyncs; uploaded %llu "
	       "tiles (%llu texels)\n",
	       app.vm.st.frames, app.vm.st.bad, app.vm.st.dropped, app.vm.st.late, app.vm.st.pieces, app.vm.st.restarts,
	       app.vm.st.resyncs, (unsigned long long)app.r.tiles_uploaded, (unsigned long long)app.r.texels_uploaded);
	if (feed.obj_from_wire)
		printf("swell-view: object %.1f x %.1f x %.1f mm from the controller (CTL_INFO), firmware %u.%u.%u\n",
		       feed.obj_a_um * 1e-3, feed.obj_b_um * 1e-3, feed.obj_h_um * 1e-3, app.vm.fw_version[0],
		       app.vm.fw_version[1], app.vm.fw_version[2]);
	else
		printf("swell-view: object %.1f x %.1f x %.1f mm from --object (no CTL_INFO received)\n",
		       feed.obj_a_um * 1e-3, feed.obj_b_um * 1e-3, feed.obj_h_um * 1e-3);
	if (app.ch.csv)
		printf("swell-view: %s: %llu chart samples written\n", o.csv, (unsigned long long)app.ch.csv_rows);
	if (frame_ms)
		timing_report(frame_ms, timed, cpu_frames_ms, &app);
	free(frame_ms);
	charts_free(&app.ch);
	canvas_free(&app.chart_cv);
	canvas_free(&app.legend_cv);
	source_close(&src);
	render_free(&app.r);
	vm_free(&app.vm);
	glfwDestroyWindow(win);
	glfwTerminate();
	return rc;
}
