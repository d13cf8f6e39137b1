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
	} sets[] = {{"wave.e", 200000000},    {"wave.damping", 2000000}, {"wave.stencil", 1},   {"body.mass", 80},
		    {"body.a", 40000},        {"body.b", 30000},         {"body.h", 20000},     {"body.damper", 3000},
		    {"force.max", 5000000},   {"force.rate", 100000000}, {"force.gain", 32768}, {"force.mode", 1},
		    {"link.silent_ticks", 5}, {"ctl.autorun", 1}};
	size_t n = 0;
	swell_param_table(&n);
	CHECK(sizeof(sets) / sizeof(sets[0]) == n); /* every row is exercised */
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
		if (t[i].when == SWELL_PWHEN_DRY) {
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
