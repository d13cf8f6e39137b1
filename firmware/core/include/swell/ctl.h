/* The controller core: the same code on every port, no OS calls, no allocation, no float; a port
 * drives it through swell/ctl_port.h. The tick's five steps (supervision, states, force law and
 * safety, solver slice, telemetry), the states and the determinism it keeps: docs/design.md, "The
 * controller's tick and states". */
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

/* enum swell_ctl_state (the heartbeat's state codes): swell/proto_table.h; parameter ids, commands and
 * their ranges: swell/param_table.h. */

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
	/* the frame's axes and flips as the parameters frame.axes and frame.flip say them: always what
	 * xform.axis and xform.sign hold (swell_ctl_check refuses a configuration where they differ) */
	uint16_t frame_axes; /* (axis[0] + 1) * 100 + (axis[1] + 1) * 10 + axis[2] + 1 */
	uint8_t frame_flip; /* bit k: sign[k] is -1 */
	uint32_t hm_inertia_g; /* hm.inertia: a HapticMaster link's port sets the device to it, 0: not */
	uint8_t passivity; /* force.passivity: 1 the time-domain passivity controller acts, 0 it only observes */
	uint8_t pc_delay; /* force.pc_delay: the link's command delay in ticks the account pairs forces with, 0 .. 7 */
	uint32_t pc_damping_uN_per_mm_s; /* force.pc_damping: the passivity controller's damping at most */
	/* set by a port that keeps the water's energy in the account (a pass over the field at each solver
	 * step's end, in the background part; docs/energy.md): 0 leaves it out of S and D on every port */
	uint8_t energy_water;
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

/* The energy account's sums (ctl_energy.c), in picojoules (uN x um), saturating: an int64 holds
 * +-9.2e6 J, a 10-minute run at 2500 Hz with 1000 N and 1 m/s on every axis stays below 2e15. The
 * force part keeps the tick's position and adds the controller's force; the background part counts. */
#define SWELL_CTL_PC_RING 8 /* force.pc_delay + 1 at most, a power of two */
struct swell_ctl_energy_sums {
	int64_t work_pJ; /* W */
	int64_t stored0_pJ, stored_pJ; /* S(0), S(n) */
	int64_t balance_pJ, min_balance_pJ; /* D after the last tick counted, and the least of the run */
	int64_t damped_pJ; /* what the passivity controller's force took out, as W counts it */
	int64_t water_pJ, water0_pJ; /* the water's share of S(n) and S(0) (energy_water) */
	int32_t pos_now_um[3]; /* the device position the force part used */
	int32_t pos_um[3]; /* the device position of the last tick counted */
	int32_t force_uN[3]; /* the force commanded on the last tick (after the safety stage, the wire's cN) */
	int32_t pc_uN[3]; /* the controller's force this tick (asked for, before the safety stage) */
	/* along the force law's axis, the last SWELL_CTL_PC_RING ticks, newest at ring_head: the force sent
	 * (the wire's cN) and the controller's part of it (cN, nearest, within the wire's 250 N); the device
	 * applies the one force.pc_delay ticks old */
	int16_t ring_cN[SWELL_CTL_PC_RING], pc_ring_cN[SWELL_CTL_PC_RING];
	uint32_t ticks, controller_ticks;
	uint8_t running; /* a run is being counted */
	uint8_t fresh; /* its first tick: S(0) to take */
	uint8_t acted; /* the controller acted since the last ENERGY message */
	uint8_t ring_head; /* the newest slot of ring_cN and pc_ring_cN */
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
	uint16_t dev_rate_hz; /* DEVICE_POS heard in the last whole second of ticks (dev.rate) */
	uint32_t dev_count, dev_window; /* DEVICE_POS and ticks in the second being counted */
	uint32_t since_dev; /* ticks since the device was last heard (saturating) */
	uint32_t dev_back; /* ticks the device has been heard without a gap */
	struct swell_seq dev_seq;
	uint8_t dev_step; /* the last DEVICE_POS's seq step: device ticks it stands for (1 for the first) */
	uint8_t run_request, clear_request;
	uint8_t host_stop; /* STOP received and no RUN since: autorun does not start the force law */
	/* an ENTER_BOOTLOADER accepted (swell_ctl_bootloader_requested); the core never clears it */
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
	uint32_t quad_reads; /* stale quads the scan reads a tick at most (ctl_priv.h, QUAD_READS_PER_S) */
	uint32_t refresh_cursor; /* next quad to resend whatever its state */
	uint32_t fp_cells; /* footprint cells of the object, for the work count */

	struct swell_ctl_queue q[SWELL_LINKS];
	struct swell_ctl_counters n;
	struct swell_ctl_energy_sums energy;
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

/* The energy account of the hand-water loop (docs/energy.md), kept by the core on every tick of a
 * run (from the tick that enters RUNNING to the one that leaves it; the next run starts it again):
 *   W  the work the hand did on the virtual environment, sum over device samples of -F . dx, F the
 *      force commanded after the safety stage on the previous tick (the force held while the device
 *      moved), dx the device's differenced position (DEVICE_POS), both on the device's axes;
 *   S  what the environment stores more than at the run's start: the object's weight m g z, the
 *      buoyancy springs as rendered (1/2 k s^2 up to full submersion or force.max, linear beyond),
 *      the floor's contact spring (the same), and the water's energy (the solver's invariant, on
 *      ports that keep it);
 *   D  = W - S: what the environment dissipated; below zero it created energy;
 *   created = max(0, -min D) over the run; damped: what the passivity controller (force.passivity)
 *   took out. All in microjoules, rounded to nearest from the core's picojoule sums. */
struct swell_energy_account {
	int64_t work_uJ; /* W */
	int64_t stored_uJ; /* S(n) - S(0) */
	int64_t balance_uJ; /* D = W - (S(n) - S(0)) */
	int64_t created_uJ; /* max(0, -min D), never negative */
	int64_t damped_uJ; /* the passivity controller's force times the motion (below 0 only where the
			    * reported velocity disagrees with the motion) */
	int64_t water_uJ; /* the water's part of S(n) - S(0) */
	uint32_t ticks; /* ticks counted in this run */
	uint32_t controller_ticks; /* ticks on which the passivity controller added damping */
};

/* The energy account of the current (or the last) run into *out; SWELL_EINVAL for a null pointer.
 * Reads only: a port or a bench may call it between any two ticks. */
enum swell_err swell_ctl_energy(const struct swell_ctl *c, struct swell_energy_account *out);

/* The water's energy in picojoules from the solver's invariant (swell_wave_energy): rho g dx^2 /
 * (2 e_eff) (kin + e_eff pot2 / 2) LSB^2, the physical energy of a wave about nine cells long
 * (docs/energy.md says why and for which waves it is less or more). One pass over the field. */
int64_t swell_ctl_water_pJ(const struct swell_wave *w, uint32_t dx_um, uint32_t rho_kg_m3, uint32_t g_mm_s2);

/* The port side (rx, tick, tx, link events, reports): swell/ctl_port.h. */

const char *swell_ctl_state_name(enum swell_ctl_state s);

#endif
