/* Effect mode: the paper's own rendering. Instead of a force every device tick, the controller sends
 * the device, at each update, the parameters of the effects the HapticMaster renders itself at its
 * own rate: the pulling spring (origin at the water surface w under the object), the pushing spring
 * (origin H lower), both with stiffness k = rho g a b, no deadband and direction up; the damper
 * b_max s; a constant force, the gravity -m g; the water's vertical velocity u_w as the effects' vel;
 * and the force and rate limits the device applies to their sum (docs/force-law.md, "Effect mode").
 *
 * struct swell_effect holds a set in wire units (EFFECT_SPRING, EFFECT_DAMPER, EFFECT_LIMIT). The
 * controller makes it from the force law's output (swell_effect_from_body); the device evaluates it
 * every tick (swell_effect_force_uN) at its own position and velocity. Integers only:
 *   springs  k (0.01 N/m) x clamp(surface - z, 0, H) (0.01 mm) = 0.1 uN exactly, rounded to nearest uN
 *   damper   -b (0.01 N s/m) x (v - u_w) (0.1 mm/s) = uN exactly
 *   gravity  bias (mN) x 1000 uN
 * The sum saturates to int32. The device side limits it further (swell/force_safety.h). */
#ifndef SWELL_EFFECT_H
#define SWELL_EFFECT_H

#include <stdint.h>

#include "swell/body.h"
#include "swell/proto.h"

struct swell_effect {
	int32_t surface_10um; /* device z of the pulling spring's origin */
	int32_t h_10um; /* the pushing spring's origin is H lower, H > 0 */
	int32_t uw_100ums; /* effects' vel: the water's vertical velocity */
	uint32_t k_10mN_m; /* each spring's stiffness */
	uint32_t b_10mNs_m; /* damper coefficient b_max s */
	int32_t bias_mN; /* constant force along z: gravity */
	uint32_t fmax_cN; /* |F| limit, >= 1 */
	uint32_t rate_100mN_s; /* |dF/dt| limit, >= 1 */
	uint8_t seq;
};

/* The set for the force law's state at this tick: the surface, u_w and submersion of out, the
 * stiffness, H and mass of the body, the limits f_max_uN and rate_uN_per_s. The device's z is the
 * pool's z less offset_z_um (effect mode needs the pool's z to be the device's z, scale 1, sign +1;
 * swell_ctl_check refuses anything else). Every field rounded to nearest and saturated to its wire
 * range. */
void swell_effect_from_body(struct swell_effect *e, const struct swell_body *b, const struct swell_body_out *out,
			    int32_t offset_z_um, uint32_t f_max_uN, uint32_t rate_uN_per_s);

/* The force along device z the set produces at z (0.01 mm) and v (0.1 mm/s), in uN: the two springs'
 * net k clamp(surface - z, 0, H), the damper -b (v - u_w) and the bias, unlimited (saturated to
 * int32). */
int32_t swell_effect_force_uN(const struct swell_effect *e, int32_t z_10um, int32_t vz_100ums);

/* The set as its three messages (node given), all with e->seq. */
void swell_effect_encode(const struct swell_effect *e, uint8_t node, struct swell_msg m[3]);

/* The device's receiver: the parts of the set being collected. */
struct swell_effect_rx {
	struct swell_effect pend;
	unsigned mask; /* parts of pend.seq received: 1 spring, 2 damper, 4 limit */
};

/* One message from the controller: -1 not an effect message; 0 taken, the set not complete; 1 the
 * three parts of one seq are in, copied to *set. A part of another seq starts a new set (the parts
 * of the old one are dropped: a set is never mixed from two updates). */
int swell_effect_recv(struct swell_effect_rx *r, const struct swell_msg *m, struct swell_effect *set);

#endif
