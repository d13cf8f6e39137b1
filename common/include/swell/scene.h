/* Scene files (*.scene): a whole configuration of the controller in plain text, read by swell-ctl at
 * start (--scene), sent to a running controller by swell-tool (scene load) and read by swell-hm for
 * the equilibrium it expects. Host only (values with units are parsed with double).
 *
 * One "name = value [unit]" a line; '#' starts a comment; blank lines are ignored. Names are the
 * parameter table's (swell/param_table.h: body.mass = 80 g, wave.damping = 0.002) and the start-up
 * parameters below, which swell-ctl --scene sets (the pool's memory is laid out at start; the
 * STM32F405 image takes the pool's four as PARAM_SET outside RUNNING and restarts its core with
 * them, firmware/core/include/swell/ctl_pool.h):
 *   pool.nx, pool.ny   grid size in cells, 2 .. 256
 *   pool.dx            cell size, 0.1 .. 65.535 mm
 *   pool.depth         rest depth, 0.01 .. 655.35 mm
 *   solver.hz          solver rate in Hz (divides the tick rate, 2 .. 256 ticks a step)
 * When the pool or the solver rate is given and wave.e is not, wave.e follows eq. 2 from them.
 * A name given twice, an unknown name, a value that does not parse or is out of range: the whole
 * file is refused, and the reason names the line ("pool.scene:7: body.mass: unit 'mm' is not g"). */
#ifndef SWELL_SCENE_H
#define SWELL_SCENE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "swell/param.h"

#define SWELL_SCENE_PARAMS_MAX 32

/* Start-up parameters: ids above the parameter table's (the core does not know them). */
enum swell_scene_key {
	SWELL_SCENE_NX = 0x8001,
	SWELL_SCENE_NY,
	SWELL_SCENE_DX_UM,
	SWELL_SCENE_DEPTH_UM,
	SWELL_SCENE_SOLVER_HZ,
};

struct swell_scene_value {
	const struct swell_param_desc *d; /* a table row or a start-up parameter */
	int32_t raw;
	int line; /* where it was given (0: not from a file) */
};

struct swell_scene {
	struct swell_scene_value v[SWELL_SCENE_PARAMS_MAX];
	size_t n;
};

/* Parse a scene file. 0 on success; -1 with "FILE:LINE: reason" (or "FILE: reason") in err and *sc
 * untouched. */
int swell_scene_load(const char *path, struct swell_scene *sc, char *err, size_t errlen);

/* The value given for id (a parameter id or enum swell_scene_key), or NULL. */
const struct swell_scene_value *swell_scene_get(const struct swell_scene *sc, uint16_t id);

/* Add or replace a value (raw, checked against its range). 0, or -1 when the scene is full or the
 * value is out of range. */
int swell_scene_put(struct swell_scene *sc, uint16_t id, int32_t raw);

/* Write sc in the file format, with a header comment (may be NULL), every value in its unit. */
int swell_scene_write(FILE *f, const struct swell_scene *sc, const char *header);

/* The descriptor of a start-up parameter (NULL for a table id). */
const struct swell_param_desc *swell_scene_key(uint16_t id);

/* The descriptor named name: a start-up parameter or a table row; NULL for none. */
const struct swell_param_desc *swell_scene_desc_by_name(const char *name);

#endif
