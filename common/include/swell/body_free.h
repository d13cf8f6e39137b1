/* Host only: a free rigid body moving vertically under the force law, for swell-sim and the tests
 * (stands in for the device until the HapticMaster model exists). Doubles; never on the controller.
 * m a = F (F includes gravity), semi-implicit Euler at the device tick. Positions in um, velocities
 * in um/s, force in uN, mass in g: a [um/s^2] = F [uN] * 1000 / m [g]. */
#ifndef SWELL_BODY_FREE_H
#define SWELL_BODY_FREE_H

#include <stdint.h>

struct swell_free_body {
	double z_um, v_um_s;
	double mass_g;
	double dt_s;
};

void swell_free_body_init(struct swell_free_body *fb, double z_um, double mass_g, uint32_t tick_hz);

/* Advance one tick under force f_uN. */
void swell_free_body_step(struct swell_free_body *fb, int32_t f_uN);

/* The device position and velocity to hand to swell_body_tick (identity axes: z is axis 2). */
void swell_free_body_pose(const struct swell_free_body *fb, int32_t x_um, int32_t y_um, int32_t pos_um[3],
			  int32_t vel_um_s[3]);

#endif
