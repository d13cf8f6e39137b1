/* The controller core: the same code on every port (Linux process, STM32F405). No OS calls, no
 * allocation, no float. A port feeds decoded messages in (swell_ctl_rx), calls swell_ctl_tick once per
 * device tick, and drains the two output queues (swell_ctl_tx) onto its carriers.
 *
 * Tick (device rate, 2500 Hz default, 1000 Hz for classic CAN), in this order:
 *   1. link supervision: the device silent for silent_ticks ticks -> zero force and FAULT;
 *   2. state machine: BOOT -> IDLE -> ARMED -> RUNNING, any -> FAULT; force is zero outside RUNNING;
 *   3. force law (swell_body_tick_force) on the surface interpolated between the two latest solver
 *      states, then the safety stage (gain, |F| <= F_max, |dF/dt| <= R), then FORCE_CMD to the device,
 *      every tick; the water the object displaces is counted at the start of the background part
 *      (swell_body_couple_later), before the solver slice, and its cells are written at once or,
 *      while the object stays in the water, once a period before the step's finish
 *      (swell_body_place): the same bits as coupling in the force part;
 *      in effect mode (force.mode 1) FORCE_CMD carries zero force and, at each solver step, the effect
 *      set goes to the device instead (swell/effect.h); the safety stage then watches the force the
 *      set produces at the device's state (telemetry and limit flags);
 *   4. solver slice: the solver (wave.h, the velocity form: 4 words a cell) runs at the scene's own
 *      rate; its step is split over the K = tick_hz / solver_hz ticks of a period: ticks 0 .. K-2 each
 *      do about ny / (K-1) rows of the kernel ("edges" below) and, within
 *      an equal share of the period's work, the finishing pass (h += acc) and the body's ceiling scan
 *      of rows whose edges are all done; tick K-1 finishes the rest. No tick carries a whole grid step,
 *      and the force law always reads the last finished step (wave.h, finishing ahead).
 *   5. telemetry to the host link within its per-tick message budget: heartbeat (10 Hz, also to the
 *      device), scene (1 Hz), controller info (CTL_INFO: firmware version and object size, 1 Hz and
 *      on change), object pose and force (100 Hz), and the heights that changed since they
 *      were last sent: the grid is scanned round-robin in quads (4 cells of one tile row, one
 *      HEIGHT_QUAD message), a bounded number a tick (none in the tick that ends a solver step), and
 *      only quads whose wire samples differ from what was last sent go out; a quad whose tile has
 *      not moved since it was last compared is passed unread (the solver's changed tiles); a budget
 *      left over resends one quad of a slower round-robin, so that a lost quad is repaired where the
 *      water no longer moves.
 * Work per tick is counted in cell-operations (solver cells, footprint cells, tile cells scanned); the
 * maximum is kept. Overruns are measured by the port and reported here.
 *
 * States and the way back (heartbeat state codes 0..4):
 *   BOOT     until the first tick.
 *   IDLE     no device: nothing is commanded. -> ARMED when the device has been heard.
 *   ARMED    device present, force zero. -> RUNNING on the RUN command, or by itself with autorun
 *            unless the host's last command was STOP,
 *            when the device reports power and no e-stop (never after an accepted ENTER_BOOTLOADER). -> IDLE when the device goes silent.
 *   RUNNING  force law active. -> ARMED on STOP (with autorun too); -> FAULT on a silent device or e-stop.
 *   FAULT    zero force. -> IDLE on CLEAR once the device is heard again and its e-stop released, or
 *            by itself with autorun after the device has been back, heard with its e-stop released,
 *            for recover_ticks ticks (counted from the release, not from when it was first heard).
 *
 * Determinism: the core's outputs depend only on its configuration and the sequence of rx/tick calls,
 * so a trace recorded at the device link replays to bit-identical outputs on any port. */
#ifndef SWELL_CTL_H
#define SWELL_CTL_H

#include <stddef.h>
#include <stdint.h>

#include "swell/body.h"
#include "swell/ctl_port.h"
#include "swell/effect.h"
#include "swell/err.h"
#include "swell/proto.h"
#include "swell/force_safety.h"
#include "swell/param_table.h"
#include "swell/wave.h"

/* enum swell_ctl_state (the heartbeat's state codes) is in swell/proto_table.h. */

/* Parameter ids, commands and their ranges: swell/param_table.h. */

#define SWELL_CTL_QUEUE 64

/* force.mode: how the force law reaches the device. STREAM: FORCE_CMD carries the force every tick.
 * EFFECT: while RUNNING, only the effect set (swell/effect.h) goes to the device, at every solver step
 * (the update rate), as EFFECT_SPRING, EFFECT_DAMPER and EFFECT_LIMIT; the device renders it every
 * tick while it is fresh (the set is its own keepalive) and reports its position once an update.
 * Outside RUNNING (and on the tick that leaves it, and from swell_ctl_zero_force) FORCE_CMD goes as
 * in STREAM, disabled: the device drops its effects on it. The device's silence limit counts update
 * periods instead of ticks (swell_ctl_silent_limit). A port may ask for a FORCE_CMD every tick
 * (cmd_every_tick). */
enum swell_force_mode {
	SWELL_FORCE_STREAM = 0,
	SWELL_FORCE_EFFECT = 1
};

struct swell_ctl_queue {
	struct swell_msg m[SWELL_CTL_QUEUE];
	uint16_t head, count;
	uint32_t dropped; /* messages that found the queue full */
};

struct swell_ctl_config {
	uint16_t nx, ny;
	uint32_t dx_um, depth_um;
	struct swell_wave_params wave;
	struct swell_body_params body;
	struct swell_body_xform xform;
	struct swell_fsafety_params safety; /* one stage per device axis; tick_hz is set from tick_hz */
	uint32_t tick_hz, solver_hz; /* solver_hz divides tick_hz, 2 .. SWELL_BODY_MAX_K ticks a step */
	uint16_t
		silent_ticks; /* device silent this many ticks (effect mode: at least two update periods) -> fault; 1 .. 10000 */
	uint16_t recover_ticks; /* autorun: device back (heard, no e-stop) this long before leaving FAULT */
	uint16_t host_budget; /* host messages a tick, 1 .. SWELL_CTL_QUEUE / 2 */
	uint8_t node; /* 0 .. SWELL_NODE_MAX */
	uint8_t autorun;
	uint8_t force_mode; /* SWELL_FORCE_STREAM or SWELL_FORCE_EFFECT; changed only outside RUNNING */
	/* set by a port whose device link needs a FORCE_CMD every tick in effect mode too (the
	 * HapticMaster's TCP interface: each tick's request carries it): enabled with zero force while
	 * RUNNING, beside the sets, and the silence limit stays in ticks */
	uint8_t cmd_every_tick;
	uint8_t fw_version[3]; /* major, minor, patch of the running firmware, sent in CTL_INFO */
};

struct swell_ctl_counters {
	uint32_t ticks, solver_steps;
	uint32_t overruns; /* reported by the port */
	uint32_t bad_frames; /* reported by the port (decoder rejections) */
	uint32_t work, work_max; /* cell-operations in the last tick, and the most in any tick */
	uint32_t dev_lost; /* device sequence numbers skipped (a jump past SWELL_SEQ_WINDOW: dev_seq.resyncs) */
	uint32_t faults;
	uint32_t quads_sent;
	uint32_t quads_refreshed; /* of which resent unchanged, to repair losses */
	uint32_t params_set, params_refused;
	uint32_t ignored; /* messages that make no sense here (wrong direction, bootloader while running) */
};

struct swell_ctl {
	struct swell_ctl_config cfg;
	enum swell_ctl_state state;
	enum swell_err last_err;
	struct swell_wave wave;
	struct swell_body body;
	struct swell_fsafety safety[3];
	uint32_t *sent; /* last wire sample sent per cell, two int16 a word; INT16_MIN: never sent */
	/* a bit a quad, 16 a tile: set where the quad's samples may differ from sent (its tile moved
	 * since the quad was last compared); a clear bit lets the scan pass the quad without reading it */
	uint16_t *quad_stale;

	/* device link */
	int32_t pos_um[3], vel_um_s[3];
	uint8_t dev_status;
	uint8_t dev_heard; /* a device message arrived since the last tick */
	uint32_t since_dev; /* ticks since the device was last heard (saturating) */
	uint32_t dev_back; /* ticks the device has been heard without a gap */
	struct swell_seq dev_seq;
	uint8_t dev_step; /* the last DEVICE_POS's seq step: device ticks it stands for (1 for the first) */
	uint8_t run_request, clear_request;
	uint8_t host_stop; /* STOP received and no RUN since: autorun does not start the force law */
	/* Set when an ENTER_BOOTLOADER was accepted (outside RUNNING, with the key): the core has zeroed
	 * the force and queued a last heartbeat; the port drains its queues and reboots into its
	 * bootloader (or, without one, exits). The core never clears it. */
	uint8_t bootloader_request;
	uint8_t info_pending; /* CTL_INFO to send at the next tick with budget (start, object changed) */
	uint32_t info_wait; /* ticks until the periodic CTL_INFO */

	/* scheduling */
	uint32_t ticks_per_step, phase;
	uint32_t work_force; /* work of the force part of the tick in progress */
	volatile uint8_t bg_pending; /* force part done, background part not yet */

	/* outputs */
	struct swell_body_out out;
	int32_t force_dev_uN[3]; /* after the safety stage, device axes */
	uint8_t limits; /* bit 0 |F| clamped, bit 1 rate limited, last tick */
	uint8_t seq_force, seq_hb, seq_pose;
	struct swell_effect effect; /* effect mode: the set last sent (seq: the next one's number) */
	uint8_t effect_sent; /* a set went out since RUNNING was entered */
	uint8_t scene_id; /* from the scene geometry: a viewer sees a new scene when it changes */

	/* telemetry */
	uint16_t tiles_x, tiles_y;
	uint32_t quads, quad_cursor; /* quads in the grid (16 a tile), next one to scan */
	uint32_t quad_reads; /* stale quads the scan reads a tick at most (ctl.c, QUAD_READS_PER_S) */
	uint32_t refresh_cursor; /* next quad to resend whatever its state */
	uint32_t fp_cells; /* footprint cells of the object, for the work count */

	struct swell_ctl_queue q[SWELL_LINKS];
	struct swell_ctl_counters n;
};

/* int32 words of the arena the controller needs for an nx x ny scene (wave storage + sent heights). */
size_t swell_ctl_arena_words(uint16_t nx, uint16_t ny);

/* A configuration for the reference scene "pool" (docs/design.md, section 4): 64 x 64 cells of 6.25 mm, depth
 * 50 mm, solver 250 Hz, device 2500 Hz, a 50 mm cube of 100 g. */
void swell_ctl_default_config(struct swell_ctl_config *cfg);

/* Validate a configuration without touching anything. */
enum swell_err swell_ctl_check(const struct swell_ctl_config *cfg);

/* Bind the arena (at least swell_ctl_arena_words words) and start in BOOT with the water at rest.
 * On error *c is untouched. */
enum swell_err swell_ctl_init(struct swell_ctl *c, const struct swell_ctl_config *cfg, int32_t *arena, size_t words);

/* The same with the buffer only the CPU touches, the solver's momentum u (swell_ctl_apart_words), in a
 * block of its own, so that a port can put it in another memory (the STM32F405's core-coupled RAM);
 * arena then holds the rest, the telemetry's last samples with it (swell_ctl_arena_words_apart).
 * The same bits as swell_ctl_init. On error *c is untouched. */
size_t swell_ctl_arena_words_apart(uint16_t nx, uint16_t ny);
size_t swell_ctl_apart_words(uint16_t nx, uint16_t ny);
enum swell_err swell_ctl_init_apart(struct swell_ctl *c, const struct swell_ctl_config *cfg, int32_t *arena,
				    size_t words, int32_t *apart, size_t apart_words);

/* The port side (rx, tick, tx, link events, reports): swell/ctl_port.h. */

const char *swell_ctl_state_name(enum swell_ctl_state s);

#endif
