// View model: late join, loss, reordering, restart, link loss, and that only changed tiles are dirty.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

extern "C" {
#include "vm.h"
#include "swell/pool.h"
#include "swell/wave.h"
}

namespace {

const uint64_t S = 1000000; // one second in us

view_scene pool64()
{
	view_scene s{};
	s.nx = SWELL_POOL_N;
	s.ny = 48;
	s.dx_um = SWELL_POOL_DX_UM;
	s.depth_um = SWELL_POOL_DEPTH_UM;
	s.tile_w = 16;
	s.tile_h = 16;
	return s;
}

std::vector<int32_t> tile_of(int32_t v, size_t n) { return std::vector<int32_t>(n, v); }

// A whole tile, row by row, as the decoder would deliver it from stream position pos.
swell_err put_tile(view_model &m, uint16_t tx, uint16_t ty, uint32_t pos, const std::vector<int32_t> &t, uint16_t w = 16,
		   uint16_t h = 16)
{
	for (uint16_t r = 0; r < h; r++) {
		swell_err e = vm_cells(&m, tx, ty, 0, r, w, pos, &t[size_t(r) * w]);
		if (e != SWELL_OK)
			return e;
	}
	return SWELL_OK;
}

uint32_t dirty_tiles(const view_model &m)
{
	uint32_t n = 0;
	for (uint16_t ty = 0; ty < m.tiles_y; ty++)
		for (uint16_t tx = 0; tx < m.tiles_x; tx++)
			n += vm_tile_dirty(&m, tx, ty);
	return n;
}

void clean_all(view_model &m)
{
	for (uint16_t ty = 0; ty < m.tiles_y; ty++)
		for (uint16_t tx = 0; tx < m.tiles_x; tx++)
			vm_tile_clean(&m, tx, ty);
}

// a view model (stale after 1 s), freed at the end; Pool: with the 64 x 48 scene held
struct Model {
	view_model m;
	Model() { vm_init(&m, S); }
	~Model() { vm_free(&m); }
};
struct Pool : Model {
	view_scene s = pool64();
	Pool() { REQUIRE(vm_scene(&m, &s, 0) == SWELL_OK); }
};

} // namespace

TEST_CASE("late join: tiles and poses before the scene description are counted and dropped")
{
	view_model m;
	vm_init(&m, S / 2);
	vm_tick(&m, 0);
	CHECK(m.status == VIEW_LINK_DOWN);
	vm_link(&m, true, 10);
	CHECK(m.status == VIEW_WAIT_SCENE);
	auto t = tile_of(SWELL_H_ONE_MM, 256);
	CHECK(put_tile(m, 0, 0, 5, t) == SWELL_ESTATE);
	view_object o{};
	o.valid = true;
	CHECK(vm_object(&m, &o) == SWELL_ESTATE);
	CHECK(m.st.ignored == 2);
	view_scene s = pool64();
	REQUIRE(vm_scene(&m, &s, 20) == SWELL_OK);
	vm_frame(&m, 0, 16, 20);
	vm_tick(&m, 20);
	CHECK(m.status == VIEW_LIVE);
	CHECK(m.tiles_x == 4);
	CHECK(m.tiles_y == 3);
	// the flat surface is shown at once: every tile starts dirty
	CHECK(dirty_tiles(m) == 12);
	CHECK(m.dirty_count == 12);
	vm_free(&m);
}

TEST_CASE_METHOD(Pool, "a tile lands in its cells in mm and marks only its own tile dirty")
{
	clean_all(m);
	CHECK(m.dirty_count == 0);
	std::vector<int32_t> t(256);
	for (int k = 0; k < 256; k++)
		t[k] = k * SWELL_H_ONE_MM / 4; // k/4 mm
	REQUIRE(put_tile(m, 2, 1, 7, t) == SWELL_OK);
	CHECK(dirty_tiles(m) == 1);
	CHECK(vm_tile_dirty(&m, 2, 1));
	// cell (i, j) = (32 + c, 16 + r) holds tile sample r * 16 + c
	CHECK(m.h_mm[16 * 64 + 32] == Approx(0.0));
	CHECK(m.h_mm[(16 + 3) * 64 + 32 + 5] == Approx((3 * 16 + 5) / 4.0));
	CHECK(m.h_mm[(16 + 15) * 64 + 47] == Approx(255 / 4.0));
	CHECK(m.h_mm[(16 + 15) * 64 + 48] == Approx(0.0)); // neighbour tile untouched
	// the same heights again (a periodic refresh) leave the tile clean: nothing to upload
	vm_tile_clean(&m, 2, 1);
	REQUIRE(put_tile(m, 2, 1, 8, t) == SWELL_OK);
	CHECK(m.dirty_count == 0);
	t[37] += 1;
	REQUIRE(put_tile(m, 2, 1, 9, t) == SWELL_OK);
	CHECK(m.dirty_count == 1);
	// edge tiles are clipped: 48 rows of 16-row tiles fit, 64 columns too, so use a 50 x 40 grid
	vm_free(&m);
	vm_init(&m, S);
	s.nx = 50;
	s.ny = 40;
	REQUIRE(vm_scene(&m, &s, 0) == SWELL_OK);
	uint16_t i0, j0, w, h;
	vm_tile_rect(&m, 3, 2, &i0, &j0, &w, &h);
	CHECK(i0 == 48);
	CHECK(j0 == 32);
	CHECK(w == 2);
	CHECK(h == 8);
	CHECK(vm_cells(&m, 3, 2, 0, 0, 3, 1, t.data()) == SWELL_ERANGE); // past the grid's edge
	CHECK(vm_cells(&m, 3, 2, 0, 8, 2, 1, t.data()) == SWELL_ERANGE); // row past the edge
	CHECK(vm_cells(&m, 3, 2, 0, 7, 2, 1, t.data()) == SWELL_OK);
	CHECK(vm_cells(&m, 4, 0, 0, 0, 1, 1, t.data()) == SWELL_ERANGE); // outside the grid
	CHECK(vm_cells(&m, 0, 0, 15, 0, 2, 1, t.data()) == SWELL_ERANGE); // past the tile
	CHECK(vm_cells(&m, 0, 0, 0, 0, 2, 0, t.data()) == SWELL_ERANGE); // position 0 is "none"
	CHECK(m.st.cells == 2);
}

TEST_CASE_METHOD(Pool, "reordering: heights from an older stream position never overwrite newer ones")
{
	auto newer = tile_of(2 * SWELL_H_ONE_MM, 256), older = tile_of(-SWELL_H_ONE_MM, 256);
	REQUIRE(put_tile(m, 0, 0, 100, newer) == SWELL_OK);
	CHECK(put_tile(m, 0, 0, 99, older) == SWELL_ESTATE);
	CHECK(m.h_mm[0] == Approx(2.0));
	CHECK(m.st.late == 1);
	// per cell: a late piece still fills cells nothing newer has touched
	int32_t one[4] = {SWELL_H_ONE_MM, SWELL_H_ONE_MM, SWELL_H_ONE_MM, SWELL_H_ONE_MM};
	int32_t five[4] = {5 * SWELL_H_ONE_MM, 5 * SWELL_H_ONE_MM, 5 * SWELL_H_ONE_MM, 5 * SWELL_H_ONE_MM};
	REQUIRE(vm_cells(&m, 1, 0, 2, 0, 2, 200, five) == SWELL_OK); // cells 18, 19 at position 200
	REQUIRE(vm_cells(&m, 1, 0, 0, 0, 4, 199, one) == SWELL_OK); // 16..19 from the older 199
	CHECK(m.h_mm[16] == Approx(1.0));
	CHECK(m.h_mm[17] == Approx(1.0));
	CHECK(m.h_mm[18] == Approx(5.0));
	CHECK(m.h_mm[19] == Approx(5.0));
	CHECK(m.st.late == 2);
	// positions compare modulo 2^32
	REQUIRE(put_tile(m, 2, 0, 0xfffffff0u, newer) == SWELL_OK);
	CHECK(put_tile(m, 2, 0, 0x10u, older) == SWELL_OK);
}

TEST_CASE_METHOD(Model, "sequence gaps count dropped frames, modulo the sequence width, a late frame is no longer lost")
{
	CHECK(vm_frame(&m, 65530, 16, 1));
	CHECK(vm_frame(&m, 65531, 16, 2));
	CHECK(vm_frame(&m, 2, 16, 3)); // 65532..65535, 0, 1 missing
	CHECK(m.st.dropped == 6);
	CHECK_FALSE(vm_frame(&m, 65535, 16, 4)); // one of them arriving late: not lost after all
	CHECK(m.st.late == 1);
	CHECK(m.st.dropped == 5);
	CHECK(vm_frame(&m, 3, 16, 5));
	// a jump of more than the loss window forward is one resynchronisation, not 39996 lost
	CHECK(vm_frame(&m, 40000, 16, 6));
	CHECK(m.st.dropped == 5);
	CHECK(m.st.resyncs == 1);
	CHECK(m.st.frames == 6);
	// 8-bit sequences: gaps up to 32 are losses, a jump beyond (89, 40, 209 ahead) one resync each,
	// wrapping or not, and the stream goes on from there
	view_model k;
	vm_init(&k, S);
	CHECK(vm_frame(&k, 125, 8, 1));
	CHECK(vm_frame(&k, 150, 8, 2)); // 24 lost
	CHECK(vm_frame(&k, 215, 8, 2)); // 64 ahead
	CHECK(vm_frame(&k, 216, 8, 3));
	CHECK(vm_frame(&k, 1, 8, 4)); // 40 ahead, wrapping
	CHECK(vm_frame(&k, 211, 8, 5)); // 209 ahead, not 46 behind
	CHECK(vm_frame(&k, 212, 8, 6));
	CHECK(k.st.late == 0);
	CHECK(k.st.dropped == 24);
	CHECK(k.st.resyncs == 3);
	// a sender that starts counting again from far back: after a few late ones, one resync
	for (uint32_t q = 190; q < 200; q++)
		vm_frame(&k, q, 8, 7);
	CHECK(k.st.late == 7);
	CHECK(k.st.resyncs == 4);
	CHECK(vm_frame(&k, 200, 8, 8));
	vm_free(&k);
}

TEST_CASE_METHOD(Model, "controller restart clears the heights and waits for the scene again")
{
	vm_link(&m, true, 0);
	view_scene s = pool64();
	REQUIRE(vm_scene(&m, &s, 0) == SWELL_OK);
	auto t = tile_of(SWELL_H_ONE_MM, 256);
	REQUIRE(put_tile(m, 0, 0, 1, t) == SWELL_OK);
	vm_heartbeat(&m, "running", 0, 3, 1);
	vm_restart(&m, 30);
	vm_heartbeat(&m, "boot", 0, 0, 0);
	vm_frame(&m, 0, 8, 30);
	vm_tick(&m, 30);
	CHECK(m.st.restarts == 1);
	CHECK_FALSE(m.have_scene);
	CHECK(m.status == VIEW_RESTARTED);
	CHECK(std::string(m.ctrl_state) == "boot");
	CHECK(put_tile(m, 0, 0, 2, t) == SWELL_ESTATE);
	REQUIRE(vm_scene(&m, &s, 40) == SWELL_OK);
	vm_tick(&m, 40);
	CHECK(m.status == VIEW_LIVE);
	CHECK(m.h_mm[0] == 0.0f); // the old heights are gone
}

TEST_CASE_METHOD(Pool, "a different scene description restarts, the same one repeated changes nothing")
{
	auto t = tile_of(SWELL_H_ONE_MM, 256);
	REQUIRE(put_tile(m, 0, 0, 1, t) == SWELL_OK);
	REQUIRE(vm_scene(&m, &s, 1) == SWELL_OK);
	CHECK(m.h_mm[0] == Approx(1.0));
	CHECK(m.st.restarts == 0);
	s.scene_id = 9;
	REQUIRE(vm_scene(&m, &s, 2) == SWELL_OK);
	CHECK(m.st.restarts == 1);
	CHECK(m.h_mm[0] == 0.0f);
	CHECK(m.scene.scene_id == 9);
}

TEST_CASE_METHOD(Pool, "a scene out of range is refused and the held scene stays")
{
	view_scene bad[5] = {s, s, s, s, s};
	bad[0].nx = 1;
	bad[1].ny = VIEW_MAX_SIDE + 1;
	bad[2].dx_um = 0;
	bad[3].tile_w = 0;
	bad[4].tile_h = VIEW_MAX_TILE + 1;
	for (auto &b : bad)
		CHECK(vm_scene(&m, &b, 1) == SWELL_ERANGE);
	CHECK(m.scene.nx == 64);
	CHECK(m.scene.ny == 48);
	CHECK(m.st.restarts == 0);
}

TEST_CASE("silence makes the data stale, link down wins, replug starts a new sequence")
{
	view_model m;
	vm_init(&m, S / 2);
	vm_link(&m, true, 0);
	view_scene s = pool64();
	REQUIRE(vm_scene(&m, &s, 0) == SWELL_OK);
	vm_frame(&m, 10, 16, 0);
	vm_tick(&m, S / 2);
	CHECK(m.status == VIEW_LIVE);
	vm_tick(&m, S / 2 + 1);
	CHECK(m.status == VIEW_STALE);
	vm_link(&m, false, S);
	CHECK(m.status == VIEW_LINK_DOWN);
	CHECK(m.st.link_drops == 1);
	vm_link(&m, true, 2 * S);
	vm_frame(&m, 500, 16, 2 * S);
	CHECK(m.st.dropped == 0);
	vm_tick(&m, 2 * S);
	CHECK(m.status == VIEW_LIVE);
	vm_free(&m);
}

TEST_CASE_METHOD(Model, "frame and tile rates are counted over one second")
{
	vm_tick(&m, 0);
	view_scene s = pool64();
	REQUIRE(vm_scene(&m, &s, 0) == SWELL_OK);
	auto t = tile_of(0, 256);
	for (uint32_t k = 0; k < 250; k++) {
		vm_frame(&m, k, 16, k * 4000);
		put_tile(m, uint16_t(k % 4), 0, k + 1, t); // 16 rows: 16 pieces
		put_tile(m, uint16_t(k % 4), 1, k + 1, t);
	}
	vm_tick(&m, S);
	CHECK(m.st.frame_hz == Approx(250.0));
	CHECK(m.st.piece_hz == Approx(250.0 * 32));
}

TEST_CASE_METHOD(Model, "latency estimate is the delay above the best path seen, and follows clock drift")
{
	vm_clock(&m, 1000, 6000); // offset 5000 us
	vm_clock(&m, 2000, 6500); // offset 4500 us: new best
	CHECK(m.st.latency_valid);
	for (int k = 0; k < 200; k++)
		vm_clock(&m, 10000 + k * 1000, 10000 + k * 1000 + 4500 + 2000); // 2 ms above best
	CHECK(m.st.latency_ms == Approx(2.0).epsilon(0.01));
	// the host clock runs 100 ppm fast for 60 s (6 ms), samples 1 ms above the best path: the
	// estimate must forget the old best (within two 2 s windows: at most 0.4 ms of drift) rather
	// than report the drift as latency
	uint64_t c = 1000000, r = c + 4500;
	for (int k = 0; k < 6000; k++) {
		c += 10000;
		r += 10001;
		vm_clock(&m, c, r + 1000);
		if (k % 10 == 0)
			vm_clock(&m, c, r); // a sample on the best path now and then
	}
	INFO("latency estimate " << m.st.latency_ms << " ms");
	CHECK(m.st.latency_ms < 1.45);
	CHECK(m.st.latency_ms > 0.95);
}

TEST_CASE_METHOD(Model, "two interleaved 8-bit counts (two senders) are resynchronisations, never more lost than received")
{
	uint8_t a = 0, b = 128;
	for (int k = 0; k < 1000; k++) {
		vm_frame(&m, a++, 8, (uint64_t)k);
		vm_frame(&m, b++, 8, (uint64_t)k);
	}
	INFO("frames " << m.st.frames << ", dropped " << m.st.dropped << ", late " << m.st.late << ", resyncs " << m.st.resyncs);
	CHECK(m.st.dropped <= m.st.frames);
	CHECK(m.st.dropped == 0);
	CHECK(m.st.resyncs >= 1000);
}
