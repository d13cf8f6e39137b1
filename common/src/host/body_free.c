/* Free vertical body for host simulations; see body_free.h. */
#include "swell/body_free.h"

#include <math.h>

void swell_free_body_init(struct swell_free_body *fb, double z_um, double mass_g, uint32_t tick_hz)
{
	fb->z_um = z_um;
	fb->v_um_s = 0;
	fb->mass_g = mass_g;
	fb->dt_s = 1.0 / tick_hz;
}

void swell_free_body_step(struct swell_free_body *fb, int32_t f_uN)
{
	fb->v_um_s += (double)f_uN * 1000.0 / fb->mass_g * fb->dt_s;
	fb->z_um += fb->v_um_s * fb->dt_s;
}

static int32_t to_i32(double x)
{
	if (!(x < 2147483647.0))
		return INT32_MAX;
	if (!(x > -2147483647.0))
		return -INT32_MAX;
	return (int32_t)lround(x);
}

void swell_free_body_pose(const struct swell_free_body *fb, int32_t x_um, int32_t y_um, int32_t pos_um[3],
			  int32_t vel_um_s[3])
{
	pos_um[0] = x_um;
	pos_um[1] = y_um;
	pos_um[2] = to_i32(fb->z_um);
	vel_um_s[0] = vel_um_s[1] = 0;
	vel_um_s[2] = to_i32(fb->v_um_s);
}
