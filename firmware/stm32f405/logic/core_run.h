/* The controller core (firmware/core) on the reference scene with a scripted device, the same on
 * the image and the host: the device reports a position every tick (powered, force enabled),
 * starting 20 mm above the pool centre and sinking at 50 mm/s to 25 mm below the rest level, then
 * holding. autorun takes the core to RUNNING, so the force law, the safety stage, the solver
 * slices and the telemetry all run. The run's checksum covers every FORCE_CMD payload sent to the
 * device and the final water state, so host and target must agree bit for bit. */
#ifndef SWELL_FW_CORE_RUN_H
#define SWELL_FW_CORE_RUN_H

#include <stddef.h>
#include <stdint.h>

#include "swell/ctl.h"
#include "swell/pool.h"

/* Arena words for the 64 x 64 reference scene (checked against swell_ctl_arena_words at init): the
 * field, the sent samples and the telemetry's stale-quad bits (16 a tile). */
#define FW_CORE_ARENA_WORDS                                                                     \
	(SWELL_WAVE_WORDS(SWELL_POOL_N, SWELL_POOL_N) + (SWELL_POOL_N * SWELL_POOL_N + 1) / 2 + \
	 (SWELL_WAVE_TILES(SWELL_POOL_N, SWELL_POOL_N) + 1) / 2)

struct fw_core_run {
	uint32_t tick; /* ticks run so far */
	uint32_t crc; /* running CRC-32 of the FORCE_CMD payloads */
	uint32_t force_cmds, host_msgs;
	int32_t last_fz_uN; /* last commanded vertical force */
	uint8_t seq;
};

enum swell_err fw_core_init(struct swell_ctl *c, struct fw_core_run *r, int32_t *arena, size_t words, uint32_t tick_hz);
/* Feed the scripted device sample for this tick (call before swell_ctl_tick). */
void fw_core_device(struct swell_ctl *c, struct fw_core_run *r);
/* Drain both output queues after the tick (FORCE_CMDs into the CRC). */
void fw_core_drain(struct swell_ctl *c, struct fw_core_run *r);
/* CRC of the run: the FORCE_CMD CRC continued with the water state checksum. */
uint32_t fw_core_checksum(const struct swell_ctl *c, const struct fw_core_run *r);

#endif
