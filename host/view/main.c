/* swell-view: shows the heights, object pose, force and controller state it receives; it has no
 * solver and invents nothing. See render.h for the GL side, vm.h for the robustness rules; its parts:
 * view_main.h. */
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

#include "png.h"
#include "view_main.h"

static double cpu_ms(void)
{
	struct timespec t;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
	return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

static uint64_t now_us(void)
{
	return swell_link_now_ns() / 1000u;
}

/* ---- window input ---- */

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
	case GLFW_KEY_W:
		a->r.o.shading = a->r.o.shading == RENDER_SHADE_WATER ? RENDER_SHADE_FLAT : RENDER_SHADE_WATER;
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
		/* the drag starts where the events say the pointer was, not where it is now: a slow frame
		 * leaves the press and the moves after it queued, and the pointer has moved on */
		if (action == GLFW_PRESS && !a->have_pointer) {
			glfwGetCursorPos(w, &a->mx, &a->my);
			a->have_pointer = true;
		}
		a->dragging = action == GLFW_PRESS;
	}
}

static void on_cursor(GLFWwindow *w, double x, double y)
{
	struct app *a = glfwGetWindowUserPointer(w);
	if (a->dragging)
		render_cam_orbit(&a->r, (float)(a->mx - x) * 0.008f, (float)(y - a->my) * 0.008f);
	a->mx = x;
	a->my = y;
	a->have_pointer = true;
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
		goto fail;
	}
	if (o.csv && !charts_csv_open(&app.ch, o.csv, err, sizeof(err))) {
		fprintf(stderr, "swell-view: %s\n", err);
		goto fail;
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
		goto fail;
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
		goto fail_glfw;
	}
	glfwMakeContextCurrent(win);
	glfwSwapInterval(o.headless ? 0 : 1);
	glfwSetWindowUserPointer(win, &app);
	glfwSetKeyCallback(win, on_key);
	glfwSetMouseButtonCallback(win, on_button);
	glfwSetCursorPosCallback(win, on_cursor);
	glfwSetScrollCallback(win, on_scroll);
	if (!render_init(&app.r, &o.ro))
		goto fail_glfw;

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
		int fw = 0, fh = 0; /* the window's framebuffer: the frame is drawn at its size and blitted to it */
		if (!o.headless)
			glfwGetFramebufferSize(win, &fw, &fh);
		if (!o.headless && !render_resize(&app.r, fw, fh))
			break;
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

fail_glfw:
	glfwTerminate();
fail:
	charts_free(&app.ch);
	vm_free(&app.vm);
	source_close(&src);
	return 1;
}
