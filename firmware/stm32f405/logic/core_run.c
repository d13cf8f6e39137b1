#include "core_run.h"

#include "swell/crc.h"

enum swell_err fw_core_init(struct swell_ctl *c, struct fw_core_run *r, int32_t *arena, size_t words, uint32_t tick_hz)
{
	struct swell_ctl_config cfg;

	swell_ctl_default_config(&cfg);
	cfg.tick_hz = tick_hz;
	cfg.safety.tick_hz = tick_hz;
	cfg.autorun = 1;
	cfg.passivity = 1; /* the force path measured with the energy account's controller on */
	*r = (struct fw_core_run){ 0 };
	return swell_ctl_init(c, &cfg, arena, words);
}

void fw_core_device(struct swell_ctl *c, struct fw_core_run *r)
{
	struct swell_msg m = { .type = SWELL_MSG_DEVICE_POS, .node = c->cfg.node };
	/* 20 mm down to -25 mm at 50 mm/s, in 10 um units */
	int64_t z = 2000 - (int64_t)r->tick * 5000 / c->cfg.tick_hz;

	m.u.device_pos.z_10um = (int16_t)(z < -2500 ? -2500 : z);
	m.u.device_pos.seq = r->seq;
	m.u.device_pos.status = SWELL_DEV_POWERED | SWELL_DEV_FORCE_ON;
	swell_ctl_rx(c, SWELL_LINK_DEVICE, &m);
	/* and its velocity (0.1 mm/s), which the damper and the passivity controller read: in the water
	 * with the wrong sign, so that the damper pushes along the motion, the energy account sees energy
	 * created and the passivity controller acts on every tick from then on (its cost is in the force
	 * path's figure) */
	m = (struct swell_msg){ .type = SWELL_MSG_DEVICE_VEL, .node = c->cfg.node };
	m.u.device_vel.vz_100ums = (int16_t)(z > 0 ? -500 : z > -2500 ? 500 : 0);
	m.u.device_vel.seq = r->seq++;
	swell_ctl_rx(c, SWELL_LINK_DEVICE, &m);
	r->tick++;
}

void fw_core_drain(struct swell_ctl *c, struct fw_core_run *r)
{
	struct swell_msg out[8];
	uint8_t payload[SWELL_CAN_LEN];
	size_t n, i;

	while ((n = swell_ctl_tx(c, SWELL_LINK_DEVICE, out, 8)) > 0) {
		for (i = 0; i < n; i++) {
			if (out[i].type != SWELL_MSG_FORCE_CMD)
				continue;
			if (swell_payload_encode(&out[i], payload, sizeof(payload)) == SWELL_OK) {
				const struct swell_msg_desc *d = swell_msg_desc_find(out[i].type);

				r->crc = swell_crc32(r->crc, payload, d ? d->len : 0);
			}
			r->force_cmds++;
		}
	}
	while ((n = swell_ctl_tx(c, SWELL_LINK_HOST, out, 8)) > 0)
		r->host_msgs += (uint32_t)n;
	r->last_fz_uN = c->force_dev_uN[2];
}

uint32_t fw_core_checksum(const struct swell_ctl *c, const struct fw_core_run *r)
{
	uint32_t w = swell_wave_checksum(&c->wave);
	uint8_t b[4] = { (uint8_t)w, (uint8_t)(w >> 8), (uint8_t)(w >> 16), (uint8_t)(w >> 24) };

	return swell_crc32(r->crc, b, 4);
}
