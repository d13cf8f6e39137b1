/* The pool (grid, cell size, depth) as a start-up choice of a port, within its memory: an arena and,
 * on the STM32F405, a fast block only the CPU reaches (swell-ctl: the arena it allocates before its
 * loop, --pool-max). The core's buffers go whole into the arena when they fit, else with the solver's
 * momentum u in the fast block; a pool that fits neither way is refused with SWELL_ESIZE and nothing
 * changes. PARAM_SET and PARAM_GET of the start-up parameters (pool.nx, pool.ny, pool.dx, pool.depth,
 * swell/scene.h) on the host link, their answers and the restart: docs/stm32f405.md. Pure logic,
 * tested on the host. */
#ifndef SWELL_CTL_POOL_H
#define SWELL_CTL_POOL_H

#include <stddef.h>
#include <stdint.h>

#include "swell/ctl.h"

struct fw_mem {
	int32_t *sram;
	size_t sram_words;
	int32_t *fast; /* NULL when the port has none */
	size_t fast_words;
	const char *fast_name; /* where the fast block is, for the boot report */
};

struct fw_pool_at {
	int apart; /* u and the sent samples in the fast block */
	size_t sram_words, fast_words; /* used in each block */
};

/* Where an nx x ny pool's buffers go in m; SWELL_ESIZE when it does not fit. */
enum swell_err fw_pool_place(uint16_t nx, uint16_t ny, const struct fw_mem *m, struct fw_pool_at *p);

/* Start the core with cfg in m (swell_ctl_init or swell_ctl_init_apart by fw_pool_place). On error
 * *c and *p are untouched. */
enum swell_err fw_pool_start(struct swell_ctl *c, const struct swell_ctl_config *cfg, const struct fw_mem *m,
			     struct fw_pool_at *p);

/* 1 for a PARAM_SET or PARAM_GET of a start-up parameter (fw_pool_param's, not the core's). */
int fw_pool_is_startup(const struct swell_msg *m);

/* A host message for the port: 1 when it is a PARAM_SET or PARAM_GET of a start-up parameter, with
 * its answer (PARAM_ACK or PARAM_NACK) in *answer, the core restarted on an accepted change and *p
 * updated; 0 for any other message (the core's own). */
int fw_pool_param(struct swell_ctl *c, const struct fw_mem *m, const struct swell_msg *in, struct swell_msg *answer,
		  struct fw_pool_at *p);

#endif
