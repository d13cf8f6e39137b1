// The messages the tests build, every field not named 0 (node 0): a parameter request, a device
// sample, a CAN error frame; a HEIGHT_QUAD into a grid. A UDP end that speaks them: swell_msg_udp.hpp.
#ifndef SWELL_TEST_MSGS_HPP
#define SWELL_TEST_MSGS_HPP

#include <cstdint>

#include <linux/can.h>
#include <linux/can/error.h>

extern "C" {
#include "swell/proto.h"
}

namespace swell_test {

// SWELL_MSG_PARAM_SET of value, or SWELL_MSG_PARAM_GET (value unused), of parameter id.
inline swell_msg param_msg(uint8_t type, uint16_t id, int32_t value, uint8_t seq)
{
	return swell_param_request(0, type == SWELL_MSG_PARAM_SET, id, value, seq);
}

// A DEVICE_POS at z (x, y) in units of 10 um; status 1: powered.
inline swell_msg device_pos_msg(uint8_t seq, int16_t z_10um, uint8_t status = 1, int16_t x_10um = 0,
				int16_t y_10um = 0)
{
	swell_msg m{};
	m.type = SWELL_MSG_DEVICE_POS;
	m.u.device_pos.x_10um = x_10um;
	m.u.device_pos.y_10um = y_10um;
	m.u.device_pos.z_10um = z_10um;
	m.u.device_pos.seq = seq;
	m.u.device_pos.status = status;
	return m;
}

// A SocketCAN error frame as the driver sends it: classes (CAN_ERR_*), the controller's status byte
// and the transmit and receive error counters.
inline can_frame err_frame(uint32_t classes, uint8_t crtl = 0, uint8_t txerr = 0, uint8_t rxerr = 0)
{
	can_frame f{};
	f.can_id = CAN_ERR_FLAG | classes;
	f.can_dlc = CAN_ERR_DLC;
	f.data[1] = crtl;
	f.data[6] = txerr;
	f.data[7] = rxerr;
	return f;
}

// Stores the cells of a HEIGHT_QUAD that lie inside an nx x ny row-major grid h (solver units), as a
// viewer places them.
inline void quad_to_grid(const swell_msg_height_quad &q, int32_t *h, unsigned nx, unsigned ny)
{
	int32_t v[4];
	const unsigned j = q.tile_y * SWELL_PROTO_TILE + q.row, i0 = q.tile_x * SWELL_PROTO_TILE + 4u * q.half;
	swell_height_quad_heights(&q, v);
	for (unsigned k = 0; k < 4; k++)
		if (j < ny && i0 + k < nx)
			h[(size_t)j * nx + i0 + k] = v[k];
}

} // namespace swell_test

#endif
