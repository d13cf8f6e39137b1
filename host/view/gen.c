/* Known-scene packet generator, see gen.h. Host-only (uses libm for the bump). */
#include "gen.h"

#include <math.h>
#include <string.h>

#include "swell/pool.h"
#include "swell/proto.h"

void gen_default(struct gen_scene *s)
{
	memset(s, 0, sizeof(*s));
	s->nx = SWELL_POOL_N;
	s->ny = SWELL_POOL_N;
	s->dx_um = SWELL_POOL_DX_UM;
	s->depth_10um = SWELL_POOL_DEPTH_UM / 10;
	s->scene_id = 1;
	s->bump_x_um = (int32_t)(0.70 * SWELL_POOL_SIDE_UM);
	s->bump_y_um = (int32_t)(0.50 * SWELL_POOL_SIDE_UM);
	s->bump_sigma_um = 25000;
	s->bump_amp_um = 3000;
	s->obj_x_10um = (int16_t)(0.30 * SWELL_POOL_SIDE_UM / 10);
	s->obj_y_10um = (int16_t)(0.35 * SWELL_POOL_SIDE_UM / 10);
	s->obj_z_10um = -1000;
	s->submersion_halfpct = 50;
	s->fx_cN = 150;
	s->fy_cN = -100;
	s->fz_cN = 80;
	s->state = SWELL_CTL_RUNNING;
}

void gen_mirror(struct gen_scene *s)
{
	s->bump_x_um = (int32_t)(0.30 * SWELL_POOL_SIDE_UM);
	s->bump_y_um = (int32_t)(0.40 * SWELL_POOL_SIDE_UM);
	s->obj_x_10um = (int16_t)(0.72 * SWELL_POOL_SIDE_UM / 10);
	s->obj_y_10um = (int16_t)(0.70 * SWELL_POOL_SIDE_UM / 10);
	s->fx_cN = -120;
	s->fy_cN = 160;
	s->scene_id = 2;
}

void gen_ripple(struct gen_scene *s)
{
	s->bump_amp_um = 2000;
	s->ripple_amp_um = 1200;
	s->ripple_len_um = 60000;
	s->ripple_speed_um_s = 120000;
}

void gen_bob(struct gen_scene *s)
{
	s->bob_period_us = 2000000;
	s->bob_z_10um = 600;
	s->bob_fz_cN = 100;
}

void gen_wake(struct gen_scene *s)
{
	gen_still(s);
	s->wake_amp_um = 1200;
	s->wake_len_um = 40000;
	s->wake_speed_um_s = 100000;
}

void gen_still(struct gen_scene *s)
{
	gen_bob(s);
	s->bump_amp_um = 0;
	s->bump_sigma_um = 0;
}

void gen_cells(struct gen_scene *s, uint16_t n)
{
	s->nx = n;
	s->ny = n;
	s->dx_um = (uint16_t)(SWELL_POOL_SIDE_UM / n);
}

/* The pose and force of the scene at time t_us (the bob moves them). */
static void gen_object_at(const struct gen_scene *s, uint64_t t_us, int16_t *z_10um, uint8_t *submersion_halfpct,
			  int16_t *fz_cN)
{
	*z_10um = s->obj_z_10um;
	*submersion_halfpct = s->submersion_halfpct;
	*fz_cN = s->fz_cN;
	if (s->bob_period_us == 0)
		return;
	double ph = sin(2 * 3.14159265358979 * (double)(t_us % s->bob_period_us) / s->bob_period_us);
	*z_10um = (int16_t)lround(s->obj_z_10um + s->bob_z_10um * ph);
	/* submerged: -z of the 50 mm box, in half percent */
	double sub = -(double)*z_10um / (SWELL_POOL_BOX_UM / 10.0) * 200.0;
	*submersion_halfpct = (uint8_t)lround(sub < 0 ? 0 : sub > 200 ? 200 : sub);
	*fz_cN = (int16_t)lround(s->fz_cN + s->bob_fz_cN * ph);
}

void gen_energy_at(const struct gen_scene *s, uint64_t t_us, uint32_t *created_uJ, int32_t *balance_10uJ)
{
	double ph = s->bob_period_us ? sin(2 * 3.14159265358979 * (double)(t_us % s->bob_period_us) / s->bob_period_us)
				     : 0.0;
	*created_uJ = (uint32_t)(t_us / 2000u); /* 0.5 mJ a second */
	*balance_10uJ = (int32_t)lround(200.0 * ph); /* +-2 mJ */
}

void gen_info(struct gen_scene *s)
{
	gen_default(s);
	s->info = true;
	memcpy(s->fw_version, (const uint8_t[3]){ 2, 7, 1 }, sizeof(s->fw_version));
	memcpy(s->obj_100um, (const uint16_t[3]){ 1000, 600, 400 }, sizeof(s->obj_100um));
}

/* Height of cell (i, j) at time t_us in wire units (LSB 2^-6 mm, saturated to int12). */
static int16_t gen_height(const struct gen_scene *s, uint16_t i, uint16_t j, uint64_t t_us)
{
	double x = ((double)i + 0.5) * s->dx_um, y = ((double)j + 0.5) * s->dx_um;
	double h_um = 0;
	if (s->bump_sigma_um > 0) {
		double rx = x - s->bump_x_um, ry = y - s->bump_y_um, sg = s->bump_sigma_um;
		h_um += s->bump_amp_um * exp(-(rx * rx + ry * ry) / (2 * sg * sg));
	}
	if (s->ripple_amp_um && s->ripple_len_um > 0) {
		/* circular ripple from the pool's corner, fading with distance */
		double r = sqrt(x * x + y * y), t = (double)t_us * 1e-6;
		double ph = 2 * 3.14159265358979 * (r - s->ripple_speed_um_s * t) / s->ripple_len_um;
		h_um += s->ripple_amp_um * cos(ph) * exp(-r / (4.0 * s->ripple_len_um));
	}
	if (s->wake_amp_um && s->wake_len_um > 0) {
		/* rings from the footprint's edge (the distance to the box's outline), fading outwards */
		double half = SWELL_POOL_BOX_UM / 2.0, t = (double)t_us * 1e-6;
		double ex = fmax(fabs(x - s->obj_x_10um * 10.0) - half, 0.0);
		double ey = fmax(fabs(y - s->obj_y_10um * 10.0) - half, 0.0);
		double r = sqrt(ex * ex + ey * ey);
		double ph = 2 * 3.14159265358979 * (r - s->wake_speed_um_s * t) / s->wake_len_um;
		h_um += s->wake_amp_um * cos(ph) * exp(-r / (2.0 * s->wake_len_um));
	}
	/* to the solver's units (2^-16 mm, saturated to what int32 holds), then the wire's codec */
	double h16 = h_um * 65.536;
	h16 = h16 > 2147483647.0 ? 2147483647.0 : h16 < -2147483648.0 ? -2147483648.0 : h16;
	return swell_height_to_sample((int32_t)lround(h16));
}

struct packer {
	struct swell_msg m[SWELL_PKT_MSGS_MAX];
	size_t n;
	uint8_t *seq;
	gen_emit_fn emit;
	void *ctx;
	unsigned packets;
	enum swell_err err;
};

static void flush(struct packer *p)
{
	size_t at = 0;
	while (at < p->n && p->err == SWELL_OK) {
		uint8_t pkt[SWELL_PKT_MAX];
		size_t len = 0, used = 0;
		p->err = swell_pkt_encode(0, *p->seq, p->m + at, p->n - at, pkt, sizeof(pkt), &len, &used);
		if (p->err != SWELL_OK)
			break;
		p->emit(p->ctx, pkt, len);
		(*p->seq)++;
		p->packets++;
		at += used;
	}
	p->n = 0;
}

static void put(struct packer *p, const struct swell_msg *m)
{
	if (p->n == SWELL_PKT_MSGS_MAX)
		flush(p);
	p->m[p->n++] = *m;
}

unsigned gen_frame(const struct gen_scene *s, uint64_t t_us, uint8_t frame, bool heartbeat, uint8_t hb_seq, bool scene,
		   bool tiles, uint8_t *seq, gen_emit_fn emit, void *ctx, enum swell_err *err)
{
	struct packer p = { .seq = seq, .emit = emit, .ctx = ctx, .err = SWELL_OK };
	struct swell_msg m;

	if (heartbeat)
		put(&p,
		    &(struct swell_msg){
			    .type = SWELL_MSG_HEARTBEAT,
			    .u.heartbeat = { .state = s->state, .version = SWELL_PROTO_VERSION, .seq = hb_seq } });
	if (heartbeat && s->bob_period_us) { /* the bob's energy account: created grows, D swings */
		uint32_t created_uJ;
		int32_t balance_10uJ;
		gen_energy_at(s, t_us, &created_uJ, &balance_10uJ);
		put(&p,
		    &(struct swell_msg){ .type = SWELL_MSG_ENERGY,
					 .u.energy = { .created_uJ = created_uJ, .balance_10uJ = balance_10uJ } });
	}
	if (scene)
		put(&p,
		    &(struct swell_msg){ .type = SWELL_MSG_SCENE,
					 .u.scene = { .nx = s->nx,
						      .ny = s->ny,
						      .h_shift = SWELL_PROTO_H_SHIFT,
						      .dx_um = s->dx_um,
						      .depth_10um = s->depth_10um,
						      .scene_id = s->scene_id } });
	if (scene && s->info)
		put(&p,
		    &(struct swell_msg){ .type = SWELL_MSG_CTL_INFO,
					 .u.ctl_info = { .fw_major = s->fw_version[0],
							 .fw_minor = s->fw_version[1],
							 .fw_patch = s->fw_version[2],
							 .obj_a_100um = s->obj_100um[0],
							 .obj_b_100um = s->obj_100um[1],
							 .obj_h_100um = s->obj_100um[2] } });
	if (tiles) {
		const unsigned tiles_x = SWELL_TILES(s->nx),
			       quads = tiles_x * SWELL_TILES(s->ny) * SWELL_QUADS_PER_TILE;
		for (unsigned q = 0; q < quads; q++) {
			const struct swell_quad_at at = swell_quad_locate(q, tiles_x);
			int16_t v[4] = { 0, 0, 0, 0 };
			for (unsigned k = 0; k < 4; k++)
				if (at.x0 + k < s->nx && at.y < s->ny)
					v[k] = gen_height(s, (uint16_t)(at.x0 + k), (uint16_t)at.y, t_us);
			m = swell_height_quad(&at, frame, v);
			put(&p, &m);
		}
	}
	int16_t z_10um, fz_cN;
	uint8_t sub;
	gen_object_at(s, t_us, &z_10um, &sub, &fz_cN);
	put(&p,
	    &(struct swell_msg){ .type = SWELL_MSG_OBJECT_POSE,
				 .u.object_pose = { .x_10um = s->obj_x_10um,
						    .y_10um = s->obj_y_10um,
						    .z_10um = z_10um,
						    .submersion_halfpct = sub,
						    .seq = frame } });
	put(&p,
	    &(struct swell_msg){
		    .type = SWELL_MSG_OBJECT_FORCE,
		    .u.object_force = { .fx_cN = s->fx_cN, .fy_cN = s->fy_cN, .fz_cN = fz_cN, .seq = frame } });
	flush(&p);
	if (err)
		*err = p.err;
	return p.err == SWELL_OK ? p.packets : 0;
}
