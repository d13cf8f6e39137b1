/* The Cortex-M4's costs of a solver step's parts (swell/ctl_port.h), in instructions measured on the
 * image (damped and undamped, every tile awake): a cell of a kernel row with its row driver and the
 * height update one row behind about 32, the body's ceiling scan of a cell while the object is out of
 * the water about 7 (LDM groups of eight), the step's end (the last row's heights, the two fixers of up
 * to 64 cells each, the tile flags, the period's coupling) about 12 k. The Linux process and the host
 * programs link the same table: they spread a step over its ticks as the image does. */
#include "swell/ctl_port.h"

const struct swell_ctl_costs swell_ctl_port_costs = { .cell = 32u, .scan_cell = 7u, .end = 12000u };
