/* The parameter table (swell/param_table.h) against the core that serves it: defaults, ranges, the
 * state rule, read-back, and the lookup that tools use. */
#include <catch2/catch.hpp>

#include "swell_msgs.hpp"

#include <cstring>
#include <set>
#include <string>
#include <vector>

extern "C" {
#include "swell/ctl.h"
#include "swell/param.h"
}

namespace {

struct Core {
	std::vector<int32_t> arena;
	swell_ctl c{};
	uint8_t seq = 0;
	Core()
	{
		swell_ctl_config cfg;
		swell_ctl_default_config(&cfg);
		arena.resize(swell_ctl_arena_words(cfg.nx, cfg.ny));
		REQUIRE(swell_ctl_init(&c, &cfg, arena.data(), arena.size()) == SWELL_OK);
	}
	/* one request, its one answer: ACK (value in *v) or NACK (reason returned) */
	swell_err ask(uint8_t type, uint16_t id, int32_t value, int32_t *v)
	{
		const swell_msg m = swell_test::param_msg(type, id, value, ++seq);
		swell_ctl_rx(&c, SWELL_LINK_HOST, &m);
		swell_msg out[4];
		size_t n = swell_ctl_tx(&c, SWELL_LINK_HOST, out, 4);
		REQUIRE(n == 1);
		if (out[0].type == SWELL_MSG_PARAM_ACK) {
			CHECK(out[0].u.param_ack.seq == seq);
			*v = out[0].u.param_ack.value;
			return SWELL_OK;
		}
		REQUIRE(out[0].type == SWELL_MSG_PARAM_NACK);
		CHECK(out[0].u.param_nack.seq == seq);
		return (swell_err)out[0].u.param_nack.err;
	}
};

} // namespace

TEST_CASE("every table default is what the reference configuration holds, read back through PARAM_GET", "[ctl][param]")
{
	Core k;
	size_t n = 0;
	const swell_param_desc *t = swell_param_table(&n);
	REQUIRE(n >= 13);
	for (size_t i = 0; i < n; i++) {
		int32_t v = -1;
		INFO(t[i].name << " (id " << t[i].id << ")");
		REQUIRE(k.ask(SWELL_MSG_PARAM_GET, t[i].id, 0, &v) == SWELL_OK);
		CHECK(v == t[i].def);
		CHECK(t[i].min <= t[i].def);
		CHECK(t[i].def <= t[i].max);
	}
}

TEST_CASE("one past either end of a parameter's table range is refused as out of range and changes nothing", "[ctl][param]")
{
	Core k;
	size_t n = 0;
	const swell_param_desc *t = swell_param_table(&n);
	const swell_ctl_config before = k.c.cfg;
	int refused = 0;
	for (size_t i = 0; i < n; i++) {
		int32_t v = 0;
		INFO(t[i].name << " range " << t[i].min << " .. " << t[i].max);
		if (t[i].min > INT32_MIN) {
			CHECK(k.ask(SWELL_MSG_PARAM_SET, t[i].id, t[i].min - 1, &v) == SWELL_ERANGE);
			refused++;
		}
		if (t[i].max < INT32_MAX) {
			CHECK(k.ask(SWELL_MSG_PARAM_SET, t[i].id, t[i].max + 1, &v) == SWELL_ERANGE);
			refused++;
		}
	}
	CHECK(refused >= (int)n); /* every row has a bound that can be passed */
	CHECK(std::memcmp(&before, &k.c.cfg, sizeof(before)) == 0);
	CHECK(k.c.n.params_refused == (uint32_t)refused);
}

TEST_CASE("a parameter set to a new value inside its range reads back that value", "[ctl][param]")
{
	Core k;
	struct {
		const char *name;
		int32_t v;
	} sets[] = {{"wave.e", 200000000},    {"wave.damping", 2000000}, {"wave.stencil", 1},        {"body.mass", 80},
		    {"body.a", 40000},        {"body.b", 30000},         {"body.h", 20000},          {"body.damper", 3000},
		    {"force.max", 5000000},   {"force.rate", 100000000}, {"force.gain", 32768},      {"force.mode", 1},
		    {"link.silent_ticks", 5}, {"ctl.autorun", 1},        {"frame.x0", 150000},       {"frame.y0", 250000},
		    {"frame.z0", -20000},     {"frame.axes", 213},       {"frame.flip", 3},          {"hm.inertia", 3000},
		    {"force.passivity", 0},   {"force.pc_delay", 3},     {"force.pc_damping", 20000}};
	size_t n = 0, rw = 0;
	const swell_param_desc *t = swell_param_table(&n);
	for (size_t i = 0; i < n; i++)
		rw += t[i].access == SWELL_PACCESS_RW;
	/* every writable row is exercised (frame.scale below: effect mode, set here, wants scale 1) */
	CHECK(sizeof(sets) / sizeof(sets[0]) + 1 == rw);
	for (auto &s : sets) {
		const swell_param_desc *d = swell_param_by_name(s.name);
		INFO(s.name << " = " << s.v);
		REQUIRE(d != nullptr);
		int32_t v = 0, back = 0;
		REQUIRE(k.ask(SWELL_MSG_PARAM_SET, d->id, s.v, &v) == SWELL_OK);
		CHECK(v == s.v);
		REQUIRE(k.ask(SWELL_MSG_PARAM_GET, d->id, 0, &back) == SWELL_OK);
		CHECK(back == s.v);
	}
	CHECK(k.c.cfg.body.mass_g == 80u);
	CHECK(k.c.cfg.wave.stencil == SWELL_STENCIL_CALIBRATED);
	CHECK(k.c.cfg.silent_ticks == 5);
	CHECK(k.c.cfg.passivity == 0);
	CHECK(k.c.cfg.pc_delay == 3);
	CHECK(k.c.cfg.pc_damping_uN_per_mm_s == 20000u);
	Core k2;
	int32_t v = 0;
	REQUIRE(k2.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_SCALE, 131072, &v) == SWELL_OK);
	CHECK(k2.c.cfg.xform.scale == 131072);
	/* effect mode renders along the device's z, unscaled: refused now, and the scale refused there */
	CHECK(k2.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FORCE_MODE, 1, &v) == SWELL_EINVAL);
	CHECK(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_SCALE, 131072, &v) == SWELL_EINVAL);
}

TEST_CASE("the frame parameters place, swap and flip the device's axes in the pool, and a code that is not a permutation "
	  "or a change while running is refused and changes nothing",
	  "[ctl][param][frame]")
{
	Core k;
	int32_t v = 0;
	REQUIRE(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_X0, 150000, &v) == SWELL_OK);
	REQUIRE(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_Y0, 250000, &v) == SWELL_OK);
	REQUIRE(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_Z0, 30000, &v) == SWELL_OK);
	REQUIRE(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_AXES, 213, &v) == SWELL_OK);
	REQUIRE(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_FLIP, 1, &v) == SWELL_OK);
	CHECK(k.c.cfg.xform.axis[0] == 1);
	CHECK(k.c.cfg.xform.axis[1] == 0);
	CHECK(k.c.cfg.xform.axis[2] == 2);
	CHECK(k.c.cfg.xform.sign[0] == -1);
	CHECK(k.c.cfg.xform.sign[1] == 1);
	CHECK(k.c.cfg.xform.sign[2] == 1);
	CHECK(k.c.body.xf.offset_um[2] == 30000); /* taken by the force law */
	/* the device at x 10, y 20, z 40 mm (in the air): the pose says where that is in the pool */
	swell_msg out[SWELL_CTL_QUEUE];
	int pose = 0;
	for (int t = 0; t < 60 && !pose; t++) {
		const swell_msg m = swell_test::device_pos_msg((uint8_t)t, 4000, 1, 1000, 2000);
		swell_ctl_rx(&k.c, SWELL_LINK_DEVICE, &m);
		swell_ctl_tick(&k.c);
		const size_t n = swell_ctl_tx(&k.c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
		swell_ctl_tx(&k.c, SWELL_LINK_DEVICE, out + n, SWELL_CTL_QUEUE - n);
		for (size_t i = 0; i < n; i++)
			if (out[i].type == SWELL_MSG_OBJECT_POSE) {
				pose = 1;
				CHECK(out[i].u.object_pose.x_10um == 15000 - 2000); /* pool x = 150 - device y */
				CHECK(out[i].u.object_pose.y_10um == 25000 + 1000); /* pool y = 250 + device x */
			}
	}
	CHECK(pose == 1);
	/* not three different axes: refused, nothing changed */
	const swell_ctl_config before = k.c.cfg;
	for (int32_t bad : {112, 124, 223, 320, 301})
		CHECK(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_FRAME_AXES, bad, &v) ==
		      (bad < 123 || bad > 321 ? SWELL_ERANGE : SWELL_EINVAL));
	CHECK(std::memcmp(&before, &k.c.cfg, sizeof(before)) == 0);
	/* running: every frame parameter is refused (state), the frame stays */
	REQUIRE(k.ask(SWELL_MSG_PARAM_SET, SWELL_PARAM_COMMAND, SWELL_CMD_RUN, &v) == SWELL_OK);
	for (int t = 0; t < 10 && k.c.state != SWELL_CTL_RUNNING; t++) {
		const swell_msg m = swell_test::device_pos_msg((uint8_t)(100 + t), 4000, 1, 1000, 2000);
		swell_ctl_rx(&k.c, SWELL_LINK_DEVICE, &m);
		swell_ctl_tick(&k.c);
		swell_ctl_tx(&k.c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
		swell_ctl_tx(&k.c, SWELL_LINK_DEVICE, out, SWELL_CTL_QUEUE);
	}
	REQUIRE(k.c.state == SWELL_CTL_RUNNING);
	for (uint16_t id : {SWELL_PARAM_FRAME_X0, SWELL_PARAM_FRAME_Y0, SWELL_PARAM_FRAME_Z0, SWELL_PARAM_FRAME_SCALE,
			    SWELL_PARAM_FRAME_AXES, SWELL_PARAM_FRAME_FLIP})
		CHECK(k.ask(SWELL_MSG_PARAM_SET, id,
			    id == SWELL_PARAM_FRAME_AXES            ? 123
				    : id == SWELL_PARAM_FRAME_SCALE ? 65536
								    : 0,
			    &v) == SWELL_ESTATE);
	CHECK(k.c.cfg.xform.offset_um[0] == 150000);
	CHECK(k.c.cfg.frame_axes == 213);
}

TEST_CASE("dev.status, dev.rate and ctl.tick_hz say what the controller measures and refuse a set", "[ctl][param]")
{
	Core k;
	int32_t v = -1;
	swell_msg out[SWELL_CTL_QUEUE];
	const uint32_t hz = k.c.cfg.tick_hz;
	/* a device heard every other tick for two whole seconds of ticks, powered and in e-stop */
	for (uint32_t t = 0; t < 2 * hz; t++) {
		if (t % 2 == 0) {
			const swell_msg m = swell_test::device_pos_msg((uint8_t)(t / 2), 4000, 1 | 4);
			swell_ctl_rx(&k.c, SWELL_LINK_DEVICE, &m);
		}
		swell_ctl_tick(&k.c);
		swell_ctl_tx(&k.c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
		swell_ctl_tx(&k.c, SWELL_LINK_DEVICE, out, SWELL_CTL_QUEUE);
	}
	REQUIRE(k.ask(SWELL_MSG_PARAM_GET, SWELL_PARAM_DEV_RATE, 0, &v) == SWELL_OK);
	CHECK(v == (int32_t)(hz / 2));
	REQUIRE(k.ask(SWELL_MSG_PARAM_GET, SWELL_PARAM_DEV_STATUS, 0, &v) == SWELL_OK);
	CHECK(v == 5);
	REQUIRE(k.ask(SWELL_MSG_PARAM_GET, SWELL_PARAM_CTL_TICK_HZ, 0, &v) == SWELL_OK);
	CHECK(v == (int32_t)hz);
	for (uint16_t id : {SWELL_PARAM_DEV_RATE, SWELL_PARAM_DEV_STATUS, SWELL_PARAM_CTL_TICK_HZ})
		CHECK(k.ask(SWELL_MSG_PARAM_SET, id, 0, &v) == SWELL_EINVAL);
	/* silent for a whole second: the rate falls to 0 */
	for (uint32_t t = 0; t < hz + 1; t++) {
		swell_ctl_tick(&k.c);
		swell_ctl_tx(&k.c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
		swell_ctl_tx(&k.c, SWELL_LINK_DEVICE, out, SWELL_CTL_QUEUE);
	}
	REQUIRE(k.ask(SWELL_MSG_PARAM_GET, SWELL_PARAM_DEV_RATE, 0, &v) == SWELL_OK);
	CHECK(v == 0);
}

TEST_CASE("DRY parameters are refused while the object displaces water, the others are not", "[ctl][param]")
{
	Core k;
	/* the device holds the object 20 mm into the water, running */
	for (int t = 0; t < 600; t++) {
		const swell_msg m = swell_test::device_pos_msg((uint8_t)t, -2000);
		swell_ctl_rx(&k.c, SWELL_LINK_DEVICE, &m);
		swell_ctl_tick(&k.c);
		swell_msg out[SWELL_CTL_QUEUE];
		swell_ctl_tx(&k.c, SWELL_LINK_HOST, out, SWELL_CTL_QUEUE);
		swell_ctl_tx(&k.c, SWELL_LINK_DEVICE, out, SWELL_CTL_QUEUE);
	}
	REQUIRE(k.c.body.applied.delta_lsb != 0);
	size_t n = 0;
	const swell_param_desc *t = swell_param_table(&n);
	int dry = 0;
	for (size_t i = 0; i < n; i++) {
		int32_t v = 0, now = 0;
		REQUIRE(k.ask(SWELL_MSG_PARAM_GET, t[i].id, 0, &now) == SWELL_OK);
		const int32_t want = now < t[i].max ? now + 1 : now - 1;
		INFO(t[i].name << ": " << now << " -> " << want << ", " << swell_param_when_text(t[i].when));
		swell_err e = k.ask(SWELL_MSG_PARAM_SET, t[i].id, want, &v);
		if (t[i].access == SWELL_PACCESS_RO) {
			CHECK(e == SWELL_EINVAL);
		} else if (t[i].group == SWELL_PGROUP_FRAME) {
			/* the frame moves the object: the body refuses it in the water (124 is no frame; a
			 * scale other than 1 is none in effect mode, set by force.mode's row above) */
			const bool invalid = t[i].id == SWELL_PARAM_FRAME_AXES ||
				(t[i].id == SWELL_PARAM_FRAME_SCALE && k.c.cfg.force_mode == SWELL_FORCE_EFFECT);
			CHECK(e == (invalid ? SWELL_EINVAL : SWELL_ESTATE));
		} else if (t[i].when == SWELL_PWHEN_DRY) {
			CHECK(e == SWELL_ESTATE);
			dry++;
		} else if (t[i].id != SWELL_PARAM_WAVE_E || want > 0) {
			CHECK(e == SWELL_OK);
		}
	}
	CHECK(dry == 5); /* mass, a, b, h, damper */
}

TEST_CASE("names, ids and commands are unique and found both ways", "[param]")
{
	size_t n = 0;
	const swell_param_desc *t = swell_param_table(&n);
	std::set<std::string> names;
	std::set<int> ids;
	for (size_t i = 0; i < n; i++) {
		names.insert(t[i].name);
		ids.insert(t[i].id);
		CHECK(swell_param_by_name(t[i].name) == &t[i]);
		CHECK(swell_param_by_id(t[i].id) == &t[i]);
	}
	CHECK(names.size() == n);
	CHECK(ids.size() == n);
	CHECK(ids.count(SWELL_PARAM_COMMAND) == 0);
	CHECK(swell_param_by_name("body.mas") == nullptr);
	CHECK(swell_param_by_id(999) == nullptr);
	CHECK(swell_command_by_name("run") == SWELL_CMD_RUN);
	CHECK(swell_command_by_name("clear") == SWELL_CMD_CLEAR);
	CHECK(swell_command_by_name("jump") == -1);
	CHECK(std::string(swell_command_name(SWELL_CMD_STOP)) == "stop");
	CHECK(swell_command_name(9) == nullptr);
}
