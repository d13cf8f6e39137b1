/* swell-view's HUD, charts, colour legend and --timing figures; see view_main.h. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "view_main.h"

void hud(struct app *a, const struct view_feed *f, const struct source *src, uint64_t now)
{
	const struct view_model *m = &a->vm;
	const struct view_stats *st = &m->st;
	char buf[512], lat[48] = "-", fw[16] = "?";
	static const uint8_t cols[][3] = { [VIEW_LINK_DOWN] = { 255, 80, 70 },
					   [VIEW_WAIT_SCENE] = { 255, 200, 60 },
					   [VIEW_RESTARTED] = { 255, 150, 40 },
					   [VIEW_STALE] = { 255, 200, 60 },
					   [VIEW_LIVE] = { 90, 230, 120 } }; /* the status line's colour */

	render_text_clear(&a->r);
	if (m->have_info)
		snprintf(fw, sizeof(fw), "%u.%u.%u", m->fw_version[0], m->fw_version[1], m->fw_version[2]);
	if (st->latency_valid)
		snprintf(lat, sizeof(lat), "+%.1f MS OVER BEST (HEARTBEATS%s)", (double)st->latency_ms,
			 f->rec_clock ? ", AS RECORDED" : "");
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

	const uint8_t *c = cols[m->status];
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
bool overlays(struct app *a, uint64_t now, bool redraw)
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
void timing_report(float *ms, long n, double cpu_ms, const struct app *a)
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
