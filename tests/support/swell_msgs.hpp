// The messages the tests build, every field not named 0 (node 0): a parameter request, a device
// sample. A UDP end that speaks them: swell_msg_udp.hpp.
#ifndef SWELL_TEST_MSGS_HPP
#define SWELL_TEST_MSGS_HPP

#include <cstdint>

extern "C" {
#include "swell/proto.h"
}

namespace swell_test {

// SWELL_MSG_PARAM_SET of value, or SWELL_MSG_PARAM_GET (value unused), of parameter id.
inline swell_msg param_msg(uint8_t type, uint16_t id, int32_t value, uint8_t seq)
{
	swell_msg m{};
	m.type = type;
	if (type == SWELL_MSG_PARAM_SET) {
		m.u.param_set.id = id;
		m.u.param_set.value = value;
		m.u.param_set.seq = seq;
	} else {
		m.u.param_get.id = id;
		m.u.param_get.seq = seq;
	}
	return m;
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

} // namespace swell_test

#endif
