/* The reference scene "pool" (docs/design.md, section 4), written once: a 64 x 64 grid of 6.25 mm
 * cells (400 mm a side), 50 mm deep, the solver at 250 Hz under a 2500 Hz device tick, and a 50 mm
 * cube as the default body. The controller's default configuration, the viewer's generator and
 * defaults, and the firmware's self-test scene all start from these. */
#ifndef SWELL_POOL_H
#define SWELL_POOL_H

#define SWELL_POOL_N 64 /* cells a side */
#define SWELL_POOL_DX_UM 6250
#define SWELL_POOL_DEPTH_UM 50000
#define SWELL_POOL_SIDE_UM (SWELL_POOL_N * SWELL_POOL_DX_UM)
#define SWELL_POOL_BOX_UM 50000 /* the default body's edge */
#define SWELL_POOL_TICK_HZ 2500
#define SWELL_POOL_SOLVER_HZ 250

/* Limits of a controller configuration (swell_ctl_check). */
#define SWELL_TICK_HZ_MIN 10
#define SWELL_TICK_HZ_MAX 100000
#define SWELL_GRID_MAX 256 /* cells a side: the wire's tile addresses */

#endif
