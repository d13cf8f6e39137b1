/* The controller core: states, link supervision, parameters, bounded work, telemetry, determinism. */
#include <catch2/catch.hpp>

#include "swell_msgs.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <random>
#include <utility>
#include <vector>

extern "C" {
#include "swell/ctl.h"
}

namespace {

struct Ctl {
	std::vector<int32_t> arena;
	swell_ctl c{};
	explicit Ctl(const swell_ctl_config &cfg) : arena(swell_ctl_arena_words(cfg.nx, cfg.ny))
	{
		REQUIRE(swell_ctl_init(&c, &cfg, arena.data(), arena.size()) == SWELL_OK);
	}
	/* The device says where it is (um, device frame) and that it is powered. */
	void device(int32_t x, int32_t y, int32_t z, uint8_t status = 1)
	{
		const swell_msg m =
			swell_test::device_pos_msg(seq++, (int16_t)(z / 10), status, (int16_t)(x / 10), (int16_t)(y / 10));
		swell_ctl_rx(&c, SWELL_LINK_DEVICE, &m);
	}
	/* n ticks, each with a device sample held 100 mm above the water (status: powered) */
	void held(int n, uint8_t status = 1)
	{
		for (int t = 0; t < n; t++) {
			device(0, 0, 100000, status);
			swell_ctl_tick(&c);
		}
	}
	void param(uint16_t id, int32_t v)
	{
		const swell_msg m = swell_test::param_msg(SWELL_MSG_PARAM_SET, id, v, seq++);
		swell_ctl_rx(&c, SWELL_LINK_HOST, &m);
	}
	std::vector<swell_msg> drain(swell_ctl_link l)
	{
		std::vector<swell_msg> out(SWELL_CTL_QUEUE);
		out.resize(swell_ctl_tx(&c, l, out.data(), out.size()));
		return out;
	}
	/* The last FORCE_CMD of a tick. */
	swell_msg_force_cmd force()
	{
		swell_msg_force_cmd f{};
		for (const swell_msg &m : drain(SWELL_LINK_DEVICE))
			if (m.type == SWELL_MSG_FORCE_CMD)
				f = m.u.force_cmd;
		return f;
	}
	uint8_t seq = 0;
};

swell_ctl_config pool()
{
	swell_ctl_config cfg;
	swell_ctl_default_config(&cfg);
	return cfg;
}

} // namespace

TEST_CASE("the reference configuration is valid and its arena is the velocity form's storage plus packed "
	  "samples and stale-quad bits",
	  "[ctl]")
{
	swell_ctl_config cfg = pool();
	CHECK(swell_ctl_check(&cfg) == SWELL_OK);
	CHECK(swell_ctl_arena_words(64, 64) == SWELL_WAVE_WORDS(64, 64) + 64 * 64 / 2 + 64 / 2);
	cfg.solver_hz = 333; /* does not divide 2500 */
	CHECK(swell_ctl_check(&cfg) == SWELL_ERANGE);
	cfg = pool();
	cfg.nx = 300; /* wider than the wire carries */
	CHECK(swell_ctl_check(&cfg) == SWELL_ESIZE);
	cfg = pool();
	cfg.wave.e = SWELL_Q30_ONE / 10 * 6; /* 0.6: unstable */
	CHECK(swell_ctl_check(&cfg) == SWELL_EUNSTABLE);
}

TEST_CASE("states go boot, idle, armed, running and fault, with zero force outside running", "[ctl][state]")
{
	Ctl k(pool());
	CHECK(k.c.state == SWELL_CTL_BOOT);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_IDLE);
	CHECK(k.force().enable == 0);

	/* device heard: armed, still no force */
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_ARMED);
	CHECK(k.force().enable == 0);

	/* run command: running; the object held 100 mm above the water feels its weight (0.981 N down) */
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	k.held(50);
	CHECK(k.c.state == SWELL_CTL_RUNNING);
	swell_msg_force_cmd f = k.force();
	CHECK(f.enable == 1);
	CHECK(f.fz_cN == -98);

	/* stop: armed, zero at once */
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_STOP);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_ARMED);
	f = k.force();
	CHECK(f.enable == 0);
	CHECK(f.fz_cN == 0);
}

TEST_CASE("a silent device gives zero force and a fault within 2 ticks, and clear brings it back", "[ctl][link]")
{
	Ctl k(pool());
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	for (int t = 0; t < 100; t++) {
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		k.drain(SWELL_LINK_DEVICE);
	}
	REQUIRE(k.c.state == SWELL_CTL_RUNNING);
	/* the device goes silent */
	int zero_after = -1;
	for (int t = 1; t <= 10 && zero_after < 0; t++) {
		swell_ctl_tick(&k.c);
		swell_msg_force_cmd f = k.force();
		if (f.enable == 0 && f.fz_cN == 0 && f.fx_cN == 0 && f.fy_cN == 0)
			zero_after = t;
	}
	INFO("zero force after " << zero_after << " silent ticks");
	CHECK(zero_after >= 1);
	CHECK(zero_after <= 2);
	CHECK(k.c.state == SWELL_CTL_FAULT);
	CHECK(k.c.last_err == SWELL_ETIMEOUT);

	/* the device comes back: still fault (no autorun) until CLEAR, then idle -> armed -> running */
	k.held(10);
	CHECK(k.c.state == SWELL_CTL_FAULT);
	CHECK(k.force().enable == 0);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_CLEAR);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	k.held(5);
	CHECK(k.c.state == SWELL_CTL_RUNNING);
	CHECK(k.c.n.faults == 1u);
}

TEST_CASE("device samples: a short gap is counted lost, a far sequence jump is one resynchronisation", "[ctl][link]")
{
	Ctl k(pool());
	k.held(10); /* seq 0..9 */
	k.seq = 13; /* 10..12 lost */
	k.held(5);
	CHECK(k.c.n.dev_lost == 3u);
	k.seq = 200; /* another device, or one that started its count again: not 182 lost */
	k.held(5);
	k.seq = 100; /* back by 105 */
	k.held(5);
	INFO("dev_lost " << k.c.n.dev_lost << ", resyncs " << k.c.dev_seq.resyncs);
	CHECK(k.c.n.dev_lost == 3u);
	CHECK(k.c.dev_seq.resyncs == 2u);
}

TEST_CASE("a link down (bus-off, unplug, reset) faults the next tick as a silent device does, on every port alike", "[ctl][link]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	cfg.recover_ticks = 20;
	Ctl silent(cfg), down(cfg);
	silent.held(10);
	down.held(10);
	REQUIRE(silent.c.state == SWELL_CTL_RUNNING);
	REQUIRE(down.c.state == SWELL_CTL_RUNNING);
	swell_ctl_link_down(&down.c, SWELL_LINK_HOST); /* the force loop does not depend on the host */
	down.held(1);
	REQUIRE(down.c.state == SWELL_CTL_RUNNING);
	silent.held(1);

	int silent_ticks = 0;
	while (silent.c.state == SWELL_CTL_RUNNING && silent_ticks < 100) {
		swell_ctl_tick(&silent.c);
		silent_ticks++;
	}
	/* the device still talks in the tick its link goes down (starved, or bus-off after the read) */
	down.device(0, 0, 100000);
	swell_ctl_link_down(&down.c, SWELL_LINK_DEVICE);
	CHECK(swell_ctl_device_lost(&down.c));
	swell_ctl_tick(&down.c);
	INFO("silence faulted after " << silent_ticks << " ticks");
	CHECK(down.c.state == SWELL_CTL_FAULT);
	CHECK(down.c.state == silent.c.state);
	CHECK(down.c.last_err == SWELL_ETIMEOUT);
	CHECK(down.c.last_err == silent.c.last_err);
	CHECK(down.c.n.faults == silent.c.n.faults);
	swell_msg_force_cmd fd = down.force(), fs = silent.force();
	CHECK(fd.enable == 0);
	CHECK(fs.enable == 0);

	/* back the same way: recover_ticks after the device is heard again */
	int back[2] = {-1, -1};
	Ctl *k[2] = {&silent, &down};
	for (int i = 0; i < 2; i++)
		for (int t = 1; t <= 40 && back[i] < 0; t++) {
			k[i]->held(1);
			if (k[i]->c.state == SWELL_CTL_RUNNING)
				back[i] = t;
		}
	INFO("running again after " << back[0] << " (silence) and " << back[1] << " (link down) ticks");
	CHECK(back[1] == back[0]);
	CHECK(back[1] >= 20);
}

TEST_CASE("autorun leaves a fault by itself after the device has been back for recover_ticks", "[ctl][link]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	cfg.recover_ticks = 20;
	Ctl k(cfg);
	k.held(10);
	REQUIRE(k.c.state == SWELL_CTL_RUNNING);
	for (int t = 0; t < 5; t++)
		swell_ctl_tick(&k.c);
	REQUIRE(k.c.state == SWELL_CTL_FAULT);
	int back = -1;
	for (int t = 1; t <= 40 && back < 0; t++) {
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		if (k.c.state == SWELL_CTL_RUNNING)
			back = t;
	}
	INFO("running again after " << back << " ticks");
	CHECK(back >= 20);
	CHECK(back <= 23);
}

TEST_CASE("with autorun, STOP from the host stops the force law and holds until RUN", "[ctl][state]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	Ctl k(cfg);
	k.held(10);
	REQUIRE(k.c.state == SWELL_CTL_RUNNING);
	REQUIRE(k.force().enable == 1);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_STOP);
	for (int t = 0; t < 200; t++) { /* autorun must not start it again */
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		const swell_msg_force_cmd f = k.force();
		INFO("tick " << t << " after STOP");
		CHECK(k.c.state == SWELL_CTL_ARMED);
		CHECK((f.enable == 0 && f.fz_cN == 0));
	}
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_RUNNING);
	/* a fault (the device silent), a STOP while in it: autorun's recovery goes no further than ARMED */
	for (int t = 0; t < 5; t++)
		swell_ctl_tick(&k.c);
	REQUIRE(k.c.state == SWELL_CTL_FAULT);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_STOP);
	for (int t = 0; t < 400; t++) {
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		CHECK(k.c.state != SWELL_CTL_RUNNING);
	}
	CHECK(k.c.state == SWELL_CTL_ARMED);
}

TEST_CASE("after an e-stop, autorun counts recover_ticks from the release, with zero force until then", "[ctl][link]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	cfg.recover_ticks = 20;
	Ctl k(cfg);
	k.held(10);
	REQUIRE(k.c.state == SWELL_CTL_RUNNING);
	/* the e-stop pressed for 100 ticks while the device goes on reporting (status: powered, e-stop) */
	for (int t = 0; t < 100; t++) {
		k.device(0, 0, 100000, 1 | 4);
		swell_ctl_tick(&k.c);
		CHECK(k.c.state == SWELL_CTL_FAULT);
		CHECK(k.force().enable == 0);
	}
	/* released: heard for 100 ticks already, but the recovery starts now */
	int back = -1;
	for (int t = 1; t <= 40 && back < 0; t++) {
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		const swell_msg_force_cmd f = k.force();
		if (k.c.state == SWELL_CTL_RUNNING)
			back = t;
		else
			CHECK((f.enable == 0 && f.fx_cN == 0 && f.fy_cN == 0 && f.fz_cN == 0));
	}
	INFO("running again " << back << " ticks after the release");
	CHECK(back >= 20);
	CHECK(back <= 23);
}

TEST_CASE("the device's emergency stop faults at once", "[ctl][state]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	Ctl k(cfg);
	k.held(10);
	REQUIRE(k.c.state == SWELL_CTL_RUNNING);
	k.device(0, 0, 100000, 1 | 4);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_FAULT);
	CHECK(k.c.last_err == SWELL_ESTOP);
	CHECK(k.force().enable == 0);
}

TEST_CASE("bad parameter sets are refused with a nack and change nothing", "[ctl][param]")
{
	Ctl k(pool());
	swell_ctl before = k.c;
	struct {
		uint16_t id;
		int32_t v;
		swell_err want;
	} bad[] = {
		{SWELL_PARAM_WAVE_E, SWELL_Q30_ONE / 10 * 6, SWELL_EUNSTABLE},
		{SWELL_PARAM_WAVE_E, -5, SWELL_ERANGE},
		{SWELL_PARAM_WAVE_DAMPING, SWELL_Q30_ONE, SWELL_ERANGE},
		{SWELL_PARAM_WAVE_STENCIL, 9, SWELL_ERANGE},
		{SWELL_PARAM_BODY_MASS_G, 0, SWELL_ERANGE},
		{SWELL_PARAM_BODY_MASS_G, -100, SWELL_ERANGE},
		{SWELL_PARAM_FORCE_MAX_UN, 0, SWELL_ERANGE},
		{SWELL_PARAM_FORCE_GAIN, -1, SWELL_ERANGE},
		{SWELL_PARAM_SILENT_TICKS, 0, SWELL_ERANGE},
		{SWELL_PARAM_AUTORUN, 2, SWELL_ERANGE},
		{SWELL_PARAM_COMMAND, 7, SWELL_ERANGE},
		{SWELL_PARAM_COMMAND, SWELL_CMD_CLEAR, SWELL_ESTATE}, /* not in fault */
		{999, 1, SWELL_EUNKNOWN},
	};
	for (auto &b : bad) {
		k.param(b.id, b.v);
		std::vector<swell_msg> out = k.drain(SWELL_LINK_HOST);
		REQUIRE(out.size() == 1);
		INFO("param " << b.id << " = " << b.v);
		CHECK(out[0].type == SWELL_MSG_PARAM_NACK);
		CHECK(out[0].u.param_nack.id == b.id);
		CHECK(out[0].u.param_nack.err == b.want);
	}
	CHECK(std::memcmp(&before.cfg, &k.c.cfg, sizeof(before.cfg)) == 0);
	CHECK(std::memcmp(&before.wave, &k.c.wave, sizeof(before.wave)) == 0);
	CHECK(std::memcmp(&before.safety, &k.c.safety, sizeof(before.safety)) == 0);
	CHECK(k.c.n.params_refused == sizeof(bad) / sizeof(bad[0]));

	/* a good one is acknowledged with the value in force */
	k.param(SWELL_PARAM_FORCE_MAX_UN, 5000000);
	std::vector<swell_msg> out = k.drain(SWELL_LINK_HOST);
	REQUIRE(out.size() == 1);
	CHECK(out[0].type == SWELL_MSG_PARAM_ACK);
	CHECK(out[0].u.param_ack.value == 5000000);
	CHECK(k.c.cfg.safety.f_max_uN == 5000000u);
}

TEST_CASE("no tick carries a whole solver step and the solver keeps its own rate", "[ctl][work]")
{
	for (uint32_t tick_hz : {2500u, 1000u}) {
		swell_ctl_config cfg = pool();
		cfg.tick_hz = tick_hz;
		cfg.autorun = 1;
		Ctl k(cfg);
		for (uint32_t t = 0; t < tick_hz; t++) { /* one second, object in the water */
			k.device(0, 0, -20000);
			swell_ctl_tick(&k.c);
			k.drain(SWELL_LINK_DEVICE);
			k.drain(SWELL_LINK_HOST);
		}
		const uint32_t whole_step = 6u * 64 * 64; /* 4 edges a cell + finish + ceiling scan */
		WARN(tick_hz << " Hz: " << k.c.n.solver_steps << " solver steps in 1 s, worst tick " << k.c.n.work_max
			     << " cell-operations, a whole step " << whole_step);
		CHECK(k.c.n.solver_steps == 250u);
		CHECK(k.c.n.work_max < whole_step / 2);
		CHECK(k.c.state == SWELL_CTL_RUNNING);
	}
}

TEST_CASE("telemetry: heartbeat, scene, pose and only the heights that changed, within budget", "[ctl][telemetry]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	Ctl k(cfg);
	int hb = 0, scene = 0, pose = 0, quads = 0, worst = 0;
	for (int t = 0; t < 2500; t++) {
		k.device(0, 0, 100000); /* held above the water: a calm pool */
		swell_ctl_tick(&k.c);
		std::vector<swell_msg> out = k.drain(SWELL_LINK_HOST);
		worst = std::max(worst, (int)out.size());
		for (auto &m : out) {
			hb += m.type == SWELL_MSG_HEARTBEAT;
			scene += m.type == SWELL_MSG_SCENE;
			pose += m.type == SWELL_MSG_OBJECT_POSE;
			quads += m.type == SWELL_MSG_HEIGHT_QUAD;
		}
		k.drain(SWELL_LINK_DEVICE);
	}
	CHECK(hb == 10);
	CHECK(scene == 1);
	CHECK(pose == 100);
	CHECK(worst <= (int)cfg.host_budget);
	/* a calm pool: every quad once (nothing known yet), then only the slow refresh that repairs
	 * losses: every quad again at least once a second */
	CHECK(quads - (int)k.c.n.quads_refreshed == 64 * 64 / 4);
	CHECK(k.c.n.quads_refreshed >= 64u * 64 / 4);

	/* drop the object in: heights change and are sent again */
	int later = 0;
	for (int t = 0; t < 500; t++) {
		k.device(0, 0, -30000);
		swell_ctl_tick(&k.c);
		for (auto &m : k.drain(SWELL_LINK_HOST))
			later += m.type == SWELL_MSG_HEIGHT_QUAD;
		k.drain(SWELL_LINK_DEVICE);
	}
	WARN("calm pool: " << quads << " quads in the first second; after the object entered: " << later << " quads in 0.2 s");
	CHECK(later > 0);
	CHECK(k.c.q[SWELL_LINK_HOST].dropped == 0u);
}

/* Every quad the scan would pass unread (its stale bit clear) holds exactly the samples last sent,
 * so passing it sends the same as reading it: checked after every tick while an object enters the
 * water and the waves spread, on a grid with partial tiles. Returns the quads found clear. */
static long check_fresh_quads(const Ctl &k)
{
	const swell_ctl &c = k.c;
	long fresh = 0;
	for (uint32_t q = 0; q < c.quads; q++) {
		if (c.quad_stale[q / SWELL_QUADS_PER_TILE] >> (q % SWELL_QUADS_PER_TILE) & 1u)
			continue;
		fresh++;
		const swell_quad_at at = swell_quad_locate(q, c.tiles_x);
		for (uint32_t i = 0; i < 4; i++) {
			if (at.y >= c.cfg.ny || at.x0 + i >= c.cfg.nx)
				continue;
			const uint32_t a = at.y * c.cfg.nx + at.x0 + i;
			const int16_t now = swell_height_to_sample(swell_wave_h(&c.wave, a));
			const int16_t sent = (int16_t)(uint16_t)(c.sent[a >> 1] >> ((a & 1u) * 16));
			if (now != sent) {
				FAIL_CHECK("quad " << q << " cell " << a << " passed unread: now " << now << ", sent " << sent);
				return fresh;
			}
		}
	}
	return fresh;
}

TEST_CASE("telemetry: a quad passed unread because its tile did not move holds the samples last sent", "[ctl][telemetry]")
{
	/* partial tiles on both sides; an odd width (no quad is two words of sent[]) and an even one */
	const uint16_t nx = GENERATE(60, 61);
	swell_ctl_config cfg = pool();
	cfg.nx = nx;
	cfg.ny = 52;
	cfg.xform.offset_um[0] = 120000; /* off the centre: the waves reach the far walls late */
	cfg.xform.offset_um[1] = 110000;
	cfg.autorun = 1;
	Ctl k(cfg);
	const uint32_t n = (uint32_t)cfg.nx * cfg.ny;
	std::vector<int32_t> view(n, 0);
	long fresh = 0, stale_ticks = 0;
	for (int t = 0; t < 2500; t++) {
		/* from 20 mm above the water down to 25 mm below at 50 mm/s, then held */
		k.device(0, 0, std::max(20000 - t * 20, -25000));
		swell_ctl_tick(&k.c);
		for (const swell_msg &m : k.drain(SWELL_LINK_HOST))
			if (m.type == SWELL_MSG_HEIGHT_QUAD)
				swell_test::quad_to_grid(m.u.height_quad, view.data(), cfg.nx, cfg.ny);
		k.drain(SWELL_LINK_DEVICE);
		fresh += check_fresh_quads(k);
		/* the viewer's picture is what the controller believes it sent */
		for (uint32_t a = 0; a < n; a++) {
			const int16_t sent = (int16_t)(uint16_t)(k.c.sent[a >> 1] >> ((a & 1u) * 16));
			if (sent != INT16_MIN && swell_sample_to_height(sent) != view[a])
				FAIL("cell " << a << ": sent " << sent << ", the viewer holds " << view[a]);
		}
		bool any_stale = false;
		for (uint32_t tile = 0; tile < (uint32_t)k.c.tiles_x * k.c.tiles_y; tile++)
			any_stale |= k.c.quad_stale[tile] != 0;
		stale_ticks += any_stale;
	}
	WARN(nx << " x 52: " << fresh << " quads passable unread over 2500 ticks, " << stale_ticks
		<< " ticks with quads to read");
	CHECK(fresh > 0);
	CHECK(stale_ticks > 1000); /* the water moved: the check saw quads go stale and come back */
	CHECK(k.c.n.solver_steps == 250u);
}

TEST_CASE("the same device trace gives bit-identical outputs", "[ctl][determinism]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	auto run = [&](std::vector<swell_msg> &dev_out, uint32_t &checksum) {
		Ctl k(cfg);
		for (int t = 0; t < 3000; t++) {
			/* a scripted hand: lower the object through the surface and shake it */
			int32_t z = 60000 - 40 * t;
			if (z < -30000)
				z = -30000 + ((t / 50) % 2 ? 5000 : -5000);
			if (t % 97 != 13) /* and drop a few samples */
				k.device((t % 200) * 50, 0, z);
			swell_ctl_tick(&k.c);
			for (auto &m : k.drain(SWELL_LINK_DEVICE))
				dev_out.push_back(m);
			k.drain(SWELL_LINK_HOST);
		}
		checksum = swell_wave_checksum(&k.c.wave);
	};
	std::vector<swell_msg> a, b;
	uint32_t ca = 0, cb = 1;
	run(a, ca);
	run(b, cb);
	REQUIRE(a.size() == b.size());
	for (size_t i = 0; i < a.size(); i++)
		REQUIRE(swell_msg_equal(&a[i], &b[i]));
	CHECK(ca == cb);
	int nonzero = 0;
	for (auto &m : a)
		nonzero += m.type == SWELL_MSG_FORCE_CMD && m.u.force_cmd.fz_cN != 0;
	CHECK(nonzero > 1000);
}

TEST_CASE("the tick split into a force part and a background part gives the same outputs", "[ctl][split]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	Ctl whole(cfg), split(cfg);
	for (int t = 0; t < 1500; t++) {
		int32_t z = 50000 - 60 * t;
		whole.device(0, 0, z);
		split.device(0, 0, z);
		swell_ctl_tick(&whole.c);
		swell_ctl_tick_force(&split.c);
		/* the force goes out before the background part runs (a heartbeat the background queued for
		 * the device goes with the next drain instead) */
		std::vector<swell_msg> a = whole.drain(SWELL_LINK_DEVICE), b = split.drain(SWELL_LINK_DEVICE);
		auto force_of = [](const std::vector<swell_msg> &v) {
			for (const swell_msg &m : v)
				if (m.type == SWELL_MSG_FORCE_CMD)
					return m;
			return swell_msg{};
		};
		swell_msg fa = force_of(a), fb = force_of(b);
		REQUIRE(fa.type == SWELL_MSG_FORCE_CMD);
		REQUIRE(swell_msg_equal(&fa, &fb));
		swell_ctl_tick_background(&split.c);
		std::vector<swell_msg> ha = whole.drain(SWELL_LINK_HOST), hb = split.drain(SWELL_LINK_HOST);
		REQUIRE(ha.size() == hb.size());
		for (size_t i = 0; i < ha.size(); i++)
			REQUIRE(swell_msg_equal(&ha[i], &hb[i]));
	}
	CHECK(swell_wave_checksum(&whole.c.wave) == swell_wave_checksum(&split.c.wave));
	CHECK(split.c.n.overruns == 0u);

	/* a background part that did not run before the next force part is an overrun */
	swell_ctl_tick_force(&split.c);
	swell_ctl_tick_force(&split.c);
	CHECK(split.c.n.overruns == 1u);
}

TEST_CASE("controller info: CTL_INFO at start and once a second with the firmware version and the object size, and a new size "
	  "goes out at once",
	  "[ctl][telemetry]")
{
	swell_ctl_config cfg = pool();
	cfg.fw_version[0] = 3;
	cfg.fw_version[1] = 14;
	cfg.fw_version[2] = 159;
	cfg.body.a_um = 40040; /* 400.4 x 0.1 mm: rounds down */
	cfg.body.b_um = 30050; /* 300.5: rounds up */
	cfg.body.h_um = 20000;
	Ctl k(cfg);
	std::vector<int> at;
	swell_msg_ctl_info last{};
	for (int t = 0; t < 2 * 2500 + 10; t++) {
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		for (auto &m : k.drain(SWELL_LINK_HOST))
			if (m.type == SWELL_MSG_CTL_INFO) {
				at.push_back(t);
				last = m.u.ctl_info;
			}
		k.drain(SWELL_LINK_DEVICE);
	}
	INFO("CTL_INFO sent at ticks " << (at.size() > 0 ? at[0] : -1) << ", " << (at.size() > 1 ? at[1] : -1) << ", "
				       << (at.size() > 2 ? at[2] : -1) << " (" << at.size() << " in all)");
	REQUIRE(at.size() == 3);
	CHECK(at[0] == 0); /* the first tick: a viewer that is already there learns it at once */
	CHECK(at[1] - at[0] == 2500); /* then 1 Hz at 2500 Hz ticks */
	CHECK(at[2] - at[1] == 2500);
	CHECK(last.fw_major == 3);
	CHECK(last.fw_minor == 14);
	CHECK(last.fw_patch == 159);
	CHECK(last.obj_a_100um == 400);
	CHECK(last.obj_b_100um == 301);
	CHECK(last.obj_h_100um == 200);

	/* a new height by PARAM_SET: CTL_INFO on the next tick, not a second later */
	k.param(SWELL_PARAM_BODY_H_UM, 30000);
	int seen = -1;
	for (int t = 0; t < 5 && seen < 0; t++) {
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		for (auto &m : k.drain(SWELL_LINK_HOST))
			if (m.type == SWELL_MSG_CTL_INFO && seen < 0) {
				seen = t;
				last = m.u.ctl_info;
			}
		k.drain(SWELL_LINK_DEVICE);
	}
	CHECK(seen == 0);
	CHECK(last.obj_h_100um == 300);
	/* a refused size changes nothing and sends nothing new */
	k.param(SWELL_PARAM_BODY_H_UM, 10); /* below the 1 mm minimum */
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	int infos = 0;
	for (auto &m : k.drain(SWELL_LINK_HOST))
		infos += m.type == SWELL_MSG_CTL_INFO;
	CHECK(infos == 0);
	CHECK(k.c.cfg.body.h_um == 30000u);
}

TEST_CASE("enter bootloader: refused while RUNNING, accepted otherwise with the force zeroed and a last heartbeat", "[ctl][boot]")
{
	swell_ctl_config cfg = pool();
	cfg.autorun = 1;
	Ctl k(cfg);
	for (int t = 0; t < 3000; t++) { /* the object pressed into the water: a real force */
		k.device(0, 0, -20000);
		swell_ctl_tick(&k.c);
		k.drain(SWELL_LINK_HOST);
		k.drain(SWELL_LINK_DEVICE);
	}
	REQUIRE(k.c.state == SWELL_CTL_RUNNING);
	REQUIRE(std::abs(k.c.force_dev_uN[2]) > 100000);
	swell_msg req{};
	req.type = SWELL_MSG_ENTER_BOOTLOADER;
	req.u.enter_bootloader.key = SWELL_PROTO_BOOT_KEY;
	uint32_t ignored = k.c.n.ignored;
	swell_ctl_rx(&k.c, SWELL_LINK_HOST, &req);
	CHECK(k.c.bootloader_request == 0);
	CHECK(k.c.n.ignored == ignored + 1);
	CHECK(k.drain(SWELL_LINK_HOST).empty()); /* nothing answered, nothing changed */

	k.param(SWELL_PARAM_AUTORUN, 0); /* autorun off and no RUN command: RUNNING -> ARMED */
	k.device(0, 0, -20000);
	swell_ctl_tick(&k.c);
	k.drain(SWELL_LINK_HOST);
	k.drain(SWELL_LINK_DEVICE);
	REQUIRE(k.c.state == SWELL_CTL_ARMED);
	swell_ctl_rx(&k.c, SWELL_LINK_HOST, &req);
	CHECK(k.c.bootloader_request == 1);
	std::vector<swell_msg> dev = k.drain(SWELL_LINK_DEVICE), host = k.drain(SWELL_LINK_HOST);
	REQUIRE(!dev.empty());
	CHECK(dev[0].type == SWELL_MSG_FORCE_CMD);
	CHECK(dev[0].u.force_cmd.enable == 0);
	REQUIRE(host.size() == 1);
	CHECK(host[0].type == SWELL_MSG_HEARTBEAT);
	CHECK(host[0].u.heartbeat.state == SWELL_CTL_ARMED);
	/* while the port gets ready to reboot, a RUN command must not bring the force back */
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	for (int t = 0; t < 10; t++) {
		k.device(0, 0, -20000);
		swell_ctl_tick(&k.c);
		for (auto &m : k.drain(SWELL_LINK_DEVICE))
			if (m.type == SWELL_MSG_FORCE_CMD)
				CHECK(m.u.force_cmd.enable == 0);
		k.drain(SWELL_LINK_HOST);
	}
	CHECK(k.c.state == SWELL_CTL_ARMED);
	CHECK(k.c.bootloader_request == 1);
}

/* The velocity form's heights follow the kernel one row behind and water added mid-step is seen by the
 * rest of the step (swell/wave.h), so the twin runs the core's schedule: the same rows a tick, the
 * coupling kept back and placed at the step's end. What is checked is what the core adds to it: the
 * force law reading h(n) through rows that hold h(n+1), and the ceiling scan ahead. */
TEST_CASE("the solver step spread over the period (rows one behind and scan ahead) gives the force law the same "
	  "surface as the library's calls on the same schedule, at 2500 and 1000 Hz",
	  "[ctl][split][ahead]")
{
	for (uint32_t tick_hz : {2500u, 1000u}) {
		swell_ctl_config cfg = pool();
		cfg.tick_hz = tick_hz;
		cfg.safety.tick_hz = tick_hz;
		cfg.autorun = 1;
		Ctl k(cfg);
		/* the twin: the same water and object, each step finished whole at the period's last tick */
		std::vector<int32_t> store(SWELL_WAVE_WORDS(cfg.nx, cfg.ny));
		swell_wave w{};
		swell_body b{};
		const swell_body_scene sc = {cfg.dx_um, cfg.tick_hz, cfg.solver_hz};
		REQUIRE(swell_wave_init(&w, cfg.nx, cfg.ny, store.data(), store.size(), &cfg.wave) == SWELL_OK);
		REQUIRE(swell_body_init(&b, &cfg.body, &cfg.xform, &sc, &w) == SWELL_OK);
		int ahead_ticks = 0, wet = 0;
		for (uint32_t t = 0; t < tick_hz; t++) { /* 1 s: down into the water from 20 mm above, swaying */
			const int32_t z = 20000 - (int32_t)(t * 50000 / tick_hz), x = (int32_t)(t % 7) * 300 - 900;
			k.device(x, 0, z);
			swell_ctl_tick_force(&k.c);
			const bool ran = k.c.body.ticks != b.ticks;
			if (ran) {
				int32_t pos[3] = {x / 10 * 10, 0, z / 10 * 10}, vel[3] = {0, 0, 0};
				swell_body_out o;
				swell_body_tick_force(&b, &w, pos, vel, &o);
				INFO(tick_hz << " Hz, tick " << t << ", phase " << k.c.phase << ", rows finished ahead "
					     << k.c.wave.done_row << ": surface " << k.c.out.surface_lsb << " vs "
					     << o.surface_lsb);
				REQUIRE(std::memcmp(&k.c.out, &o, sizeof(o)) == 0);
				wet += o.delta_lsb > 0;
			}
			ahead_ticks += k.c.wave.done_row > 0;
			swell_ctl_tick_background(&k.c);
			swell_body_couple_later(&b, &w);
			if (k.c.phase != 0) /* the rows the core did in this tick, whatever its share */
				swell_wave_step_rows(&w, k.c.wave.next_row - w.next_row);
			if (k.c.phase == 0) { /* the step just completed, in both */
				swell_wave_step_finish(&w);
				swell_body_place(&b, &w);
				swell_body_solver_stepped(&b, &w);
				REQUIRE(swell_wave_checksum(&w) == swell_wave_checksum(&k.c.wave));
			} else {
				swell_body_scan_ahead(&b, &w);
			}
			k.drain(SWELL_LINK_DEVICE);
			k.drain(SWELL_LINK_HOST);
		}
		CHECK(wet > (int)tick_hz / 3);
		CHECK(k.c.n.solver_steps == 250u);
		if (tick_hz == 2500u)
			CHECK(ahead_ticks > 1000);
	}
}

TEST_CASE("a force limit that is not a whole number of cN is never exceeded on the wire", "[ctl][safety]")
{
	/* the object held 100 mm above the water: the force law asks for its weight, -981000 uN */
	for (uint32_t f_max : {1u, 9999u, 15000u, 25001u, 123456u, 980999u, 10000000u}) {
		swell_ctl_config cfg = pool();
		cfg.autorun = 1;
		cfg.safety.f_max_uN = f_max;
		Ctl k(cfg);
		int running = 0, worst_cN = 0;
		for (int t = 0; t < 100; t++) {
			k.device(0, 0, 100000);
			swell_ctl_tick(&k.c);
			for (const swell_msg &m : k.drain(SWELL_LINK_DEVICE)) {
				if (m.type != SWELL_MSG_FORCE_CMD)
					continue;
				const swell_msg_force_cmd &f = m.u.force_cmd;
				for (int cN : {(int)f.fx_cN, (int)f.fy_cN, (int)f.fz_cN})
					worst_cN = std::max(worst_cN, std::abs(cN));
				running += f.enable;
			}
			for (const swell_msg &m : k.drain(SWELL_LINK_HOST))
				if (m.type == SWELL_MSG_OBJECT_FORCE)
					worst_cN = std::max(worst_cN, std::abs((int)m.u.object_force.fz_cN));
		}
		INFO("f_max " << f_max << " uN: largest force sent " << worst_cN << " cN = " << worst_cN * 10000
			      << " uN, limited output " << k.c.force_dev_uN[2] << " uN");
		REQUIRE(running > 90);
		CHECK((int64_t)worst_cN * 10000 <= (int64_t)f_max);
		/* as close as it may be: the weight to the nearest cN (98), or the whole cN within f_max */
		CHECK(worst_cN == (int)std::min<uint32_t>(98u, f_max / 10000u));
	}
}

TEST_CASE("random device traffic, parameters and commands: every force sent is zero outside RUNNING, "
	  "within f_max and within the rate step",
	  "[ctl][safety][random]")
{
	std::mt19937 rng(4242);
	auto pick = [&](int n) { return (int)(rng() % (uint32_t)n); };
	for (int run = 0; run < 6; run++) {
		swell_ctl_config cfg = pool();
		cfg.autorun = (uint8_t)(run & 1);
		Ctl k(cfg);
		int32_t prev[3] = {0, 0, 0};
		uint32_t prev_fmax = k.c.cfg.safety.f_max_uN;
		int prev_running = 0, forces = 0, running_ticks = 0;
		int32_t z = 100000, vz = 0;
		for (int t = 0; t < 4000; t++) {
			/* the device: mostly there, moving through the water and the floor, sometimes silent,
			 * sometimes e-stopped or unpowered */
			if (pick(50) != 0) {
				z = std::max(-300000, std::min(300000, z + pick(4001) - 2000));
				vz = pick(600001) - 300000;
				uint8_t status = (uint8_t)(pick(40) == 0 ? 1 | 4 : pick(60) == 0 ? 0 : 1);
				k.device(pick(400001) - 200000, pick(400001) - 200000, z, status);
				swell_msg v{};
				v.type = SWELL_MSG_DEVICE_VEL;
				v.u.device_vel.vz_100ums = (int16_t)(vz / 100);
				swell_ctl_rx(&k.c, SWELL_LINK_DEVICE, &v);
			}
			switch (pick(40)) {
			case 0:
				k.param(SWELL_PARAM_FORCE_MAX_UN, 1 + pick(3000000));
				break;
			case 1:
				k.param(SWELL_PARAM_FORCE_RATE, 2500 + pick(2000000000));
				break;
			case 2:
				k.param(SWELL_PARAM_FORCE_GAIN, pick(5 * SWELL_Q16_ONE));
				break;
			case 3:
				k.param(SWELL_PARAM_COMMAND, pick(3));
				break;
			case 4:
				k.param(SWELL_PARAM_WAVE_E, SWELL_Q30_ONE / 20 + pick(SWELL_Q30_ONE / 2));
				break;
			case 5:
				k.param(SWELL_PARAM_BODY_MASS_G, 1 + pick(2000));
				break;
			case 6:
				k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
				break;
			default:
				break;
			}
			swell_ctl_tick(&k.c);
			k.drain(SWELL_LINK_HOST);
			const int running = k.c.state == SWELL_CTL_RUNNING;
			const uint32_t fmax = k.c.cfg.safety.f_max_uN;
			const int32_t step = k.c.safety[2].step_uN;
			for (const swell_msg &m : k.drain(SWELL_LINK_DEVICE)) {
				if (m.type != SWELL_MSG_FORCE_CMD)
					continue;
				const swell_msg_force_cmd &f = m.u.force_cmd;
				forces++;
				INFO("run " << run << " tick " << t << " state " << swell_ctl_state_name(k.c.state) << " f_max "
					    << fmax << " uN: sent " << f.fx_cN << " " << f.fy_cN << " " << f.fz_cN
					    << " cN, enable " << (int)f.enable);
				REQUIRE(f.enable == running);
				if (!running)
					REQUIRE((f.fx_cN == 0 && f.fy_cN == 0 && f.fz_cN == 0));
				for (int cN : {(int)f.fx_cN, (int)f.fy_cN, (int)f.fz_cN})
					REQUIRE((int64_t)std::abs(cN) * 10000 <= (int64_t)fmax);
			}
			for (int a = 0; a < 3; a++) {
				const int32_t now = k.c.force_dev_uN[a];
				INFO("run " << run << " tick " << t << " axis " << a << ": " << prev[a] << " -> " << now
					    << " uN, step " << step << ", f_max " << prev_fmax << " -> " << fmax);
				REQUIRE(std::abs((int64_t)now) <= (int64_t)fmax);
				if (!running)
					REQUIRE(now == 0);
				else if (prev_running && fmax >= prev_fmax) /* a lowered limit cuts at once */
					REQUIRE(std::abs((int64_t)now - prev[a]) <= step);
				else if (!prev_running)
					REQUIRE(std::abs((int64_t)now) <= step); /* from zero */
				prev[a] = now;
			}
			running_ticks += running;
			prev_running = running;
			prev_fmax = fmax;
		}
		INFO("run " << run);
		CHECK(forces >= 4000);
		CHECK(running_ticks > 200);
	}
}

TEST_CASE("effect mode: force.mode changes only outside RUNNING, running no FORCE_CMD goes out and a full effect set "
	  "goes out at every solver step, a stop disables at once, the device is silent after silent_ticks updates, "
	  "and a sample once an update is counted as no loss",
	  "[ctl][effect]")
{
	Ctl k(pool());
	// FORCE_CMDs in the device queue: how many, and how many of them enabled
	auto cmds = [&k]() {
		std::pair<int, int> n{0, 0};
		for (const swell_msg &m : k.drain(SWELL_LINK_DEVICE))
			if (m.type == SWELL_MSG_FORCE_CMD) {
				n.first++;
				n.second += m.u.force_cmd.enable;
			}
		return n;
	};
	swell_ctl_tick(&k.c);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	k.drain(SWELL_LINK_DEVICE);
	CHECK(swell_ctl_silent_limit(&k.c) == 2); // stream: ticks
	k.param(SWELL_PARAM_FORCE_MODE, SWELL_FORCE_EFFECT);
	CHECK(k.c.cfg.force_mode == SWELL_FORCE_EFFECT); // armed: taken
	CHECK(swell_ctl_silent_limit(&k.c) == 20); // effect: 2 updates of 10 ticks (2500 / 250 Hz)
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	int sets = 0, forces = 0;
	swell_effect got{}, last{};
	swell_effect_rx rx{};
	uint32_t lost0 = 0;
	for (int t = 0; t < 100; t++) { // 10 solver periods, the device reporting once an update
		if (t % 10 == 0) {
			k.seq = (uint8_t)(k.seq + 9); // its seq counts device ticks
			k.device(0, 0, 100000);
			if (t == 0)
				lost0 = k.c.n.dev_lost; // the parameters above took seq numbers too
		}
		swell_ctl_tick(&k.c);
		for (const swell_msg &m : k.drain(SWELL_LINK_DEVICE)) {
			forces += m.type == SWELL_MSG_FORCE_CMD;
			if (swell_effect_recv(&rx, &m, &got) == 1) {
				sets++;
				last = got;
			}
		}
	}
	CHECK(k.c.state == SWELL_CTL_RUNNING);
	CHECK(k.c.n.dev_lost == lost0); // 9 device ticks skipped an update: not a loss
	CHECK(k.c.dev_step == 10);
	CHECK(forces == 0); // the sets are the device's keepalive
	CHECK(sets >= 10);
	CHECK(sets <= 11); // the first tick of RUNNING sends one at once
	// held 100 mm above the water: the set is gravity, the springs' origin at the surface (rest level)
	CHECK(last.bias_mN == -981);
	CHECK(last.k_10mN_m == 2453); // 1000 kg/m^3 9.81 m/s^2 50 mm 50 mm = 24.525 N/m
	CHECK(last.h_10um == 5000);
	CHECK(last.b_10mNs_m == 0); // not submerged
	CHECK(last.fmax_cN == 1000);
	CHECK(last.rate_100mN_s == 5000);
	CHECK(swell_effect_force_uN(&last, 10000, 0) == -981000);
	// telemetry shows what the effects produce here: the weight
	CHECK(k.c.force_dev_uN[2] == -981000);
	// refused while running, nothing changes
	k.param(SWELL_PARAM_FORCE_MODE, SWELL_FORCE_STREAM);
	CHECK(k.c.cfg.force_mode == SWELL_FORCE_EFFECT);
	bool refused = false;
	for (const swell_msg &m : k.drain(SWELL_LINK_HOST))
		refused |= m.type == SWELL_MSG_PARAM_NACK && m.u.param_nack.err == SWELL_ESTATE;
	CHECK(refused);
	// the port's zero force (exit) is a disabled FORCE_CMD in effect mode: the device drops its effects
	swell_ctl_zero_force(&k.c);
	CHECK(cmds() == std::make_pair(1, 0));
	// a silent device: still RUNNING 19 ticks after the tick of its last sample, FAULT on the 20th
	k.seq = (uint8_t)(k.seq + 9);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	k.drain(SWELL_LINK_DEVICE);
	for (int t = 0; t < 19; t++)
		swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_RUNNING);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_FAULT);
	CHECK(cmds() == std::make_pair(1, 0)); // the tick that left RUNNING sends a disabled FORCE_CMD
	// stop (back from the fault by a clear first): the next FORCE_CMD is disabled
	k.device(0, 0, 100000);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_CLEAR);
	swell_ctl_tick(&k.c);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_RUNNING);
	k.drain(SWELL_LINK_DEVICE);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_STOP);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_ARMED);
	CHECK(cmds() == std::make_pair(1, 0));
	k.param(SWELL_PARAM_FORCE_MODE, SWELL_FORCE_STREAM);
	CHECK(k.c.cfg.force_mode == SWELL_FORCE_STREAM);
	// a port that needs a FORCE_CMD every tick (the HapticMaster's TCP link): enabled, zero force,
	// beside the sets, and the silence limit stays in ticks
	k.c.cfg.cmd_every_tick = 1;
	k.param(SWELL_PARAM_FORCE_MODE, SWELL_FORCE_EFFECT);
	CHECK(swell_ctl_silent_limit(&k.c) == 2);
	k.param(SWELL_PARAM_COMMAND, SWELL_CMD_RUN);
	k.device(0, 0, 100000);
	swell_ctl_tick(&k.c);
	CHECK(k.c.state == SWELL_CTL_RUNNING);
	k.drain(SWELL_LINK_DEVICE);
	for (int t = 0; t < 10; t++) {
		k.device(0, 0, 100000);
		swell_ctl_tick(&k.c);
		INFO("tick " << t);
		CHECK(cmds() == std::make_pair(1, 1));
	}
}
