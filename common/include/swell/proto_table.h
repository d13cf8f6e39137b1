/* The swell wire protocol: THE single source. Every message, field, width, scale, unit and range is
 * listed here once; the C encoders/decoders (proto.c), the CAN database (docs/swell.dbc) and the
 * reference (docs/protocol.md) are expanded from it (tools/protocol/swell-protogen).
 *
 * Change a line here, run swell-protogen, commit the regenerated files; CI fails on any difference.
 * Bump SWELL_PROTO_VERSION whenever an existing layout changes.
 *
 * SWELL_PROTO_MESSAGES(M) lists the messages, in priority order:
 *   M(NAME, name, type, len, from, to, "description")
 *     type  7-bit message type; classic CAN id = type << 4 | node (lower id wins arbitration)
 *     len   payload length in bytes (<= 8, so every message fits one classic CAN frame)
 *     from, to  sending and receiving node kinds (CTL controller, DEV HapticMaster, VIEW host viewer)
 * SWELL_PROTO_FIELDS_<name>(F, m) lists the fields of one message (m is passed through to F):
 *   F(m, member, ctype, start, bits, min, max, kind, "factor", "unit", "description")
 *     start, bits  little-endian (Intel) bit position and width, as in a DBC file
 *     min, max     valid raw range; a field is signed iff min < 0; raw outside it is rejected
 *     kind         PLAIN, SEQ (stream sequence number, wraps), VERSION (must equal the version)
 *     factor, unit physical value = raw * factor, in unit (offset is always 0)
 * Bits of a payload that no field covers are reserved: sent as 0, a frame with any set is rejected. */
#ifndef SWELL_PROTO_TABLE_H
#define SWELL_PROTO_TABLE_H

#include <stdint.h>

#include "swell/err.h"

#define SWELL_PROTO_VERSION 1

/* Heights on the wire: int12 samples, LSB 2^-SWELL_PROTO_H_SHIFT mm (1/64 mm = 15.625 um),
 * saturated to [-32, +31.984] mm relative to rest depth. The solver's heights are int32 with
 * LSB 2^-16 mm: sample = sat12(round(h >> (16 - SWELL_PROTO_H_SHIFT))). */
#define SWELL_PROTO_H_SHIFT 6
/* Tiles are SWELL_PROTO_TILE x SWELL_PROTO_TILE cells; one HEIGHT_QUAD frame carries 4 cells of
 * one tile row, so a tile is 16 frames. Up to 32 x 32 tiles: grids up to 256 x 256 cells. */
#define SWELL_PROTO_TILE 8
#define SWELL_PROTO_BOOT_KEY 0x4C425753u /* "SWBL" little-endian */

/* DEVICE_POS.status bits. */
enum swell_dev_status {
	SWELL_DEV_POWERED = 1u << 0,
	SWELL_DEV_FORCE_ON = 1u << 1,
	SWELL_DEV_ESTOP = 1u << 2,
	SWELL_DEV_FAULT = 1u << 3
};

/* Controller states, as HEARTBEAT.state carries them: S(NAME, code, "name"). */
#define SWELL_STATES(S) \
	S(BOOT, 0, "boot") S(IDLE, 1, "idle") S(ARMED, 2, "armed") S(RUNNING, 3, "running") S(FAULT, 4, "fault")

enum swell_ctl_state {
#define SWELL_X(NAME, code, name) SWELL_CTL_##NAME = code,
	SWELL_STATES(SWELL_X)
#undef SWELL_X
};

#define SWELL_PROTO_MESSAGES(M)                                                                                       \
	M(FORCE_CMD, force_cmd, 0x01, 8, CTL, DEV,                                                                    \
	  "Force command to the HapticMaster, every haptic tick (effect mode: only outside RUNNING, disabled). Zero " \
	  "force unless ENABLE is set.")                                                                              \
	M(DEVICE_POS, device_pos, 0x02, 8, DEV, CTL,                                                                  \
	  "Measured end-effector position and device status, every haptic tick (effect mode: once an update while "   \
	  "effect sets come).")                                                                                       \
	M(DEVICE_VEL, device_vel, 0x03, 7, DEV, CTL,                                                                  \
	  "Measured end-effector velocity, every haptic tick where the carrier has room.")                            \
	M(DEVICE_FORCE, device_force, 0x04, 7, DEV, CTL,                                                              \
	  "Measured force at the force sensor, every haptic tick where the carrier has room.")                        \
	M(EFFECT_SPRING, effect_spring, 0x05, 7, CTL, DEV,                                                            \
	  "Effect mode: the two buoyancy springs, every update (docs/force-law.md). Same seq as EFFECT_DAMPER and "   \
	  "EFFECT_LIMIT: the device renders a set only once all three of one seq have come, and only while it is "    \
	  "fresh (the sets are its keepalive).")                                                                      \
	M(EFFECT_DAMPER, effect_damper, 0x06, 8, CTL, DEV,                                                            \
	  "Effect mode: the damper, the gravity force and the springs' spacing H, every update.")                     \
	M(EFFECT_LIMIT, effect_limit, 0x07, 5, CTL, DEV,                                                              \
	  "Effect mode: the force and rate limits the device applies to what the effects produce, every update.")     \
	M(HEARTBEAT, heartbeat, 0x08, 8, CTL, VIEW,                                                                   \
	  "Controller state, last error, protocol version and counters, 10 Hz (also to DEV).")                        \
	M(PARAM_SET, param_set, 0x10, 7, VIEW, CTL, "Set a parameter; answered by PARAM_ACK or PARAM_NACK.")          \
	M(PARAM_GET, param_get, 0x11, 3, VIEW, CTL, "Read a parameter; answered by PARAM_ACK or PARAM_NACK.")         \
	M(PARAM_ACK, param_ack, 0x12, 7, CTL, VIEW, "Parameter value now in force (answer to SET or GET).")           \
	M(PARAM_NACK, param_nack, 0x13, 4, CTL, VIEW,                                                                 \
	  "Parameter request refused with a swell_err code; nothing was changed.")                                    \
	M(ENTER_BOOTLOADER, enter_bootloader, 0x18, 4, VIEW, CTL,                                                     \
	  "Reboot into the bootloader; accepted only with the key and outside RUNNING.")                              \
	M(SCENE, scene, 0x20, 8, CTL, VIEW, "Scene description, 1 Hz and on change, so that a viewer can join late.") \
	M(OBJECT_POSE, object_pose, 0x21, 8, CTL, VIEW, "Floating object pose and submersion, viewer rate.")          \
	M(OBJECT_FORCE, object_force, 0x22, 8, CTL, VIEW, "Force the force law commands, viewer rate.")               \
	M(CTL_INFO, ctl_info, 0x23, 8, CTL, VIEW,                                                                     \
	  "Firmware version and object size, 1 Hz and on change, so that a viewer or flasher can join late.")         \
	M(ENERGY, energy, 0x24, 8, CTL, VIEW,                                                                         \
	  "The energy account of the run (docs/energy.md), with the heartbeat: energy created and the balance D.")    \
	M(HEIGHT_QUAD, height_quad, 0x30, 8, CTL, VIEW,                                                               \
	  "Four heights of one tile row; a changed tile is sent as its 16 quads. Lowest priority.")

#define SWELL_PROTO_FIELDS_force_cmd(F, m)                                                    \
	F(m, fx_cN, int16_t, 0, 16, -25000, 25000, PLAIN, "0.01", "N", "force along x")       \
	F(m, fy_cN, int16_t, 16, 16, -25000, 25000, PLAIN, "0.01", "N", "force along y")      \
	F(m, fz_cN, int16_t, 32, 16, -25000, 25000, PLAIN, "0.01", "N", "force along z (up)") \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "sequence number, +1 per command")    \
	F(m, enable, uint8_t, 56, 1, 0, 1, PLAIN, "1", "", "1: apply the force; 0: zero force")

#define SWELL_PROTO_FIELDS_device_pos(F, m)                                                    \
	F(m, x_10um, int16_t, 0, 16, -30000, 30000, PLAIN, "0.01", "mm", "position x")         \
	F(m, y_10um, int16_t, 16, 16, -30000, 30000, PLAIN, "0.01", "mm", "position y")        \
	F(m, z_10um, int16_t, 32, 16, -30000, 30000, PLAIN, "0.01", "mm", "position z (up)")   \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "sequence number, +1 per device tick") \
	F(m, status, uint8_t, 56, 4, 0, 15, PLAIN, "1", "",                                    \
	  "bit 0 powered, bit 1 force enabled, bit 2 e-stop pressed, bit 3 fault")

#define SWELL_PROTO_FIELDS_device_vel(F, m)                                                      \
	F(m, vx_100ums, int16_t, 0, 16, -30000, 30000, PLAIN, "0.1", "mm/s", "velocity x")       \
	F(m, vy_100ums, int16_t, 16, 16, -30000, 30000, PLAIN, "0.1", "mm/s", "velocity y")      \
	F(m, vz_100ums, int16_t, 32, 16, -30000, 30000, PLAIN, "0.1", "mm/s", "velocity z (up)") \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "sequence number, same as DEVICE_POS")

#define SWELL_PROTO_FIELDS_device_force(F, m)                                                    \
	F(m, fx_cN, int16_t, 0, 16, -25000, 25000, PLAIN, "0.01", "N", "measured force x")       \
	F(m, fy_cN, int16_t, 16, 16, -25000, 25000, PLAIN, "0.01", "N", "measured force y")      \
	F(m, fz_cN, int16_t, 32, 16, -25000, 25000, PLAIN, "0.01", "N", "measured force z (up)") \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "sequence number, same as DEVICE_POS")

#define SWELL_PROTO_FIELDS_effect_spring(F, m)                                                                  \
	F(m, surface_10um, int16_t, 0, 16, -30000, 30000, PLAIN, "0.01", "mm",                                  \
	  "device z of the pulling spring's origin (the water surface w under the object)")                     \
	F(m, uw_100ums, int16_t, 16, 16, -30000, 30000, PLAIN, "0.1", "mm/s",                                   \
	  "the water's vertical velocity: the springs' and the damper's vel")                                   \
	F(m, k_10mN_m, uint16_t, 32, 16, 0, 65535, PLAIN, "0.01", "N/m", "stiffness of each spring, rho g a b") \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "update number, +1 per update")

#define SWELL_PROTO_FIELDS_effect_damper(F, m)                                                                     \
	F(m, b_10mNs_m, uint16_t, 0, 16, 0, 65535, PLAIN, "0.01", "N*s/m", "damper coefficient b_max s")           \
	F(m, bias_mN, int32_t, 16, 24, -8388607, 8388607, PLAIN, "0.001", "N", "constant force along z (gravity)") \
	F(m, h_10um, uint16_t, 40, 16, 1, 65535, PLAIN, "0.01", "mm",                                              \
	  "the pushing spring's origin is this much lower")                                                        \
	F(m, seq, uint8_t, 56, 8, 0, 255, SEQ, "1", "", "update number, same as EFFECT_SPRING")

#define SWELL_PROTO_FIELDS_effect_limit(F, m)                                                                       \
	F(m, fmax_cN, uint16_t, 0, 16, 1, 25000, PLAIN, "0.01", "N", "largest |force| the effects may produce")     \
	F(m, rate_100mN_s, uint16_t, 16, 16, 1, 65535, PLAIN, "0.1", "N/s", "largest rate of change of that force") \
	F(m, seq, uint8_t, 32, 8, 0, 255, SEQ, "1", "", "update number, same as EFFECT_SPRING")

#define SWELL_PROTO_FIELDS_heartbeat(F, m)                                                                            \
	F(m, state, uint8_t, 0, 8, 0, 4, PLAIN, "1", "", "0 boot, 1 idle, 2 armed, 3 running, 4 fault")               \
	F(m, err, uint8_t, 8, 8, 0, SWELL_ERR_COUNT - 1, PLAIN, "1", "", "last error, enum swell_err (0 none)")       \
	F(m, version, uint8_t, 16, 8, SWELL_PROTO_VERSION, SWELL_PROTO_VERSION, VERSION, "1", "", "protocol version") \
	F(m, seq, uint8_t, 24, 8, 0, 255, SEQ, "1", "", "sequence number, +1 per heartbeat")                          \
	F(m, bad_frames, uint16_t, 32, 16, 0, 65535, PLAIN, "1", "", "frames rejected, saturating")                   \
	F(m, overruns, uint16_t, 48, 16, 0, 65535, PLAIN, "1", "", "tick overruns, saturating")

#define SWELL_PROTO_FIELDS_param_set(F, m)                                                                  \
	F(m, id, uint16_t, 0, 16, 0, 65535, PLAIN, "1", "", "parameter id (firmware parameter table)")      \
	F(m, value, int32_t, 16, 32, INT32_MIN, INT32_MAX, PLAIN, "1", "", "raw value, unit per parameter") \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "request number, echoed in the answer")

#define SWELL_PROTO_FIELDS_param_get(F, m)                                  \
	F(m, id, uint16_t, 0, 16, 0, 65535, PLAIN, "1", "", "parameter id") \
	F(m, seq, uint8_t, 16, 8, 0, 255, SEQ, "1", "", "request number, echoed in the answer")

#define SWELL_PROTO_FIELDS_param_ack(F, m)                                                   \
	F(m, id, uint16_t, 0, 16, 0, 65535, PLAIN, "1", "", "parameter id")                  \
	F(m, value, int32_t, 16, 32, INT32_MIN, INT32_MAX, PLAIN, "1", "", "value in force") \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "request number answered")

#define SWELL_PROTO_FIELDS_param_nack(F, m)                                                                   \
	F(m, id, uint16_t, 0, 16, 0, 65535, PLAIN, "1", "", "parameter id")                                   \
	F(m, err, uint8_t, 16, 8, 1, SWELL_ERR_COUNT - 1, PLAIN, "1", "", "reason, enum swell_err (never 0)") \
	F(m, seq, uint8_t, 24, 8, 0, 255, SEQ, "1", "", "request number answered")

#define SWELL_PROTO_FIELDS_enter_bootloader(F, m)                                              \
	F(m, key, uint32_t, 0, 32, SWELL_PROTO_BOOT_KEY, SWELL_PROTO_BOOT_KEY, PLAIN, "1", "", \
	  "must be 0x4C425753 (\"SWBL\")")

#define SWELL_PROTO_FIELDS_scene(F, m)                                                          \
	F(m, nx, uint16_t, 0, 9, 1, 256, PLAIN, "1", "cells", "grid columns")                   \
	F(m, ny, uint16_t, 9, 9, 1, 256, PLAIN, "1", "cells", "grid rows")                      \
	F(m, h_shift, uint8_t, 18, 4, SWELL_PROTO_H_SHIFT, SWELL_PROTO_H_SHIFT, PLAIN, "1", "", \
	  "height sample LSB is 2^-h_shift mm")                                                 \
	F(m, dx_um, uint16_t, 24, 16, 100, 65535, PLAIN, "0.001", "mm", "cell size")            \
	F(m, depth_10um, uint16_t, 40, 16, 1, 65535, PLAIN, "0.01", "mm", "rest depth")         \
	F(m, scene_id, uint8_t, 56, 8, 0, 255, PLAIN, "1", "", "changes whenever the scene changes")

#define SWELL_PROTO_FIELDS_object_pose(F, m)                                                               \
	F(m, x_10um, int16_t, 0, 16, -30000, 30000, PLAIN, "0.01", "mm", "object centre x, pool frame")    \
	F(m, y_10um, int16_t, 16, 16, -30000, 30000, PLAIN, "0.01", "mm", "object centre y, pool frame")   \
	F(m, z_10um, int16_t, 32, 16, -30000, 30000, PLAIN, "0.01", "mm", "object bottom z, rest level 0") \
	F(m, submersion_halfpct, uint8_t, 48, 8, 0, 200, PLAIN, "0.5", "%", "submerged fraction")          \
	F(m, seq, uint8_t, 56, 8, 0, 255, SEQ, "1", "", "sequence number")

#define SWELL_PROTO_FIELDS_object_force(F, m)                                                      \
	F(m, fx_cN, int16_t, 0, 16, -25000, 25000, PLAIN, "0.01", "N", "force law output x")       \
	F(m, fy_cN, int16_t, 16, 16, -25000, 25000, PLAIN, "0.01", "N", "force law output y")      \
	F(m, fz_cN, int16_t, 32, 16, -25000, 25000, PLAIN, "0.01", "N", "force law output z (up)") \
	F(m, seq, uint8_t, 48, 8, 0, 255, SEQ, "1", "", "sequence number, same as OBJECT_POSE")    \
	F(m, limits, uint8_t, 56, 2, 0, 3, PLAIN, "1", "", "bit 0 |F| clamped, bit 1 dF/dt limited")

#define SWELL_PROTO_FIELDS_ctl_info(F, m)                                                                        \
	F(m, fw_major, uint8_t, 0, 8, 0, 255, PLAIN, "1", "", "firmware version, major")                         \
	F(m, fw_minor, uint8_t, 8, 8, 0, 255, PLAIN, "1", "", "firmware version, minor")                         \
	F(m, fw_patch, uint8_t, 16, 8, 0, 255, PLAIN, "1", "", "firmware version, patch")                        \
	F(m, obj_a_100um, uint16_t, 24, 13, 1, 8191, PLAIN, "0.1", "mm", "object footprint along x (saturated)") \
	F(m, obj_b_100um, uint16_t, 37, 13, 1, 8191, PLAIN, "0.1", "mm", "object footprint along y (saturated)") \
	F(m, obj_h_100um, uint16_t, 50, 13, 1, 8191, PLAIN, "0.1", "mm", "object height (saturated)")

#define SWELL_PROTO_FIELDS_energy(F, m)                                                                               \
	F(m, created_uJ, uint32_t, 0, 32, 0, 4294967295u, PLAIN, "0.001", "mJ",                                       \
	  "energy created in this run, max(0, -min D), saturating")                                                   \
	F(m, balance_10uJ, int32_t, 32, 24, -8388607, 8388607, PLAIN, "0.01", "mJ",                                   \
	  "D = W - (S - S(0)): dissipated since the run began (below 0: created), saturating")                        \
	F(m, acting, uint8_t, 56, 1, 0, 1, PLAIN, "1", "", "1: the passivity controller acted since the last ENERGY") \
	F(m, passivity, uint8_t, 57, 1, 0, 1, PLAIN, "1", "", "force.passivity in force")

#define SWELL_PROTO_FIELDS_height_quad(F, m)                                                      \
	F(m, tile_x, uint8_t, 0, 5, 0, 31, PLAIN, "1", "", "tile column")                         \
	F(m, tile_y, uint8_t, 5, 5, 0, 31, PLAIN, "1", "", "tile row")                            \
	F(m, row, uint8_t, 10, 3, 0, 7, PLAIN, "1", "", "row inside the tile")                    \
	F(m, half, uint8_t, 13, 1, 0, 1, PLAIN, "1", "", "0: cells 0-3 of the row, 1: cells 4-7") \
	F(m, frame, uint8_t, 14, 2, 0, 3, PLAIN, "1", "", "solver frame number, low 2 bits")      \
	F(m, h0, int16_t, 16, 12, -2048, 2047, PLAIN, "0.015625", "mm", "height of cell 0 or 4")  \
	F(m, h1, int16_t, 28, 12, -2048, 2047, PLAIN, "0.015625", "mm", "height of cell 1 or 5")  \
	F(m, h2, int16_t, 40, 12, -2048, 2047, PLAIN, "0.015625", "mm", "height of cell 2 or 6")  \
	F(m, h3, int16_t, 52, 12, -2048, 2047, PLAIN, "0.015625", "mm", "height of cell 3 or 7")

#endif
