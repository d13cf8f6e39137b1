// The pool as a start-up choice of the image (firmware/core/src/ctl_pool.c): placement in SRAM and the fast block,
// PARAM_SET / PARAM_GET of the start-up parameters, refusals that change nothing.
#include <catch2/catch.hpp>

#include "swell_msgs.hpp"

#include <cstring>
#include <vector>

extern "C" {
#include "logic/core_run.h"
#include "swell/ctl_pool.h"
#include "swell/scene.h"
}

namespace {
// The image's blocks: a 120 KB SRAM arena and the 64 KB fast block (CCM, or QEMU's SRAM above 128 KB).
struct mem_f405 {
	std::vector<int32_t> sram = std::vector<int32_t>(30720), fast = std::vector<int32_t>(16384);
	fw_mem m{sram.data(), sram.size(), fast.data(), fast.size(), "fast"};
};

// ticks of the scripted device (logic/core_run.h) on c; returns the run's checksum
uint32_t run(swell_ctl *c, fw_core_run *r, uint32_t ticks)
{
	for (uint32_t n = 0; n < ticks; n++) {
		fw_core_device(c, r);
		swell_ctl_tick(c);
		fw_core_drain(c, r);
	}
	return fw_core_checksum(c, r);
}
} // namespace

TEST_CASE("a pool goes whole into SRAM when it fits, else u into the fast block, else it is refused", "[pool]")
{
	mem_f405 f;
	fw_pool_at p{};

	REQUIRE(fw_pool_place(64, 64, &f.m, &p) == SWELL_OK);
	CHECK(p.apart == 0);
	CHECK(p.sram_words == swell_ctl_arena_words(64, 64));
	CHECK(p.fast_words == 0);
	REQUIRE(fw_pool_place(110, 110, &f.m, &p) == SWELL_OK); // h, u, flags, samples, stale bits: 30400 words
	CHECK(p.apart == 0);
	CHECK(p.sram_words == swell_ctl_arena_words(110, 110));
	REQUIRE(fw_pool_place(111, 111, &f.m, &p) == SWELL_OK); // 30802 words whole: u goes apart
	CHECK(p.apart == 1);
	REQUIRE(fw_pool_place(128, 128, &f.m, &p) == SWELL_OK);
	CHECK(p.apart == 1);
	// h, the tile flags, the sent samples, the stale bits: 99072 bytes of the 122880
	CHECK(p.sram_words == 128 * 128 + (16 * 16 + 3) / 4 + 128 * 128 / 2 + (16 * 16 + 1) / 2);
	CHECK(p.fast_words == 128 * 128); // u alone: the whole 64 KB
	const fw_pool_at before = p;
	CHECK(fw_pool_place(128, 136, &f.m, &p) == SWELL_ESIZE); // u: 17408 words > 16384
	CHECK(fw_pool_place(136, 136, &f.m, &p) == SWELL_ESIZE);
	CHECK(std::memcmp(&p, &before, sizeof(p)) == 0);
	fw_mem no_fast = f.m;
	no_fast.fast = nullptr;
	no_fast.fast_words = 0;
	CHECK(fw_pool_place(111, 111, &no_fast, &p) == SWELL_ESIZE);
	CHECK(fw_pool_place(110, 110, &no_fast, &p) == SWELL_OK);
}

TEST_CASE("a start-up parameter set on the wire restarts the core with the new pool, and one that does not fit is "
	  "refused with its reason and changes nothing",
	  "[pool]")
{
	mem_f405 f;
	static swell_ctl c;
	fw_core_run r;
	fw_pool_at p{};
	swell_msg ans{};

	REQUIRE(fw_core_init(&c, &r, f.sram.data(), f.sram.size(), 2500) == SWELL_OK);
	c.cfg.wave.damping = 5000; // a parameter set before: kept by the restart

	swell_msg m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_PARAM_WAVE_DAMPING, 1, 42);
	CHECK(fw_pool_param(&c, &f.m, &m, &ans, &p) == 0); // the core's own parameter
	CHECK_FALSE(fw_pool_is_startup(&m));

	m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_SCENE_NX, 128, 42);
	REQUIRE(fw_pool_param(&c, &f.m, &m, &ans, &p) == 1);
	REQUIRE(ans.type == SWELL_MSG_PARAM_ACK);
	CHECK(ans.u.param_ack.id == SWELL_SCENE_NX);
	CHECK(ans.u.param_ack.value == 128);
	CHECK(ans.u.param_ack.seq == 42);
	CHECK(c.cfg.nx == 128);
	CHECK(c.cfg.ny == 64);
	CHECK(c.cfg.wave.damping == 5000);
	CHECK(c.state == SWELL_CTL_BOOT);
	CHECK(p.apart == 0); // 128 x 64 fits SRAM whole

	const swell_ctl_config cfg = c.cfg;
	const fw_pool_at place = p;
	m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_SCENE_NY, 136, 42); // u: 17408 words > 16384
	REQUIRE(fw_pool_param(&c, &f.m, &m, &ans, &p) == 1);
	REQUIRE(ans.type == SWELL_MSG_PARAM_NACK);
	CHECK(ans.u.param_nack.err == SWELL_ESIZE);
	CHECK(ans.u.param_nack.seq == 42);
	m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_SCENE_NY, 300, 42); // beyond the wire's 256 cells
	REQUIRE(fw_pool_param(&c, &f.m, &m, &ans, &p) == 1);
	CHECK(ans.u.param_nack.err == SWELL_ESIZE);
	m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_SCENE_DEPTH_UM, 0, 42);
	REQUIRE(fw_pool_param(&c, &f.m, &m, &ans, &p) == 1);
	CHECK(ans.u.param_nack.err == SWELL_ERANGE);
	m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_SCENE_DX_UM, 1000,
				  42); // eq. 2: e = 7.67 at 1 mm cells, beyond the stability limit
	REQUIRE(fw_pool_param(&c, &f.m, &m, &ans, &p) == 1);
	REQUIRE(ans.type == SWELL_MSG_PARAM_NACK);
	CHECK(ans.u.param_nack.err != SWELL_OK);
	CHECK(std::memcmp(&c.cfg, &cfg, sizeof(cfg)) == 0);
	CHECK(std::memcmp(&p, &place, sizeof(p)) == 0);

	m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_SCENE_DX_UM, 12500,
				  42); // e follows eq. 2: a quarter of the reference pool's
	REQUIRE(fw_pool_param(&c, &f.m, &m, &ans, &p) == 1);
	REQUIRE(ans.type == SWELL_MSG_PARAM_ACK);
	q30_t e = 0;
	REQUIRE(swell_wave_e_from_physical(9810, 4000, 50000, 12500, &e) == SWELL_OK);
	CHECK(c.cfg.wave.e == e);
	CHECK(c.cfg.dx_um == 12500);

	swell_msg get{};
	get.type = SWELL_MSG_PARAM_GET;
	get.u.param_get.id = SWELL_SCENE_NX;
	get.u.param_get.seq = 9;
	REQUIRE(fw_pool_param(&c, &f.m, &get, &ans, &p) == 1);
	REQUIRE(ans.type == SWELL_MSG_PARAM_ACK);
	CHECK(ans.u.param_ack.value == 128);
	CHECK(ans.u.param_ack.seq == 9);

	run(&c, &r, 600); // autorun: the object reaches the water, the force law runs
	REQUIRE(c.state == SWELL_CTL_RUNNING);
	const uint32_t wave = swell_wave_checksum(&c.wave);
	m = swell_test::param_msg(SWELL_MSG_PARAM_SET, SWELL_SCENE_NX, 64, 42);
	REQUIRE(fw_pool_param(&c, &f.m, &m, &ans, &p) == 1);
	CHECK(ans.u.param_nack.err == SWELL_ESTATE);
	CHECK(c.cfg.nx == 128);
	CHECK(c.state == SWELL_CTL_RUNNING);
	CHECK(swell_wave_checksum(&c.wave) == wave);
}

TEST_CASE("the core with u in a block apart gives the same bits as in one arena", "[pool]")
{
	static swell_ctl one, apart;
	std::vector<int32_t> arena(swell_ctl_arena_words(88, 88)), sram(swell_ctl_arena_words_apart(88, 88)),
		fast(swell_ctl_apart_words(88, 88));
	fw_core_run r1, r2;

	REQUIRE(fw_core_init(&one, &r1, arena.data(), arena.size(), 2500) == SWELL_OK);
	swell_ctl_config cfg = one.cfg;
	cfg.nx = cfg.ny = 88;
	REQUIRE(swell_ctl_init(&one, &cfg, arena.data(), arena.size()) == SWELL_OK);
	CHECK(swell_ctl_init_apart(&apart, &cfg, sram.data(), sram.size() - 1, fast.data(), fast.size()) == SWELL_ESIZE);
	CHECK(swell_ctl_init_apart(&apart, &cfg, sram.data(), sram.size(), fast.data(), fast.size() - 1) == SWELL_ESIZE);
	REQUIRE(swell_ctl_init_apart(&apart, &cfg, sram.data(), sram.size(), fast.data(), fast.size()) == SWELL_OK);
	CHECK(apart.wave.u == fast.data());
	r2 = r1;
	const uint32_t a = run(&one, &r1, 1500), b = run(&apart, &r2, 1500);
	CHECK(a == b);
	CHECK(r1.force_cmds == r2.force_cmds);
	CHECK(r1.last_fz_uN == r2.last_fz_uN);
	CHECK(r1.last_fz_uN != 0); // the object is in the water
	auto moving = [&] {
		size_t k = 0;
		for (size_t i = 0; i < 88u * 88u; i++)
			k += fast[i] != 0;
		return k;
	};
	CHECK(moving() > 0);
	swell_wave_rest(&apart.wave); // the water at rest: u apart is cleared too
	CHECK(moving() == 0);
}
