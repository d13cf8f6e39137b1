/* The controller's parameters: THE single source, beside the message table (proto_table.h). The
 * core's get/set (firmware/core/src/ctl_param.c), the reference configuration, docs/protocol.md
 * (tools/protocol/swell-protogen) and every tool that names a parameter (swell-tool, swell-inject,
 * swell-flash) are expanded from it.
 *
 * A parameter travels as PARAM_SET / PARAM_GET with a raw int32 value; physical = raw x factor, in
 * unit. SWELL_PARAMS(P) lists them:
 *   P(NAME, id, "name", member, ctype, group, min, max, def, "factor", "unit", access, when, "description")
 *     NAME     suffix of the id constant SWELL_PARAM_<NAME> and the default SWELL_PARAM_DEF_<NAME>
 *     id       16-bit id on the wire (never reused)
 *     "name"   what people and tools call it (swell-tool get body.mass)
 *     member   RW: the field of struct swell_ctl_config that holds it; RO: the field of struct
 *              swell_ctl (expanded only in the core)
 *     ctype    its C type there
 *     group    the module that validates and takes it: WAVE (solver), BODY (force law), SIZE (force
 *              law; the object's size, also sent in CTL_INFO), SAFETY (safety stage), FRAME (the
 *              device-to-pool frame, taken by the force law), CORE
 *     min, max raw range; outside it the set is refused with SWELL_ERANGE before anything else
 *              (the module's own checks, such as stability, come after it)
 *     def      raw value in the reference scene (swell_ctl_default_config)
 *     access   RW: read and written by the host link (the controller writes none itself); RO: what
 *              the controller measures, read only (a set is refused with SWELL_EINVAL; never in a
 *              scene file)
 *     when     ANY: in every state; DRY: refused (SWELL_ESTATE) while the object displaces water;
 *              IDLE: refused (SWELL_ESTATE) while the force law runs (RUNNING)
 *
 * SWELL_PARAM_COMMAND is write only: its value is one of SWELL_COMMANDS(C):
 *   C(NAME, value, "name", "description")
 * Changing a row's meaning needs a new id; adding a row does not change the protocol version. */
#ifndef SWELL_PARAM_TABLE_H
#define SWELL_PARAM_TABLE_H

#include <stdint.h>

#include "swell/pool.h"

/* 2^-30 and 2^-16 written out in decimal (exact), the factors of Q1.30 and Q15.16 values. */
#define SWELL_PARAM_Q30 "0.000000000931322574615478515625"
#define SWELL_PARAM_Q16 "0.0000152587890625"

#define SWELL_PARAMS(P)                                                                                                \
	P(WAVE_E, 1, "wave.e", wave.e, int32_t, WAVE, 1, INT32_MAX, 215723192, SWELL_PARAM_Q30, "", RW, ANY,           \
	  "solver coupling e = g dt^2 d / dx^2 (eq. 2), Q1.30; refused (unstable) at or above "                        \
	  "the stability limit, 1/2 without damping")                                                                  \
	P(WAVE_DAMPING, 2, "wave.damping", wave.damping, int32_t, WAVE, 0, 1073741823, 1073742, SWELL_PARAM_Q30, "",   \
	  RW, ANY, "damping t per solver step, Q1.30; the stability limit grows with it")                              \
	P(WAVE_STENCIL, 3, "wave.stencil", wave.stencil, enum swell_stencil, WAVE, 0, 1, 0, "1", "", RW, ANY,          \
	  "0 paper (the printed 9-point L9), 1 calibrated (L9 / 2: waves at sqrt(g d))")                               \
	P(BODY_MASS_G, 10, "body.mass", body.mass_g, uint32_t, BODY, 1, 100000, 100, "1", "g", RW, DRY,                \
	  "mass of the object (its weight m g within the force law's limit)")                                          \
	P(BODY_A_UM, 11, "body.a", body.a_um, uint32_t, SIZE, 1000, 4194240, SWELL_POOL_BOX_UM, "0.001", "mm", RW,     \
	  DRY, "footprint along pool x, at most 64 cells")                                                             \
	P(BODY_B_UM, 12, "body.b", body.b_um, uint32_t, SIZE, 1000, 4194240, SWELL_POOL_BOX_UM, "0.001", "mm", RW,     \
	  DRY, "footprint along pool y, at most 64 cells")                                                             \
	P(BODY_H_UM, 13, "body.h", body.h_um, uint32_t, SIZE, 1000, 500000, SWELL_POOL_BOX_UM, "0.001", "mm", RW, DRY, \
	  "height H of the box (the two springs' origins are H apart)")                                                \
	P(BODY_DAMPER, 14, "body.damper", body.damper_uN_per_mm_s, uint32_t, BODY, 0, 10000000, 15000, "0.001",        \
	  "N*s/m", RW, DRY, "viscous damper b_max at full submersion (raw uN per mm/s)")                               \
	P(FORCE_MAX_UN, 20, "force.max", safety.f_max_uN, uint32_t, SAFETY, 1, 1000000000, 10000000, "0.000001", "N",  \
	  RW, ANY, "limit of the force on each device axis; a lowered limit cuts at once")                             \
	P(FORCE_RATE, 21, "force.rate", safety.rate_uN_per_s, uint32_t, SAFETY, 10, INT32_MAX, 500000000, "0.000001",  \
	  "N/s", RW, ANY, "limit of the force's rate of change on each axis, at least 1 uN per tick")                  \
	P(FORCE_GAIN, 22, "force.gain", safety.gain, int32_t, SAFETY, 0, 262144, 65536, SWELL_PARAM_Q16, "", RW, ANY,  \
	  "haptic gain on the force law's output, Q15.16, 0 to 4")                                                     \
	P(FORCE_MODE, 23, "force.mode", force_mode, uint8_t, CORE, 0, 1, 0, "1", "", RW, IDLE,                         \
	  "0 stream (FORCE_CMD every tick), 1 effect (springs, damper and gravity as device effects, every update)")   \
	P(FORCE_PASSIVITY, 24, "force.passivity", passivity, uint8_t, CORE, 0, 1, 1, "1", "", RW, ANY,                 \
	  "1: the time-domain passivity controller adds damping, at most force.pc_damping, while the energy "          \
	  "account shows energy created (docs/energy.md), inside force.max and force.rate, in stream mode; 0: "        \
	  "the account only observes")                                                                                 \
	P(FORCE_PC_DELAY, 25, "force.pc_delay", pc_delay, uint8_t, CORE, 0, 7, 0, "1", "ticks", RW, ANY,               \
	  "stream mode: the device applies a FORCE_CMD this many ticks after the controller sends it (the "            \
	  "link's delay); the energy account pairs each motion with the force applied then: the device's "             \
	  "port (docs/energy.md)")                                                                                     \
	P(FORCE_PC_DAMPING, 26, "force.pc_damping", pc_damping_uN_per_mm_s, uint32_t, CORE, 0, 1000000, 50000,         \
	  "0.001", "N*s/m", RW, ANY,                                                                                   \
	  "the passivity controller's damping at most (raw uN per mm/s): a larger one, reaching the device "           \
	  "the link's delay late, feeds the motion it answers (docs/energy.md)")                                       \
	P(SILENT_TICKS, 30, "link.silent_ticks", silent_ticks, uint16_t, CORE, 1, 10000, 2, "1", "ticks", RW, ANY,     \
	  "device silent this many ticks (effect mode: at least two update periods): zero force and FAULT")            \
	P(AUTORUN, 31, "ctl.autorun", autorun, uint8_t, CORE, 0, 1, 0, "1", "", RW, ANY,                               \
	  "1: ARMED goes to RUNNING by itself (unless the host sent STOP) and FAULT recovers by itself")               \
	P(FRAME_X0, 50, "frame.x0", xform.offset_um[0], int32_t, FRAME, -2000000, 2000000, 200000, "0.001", "mm", RW,  \
	  IDLE, "pool x of the device's origin (docs/frame.md: pool = offset + flip x scale x device[axes])")          \
	P(FRAME_Y0, 51, "frame.y0", xform.offset_um[1], int32_t, FRAME, -2000000, 2000000, 200000, "0.001", "mm", RW,  \
	  IDLE, "pool y of the device's origin")                                                                       \
	P(FRAME_Z0, 52, "frame.z0", xform.offset_um[2], int32_t, FRAME, -2000000, 2000000, 0, "0.001", "mm", RW, IDLE, \
	  "pool z of the device's origin (pool z 0: the water's rest level)")                                          \
	P(FRAME_SCALE, 53, "frame.scale", xform.scale, int32_t, FRAME, 6554, 1048576, 65536, SWELL_PARAM_Q16, "", RW,  \
	  IDLE, "pool mm per device mm, Q15.16, 0.1 to 16 (forces go back unscaled); effect mode: 1")                  \
	P(FRAME_AXES, 54, "frame.axes", frame_axes, uint16_t, FRAME, 123, 321, 123, "1", "", RW, IDLE,                 \
	  "the device axes (1 x, 2 y, 3 z) that give pool x, y and z, three digits: 123 as they are, 213 x and y "     \
	  "swapped; effect mode: z stays 3")                                                                           \
	P(FRAME_FLIP, 55, "frame.flip", frame_flip, uint8_t, FRAME, 0, 7, 0, "1", "", RW, IDLE,                        \
	  "pool axes that run against their device axis: 1 x, 2 y, 4 z, summed; effect mode: not 4")                   \
	P(HM_INERTIA, 56, "hm.inertia", hm_inertia_g, uint32_t, CORE, 0, 100000, 2000, "0.001", "kg", RW, IDLE,        \
	  "the inertia a HapticMaster is set to at start-up (hm: links: set inertia), the force law's damper is "      \
	  "tuned for 2 kg; 0: left as the device has it")                                                              \
	P(DEV_STATUS, 60, "dev.status", dev_status, uint8_t, CORE, 0, 255, 0, "1", "", RO, ANY,                        \
	  "the device's last status: 1 powered, 2 force on, 4 e-stop (or not rendering), 8 fault, summed")             \
	P(DEV_RATE, 61, "dev.rate", dev_rate_hz, uint16_t, CORE, 0, 65535, 0, "1", "Hz", RO, ANY,                      \
	  "device samples heard in the last whole second")                                                             \
	P(CTL_TICK_HZ, 62, "ctl.tick_hz", cfg.tick_hz, uint32_t, CORE, 0, 100000, 2500, "1", "Hz", RO, ANY,            \
	  "the controller's tick rate")                                                                                \
	P(DEV_X, 63, "dev.x", pos_um[0], int32_t, CORE, -300000, 300000, 0, "0.001", "mm", RO, ANY,                    \
	  "the device's last position x, in its own frame (frame.* map it into the pool)")                             \
	P(DEV_Y, 64, "dev.y", pos_um[1], int32_t, CORE, -300000, 300000, 0, "0.001", "mm", RO, ANY,                    \
	  "the device's last position y, in its own frame")                                                            \
	P(DEV_Z, 65, "dev.z", pos_um[2], int32_t, CORE, -300000, 300000, 0, "0.001", "mm", RO, ANY,                    \
	  "the device's last position z, in its own frame")
#define SWELL_PARAM_COMMAND_ID 40
#define SWELL_PARAM_COMMAND_NAME "ctl.command"

#define SWELL_COMMANDS(C)                                                                        \
	C(STOP, 0, "stop", "force law off: RUNNING -> ARMED; holds with autorun too, until RUN") \
	C(RUN, 1, "run", "ARMED -> RUNNING when the device is powered and its e-stop released")  \
	C(CLEAR, 2, "clear", "FAULT -> IDLE once the device is heard again; refused (state) elsewhere")

enum swell_param_id {
#define SWELL_X(NAME, id, name, member, ctype, group, min, max, def, factor, unit, access, when, desc) \
	SWELL_PARAM_##NAME = id,
	SWELL_PARAMS(SWELL_X)
#undef SWELL_X
	SWELL_PARAM_COMMAND = SWELL_PARAM_COMMAND_ID, /* enum swell_ctl_command, write only */
};

/* Raw values of the reference scene, SWELL_PARAM_DEF_<NAME>. */
enum swell_param_default {
#define SWELL_X(NAME, id, name, member, ctype, group, min, max, def, factor, unit, access, when, desc) \
	SWELL_PARAM_DEF_##NAME = def,
	SWELL_PARAMS(SWELL_X)
#undef SWELL_X
};

/* Commands, written to parameter SWELL_PARAM_COMMAND. */
enum swell_ctl_command {
#define SWELL_X(NAME, value, name, desc) SWELL_CMD_##NAME = value,
	SWELL_COMMANDS(SWELL_X)
#undef SWELL_X
};

#endif
