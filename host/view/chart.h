/* Live strip charts of what swell-view receives: the last 10 s of the commanded force (z and |F|,
 * with the controller's force limit), the object's bottom against the water surface under it, the
 * submersion, the link's frame rate and latency, and the controller's energy account (energy created
 * and the balance D, docs/energy.md). Every sample comes from a received frame (OBJECT_POSE,
 * OBJECT_FORCE, HEARTBEAT, ENERGY) at its receive time; a lost pose or force (a jump in its
 * sequence number) or silence longer than CHART_GAP_US leaves a gap in the line, never an invented
 * value. The same samples can go to a CSV file as they arrive.
 *
 * GL-free: the display thread fills it from the decoder side and draws it onto a canvas that the
 * renderer shows as an overlay. Reception never waits for it: live links are read by their own thread
 * into a ring (sources.h), and this runs when the display thread drains that ring. */
#ifndef SWELL_VIEW_CHART_H
#define SWELL_VIEW_CHART_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "canvas.h"
#include "vm.h"

#define CHART_WINDOW_US 10000000u /* the time axis: the last 10 s */
#define CHART_CAP 8192u /* samples kept a series (10 s at 800 a second) */
#define CHART_GAP_US 500000u /* samples further apart than this are not joined */
#define CHART_RATE_BIN_US 250000u /* the frame rate is counted over 250 ms */

enum chart_series {
	CHART_FZ, /* N, commanded force z (up) */
	CHART_FABS, /* N, |F| */
	CHART_BOTTOM, /* mm, object bottom z, rest level 0 */
	CHART_WATER, /* mm, mean water surface under the object's footprint */
	CHART_SUBMERSION, /* %, as the controller reports it */
	CHART_RATE, /* frames/s received (good frames) */
	CHART_LATENCY, /* ms over the best path (vm_clock) */
	CHART_CREATED, /* mJ, energy created in the controller's run (ENERGY) */
	CHART_BALANCE, /* mJ, the run's balance D (ENERGY) */
	CHART_SERIES
};

struct chart_sample {
	uint64_t t_us; /* receive time */
	float v;
	bool gap; /* not joined to the sample before (lost frames) */
};

struct chart_ring {
	struct chart_sample *s; /* CHART_CAP samples */
	uint32_t head, n; /* next write slot, samples held */
};

struct charts {
	struct chart_ring ring[CHART_SERIES];
	float force_limit_N; /* the limit line (the controller's f_max; not on the wire) */
	bool have_pose, have_force;
	uint8_t pose_seq, force_seq;
	uint32_t lost_poses, lost_forces;
	uint32_t resyncs; /* pose or force sequence jumps past SWELL_SEQ_WINDOW (not counted lost) */
	bool have_rate;
	uint64_t rate_t_us;
	uint32_t rate_frames;
	FILE *csv;
	uint64_t csv_rows;
};

/* Allocate the rings. False when out of memory. */
bool charts_init(struct charts *c, float force_limit_N);
void charts_free(struct charts *c);

/* Write every sample from now on to path as CSV (header first). False with the reason in err. */
bool charts_csv_open(struct charts *c, const char *path, char *err, size_t errlen);

/* A received OBJECT_POSE (seq: its sequence number; the pose sequence is the loss detector). */
void charts_pose(struct charts *c, uint64_t t_us, uint8_t seq, float bottom_mm, float water_mm, float submersion_pct);
/* A received OBJECT_FORCE belonging to pose `seq`; limited: the controller's limit bits. */
void charts_force(struct charts *c, uint64_t t_us, uint8_t seq, float fx_N, float fy_N, float fz_N, unsigned limited);
/* A latency estimate, at a heartbeat. */
void charts_latency(struct charts *c, uint64_t t_us, float ms);
/* A received ENERGY: energy created and the balance D of the controller's run, mJ; acting: the
 * passivity controller acted since the last one. */
void charts_energy(struct charts *c, uint64_t t_us, float created_mJ, float balance_mJ, unsigned acting);
/* Advance time with the count of good frames received so far: adds a frame-rate sample every
 * CHART_RATE_BIN_US. */
void charts_tick(struct charts *c, uint64_t now_us, uint32_t frames_total);
/* The controller restarted or the scene changed: the sequences start again (no loss counted). */
void charts_restart(struct charts *c);

/* Mean water height (mm) over the cells under an a x b footprint centred at (x, y) um; the cell
 * nearest the centre when the footprint covers none. 0 without a scene. */
float charts_water_under(const struct view_model *m, int32_t x_um, int32_t y_um, uint32_t a_um, uint32_t b_um);

/* The y range of a series' chart over the window ending at now_us (the rules docs/view.md gives),
 * and the grid step. */
void charts_range(const struct charts *c, int chart, uint64_t now_us, float *lo, float *hi, float *step);

/* Draw the six charts onto the whole canvas for the window ending at now_us. */
void charts_draw(const struct charts *c, struct canvas *cv, uint64_t now_us);
/* The canvas size charts_draw is laid out for at `scale` (and the number of charts). */
#define CHART_COUNT 6
void charts_size(int scale, int *w, int *h);

/* A "nice" ceiling: the smallest of 1, 2, 2.5, 5 x 10^k not below x (x > 0). */
float charts_nice(float x);

#endif
