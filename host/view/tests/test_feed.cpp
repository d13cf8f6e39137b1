// Decoder side: frames made by the common/ encoders land in the view model where they belong, on every
// carrier; rejected frames are counted and change nothing.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

extern "C" {
#include "feed.h"
#include "replay_drain.h"
#include "swell/link.h"
#include "swell/pool.h"
#include "swell/proto.h"
#include "swell/wave.h"
}

namespace {

swell_msg scene_msg(uint8_t id = 1)
{
	swell_msg m;
	memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_SCENE;
	m.u.scene.nx = 20; // not a multiple of the 8-cell tile: edge tiles are partial
	m.u.scene.ny = 12;
	m.u.scene.h_shift = SWELL_PROTO_H_SHIFT;
	m.u.scene.dx_um = SWELL_POOL_DX_UM;
	m.u.scene.depth_10um = 5000;
	m.u.scene.scene_id = id;
	return m;
}

swell_msg quad(uint8_t tx, uint8_t ty, uint8_t row, uint8_t half, int16_t h0, int16_t h1, int16_t h2, int16_t h3)
{
	swell_msg m;
	memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_HEIGHT_QUAD;
	auto &q = m.u.height_quad;
	q.tile_x = tx;
	q.tile_y = ty;
	q.row = row;
	q.half = half;
	q.h0 = h0;
	q.h1 = h1;
	q.h2 = h2;
	q.h3 = h3;
	return m;
}

swell_msg heartbeat(uint8_t state, uint8_t seq)
{
	swell_msg m;
	memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_HEARTBEAT;
	m.u.heartbeat.state = state;
	m.u.heartbeat.version = SWELL_PROTO_VERSION;
	m.u.heartbeat.seq = seq;
	m.u.heartbeat.overruns = 7;
	return m;
}

struct rig {
	view_model vm;
	view_feed f;
	uint8_t seq = 0;
	rig(uint8_t node = FEED_NODE_ANY)
	{
		vm_init(&vm, 1000000);
		feed_init(&f, &vm, node);
	}
	~rig() { vm_free(&vm); }
	void pkt(const std::vector<swell_msg> &m, uint8_t node = 0, uint64_t t = 1000)
	{
		size_t at = 0;
		while (at < m.size()) {
			uint8_t p[SWELL_PKT_MAX];
			size_t len = 0, used = 0;
			REQUIRE(swell_pkt_encode(node, seq++, m.data() + at, m.size() - at, p, sizeof(p), &len, &used) ==
				SWELL_OK);
			feed_packet(&f, p, len, t);
			at += used;
		}
	}
	void can(const swell_msg &m, uint64_t t = 1000)
	{
		uint32_t id;
		uint8_t d[8], len;
		REQUIRE(swell_can_encode(&m, &id, d, &len) == SWELL_OK);
		feed_can(&f, id, d, len, false, t);
	}
	float h(int i, int j) const { return vm.h_mm[j * vm.scene.nx + i]; }
};

} // namespace

TEST_CASE("packets: a scene, then quads land in their cells in mm (1/64 mm a sample)")
{
	rig r;
	r.pkt({quad(0, 0, 0, 0, 64, 64, 64, 64)}); // before the scene: ignored
	CHECK(r.vm.st.ignored == 1);
	r.pkt({scene_msg()});
	REQUIRE(r.vm.have_scene);
	CHECK(r.vm.scene.nx == 20);
	CHECK(r.vm.scene.depth_um == 50000);
	CHECK(r.vm.tiles_x == 3);
	CHECK(r.vm.tiles_y == 2);
	// tile (1, 1), row 2, right half: cells x = 12..15, y = 10
	r.pkt({quad(1, 1, 2, 1, 64, -32, 1, 2047)});
	CHECK(r.h(12, 10) == Approx(1.0));
	CHECK(r.h(13, 10) == Approx(-0.5));
	CHECK(r.h(14, 10) == Approx(1.0 / 64));
	CHECK(r.h(15, 10) == Approx(2047.0 / 64));
	CHECK(r.h(11, 10) == 0.0f);
	// the partial edge tile (2, 0): cells 16..19 exist, the right half (20..23) does not
	r.pkt({quad(2, 0, 0, 0, 64, 64, 64, 64), quad(2, 0, 0, 1, 64, 64, 64, 64)});
	CHECK(r.h(19, 0) == Approx(1.0));
	CHECK(r.vm.st.pieces == 2);
	// a row below the grid's last row (y = 12) in tile (0, 1): nothing to show, no harm
	r.pkt({quad(0, 1, 5, 0, 64, 64, 64, 64)});
	CHECK(r.vm.st.pieces == 2);
	// a tile outside this scene: decodable, but wrong here
	uint32_t bad = r.vm.st.bad;
	r.pkt({quad(5, 0, 0, 0, 1, 1, 1, 1)});
	CHECK(r.vm.st.bad == bad + 1);
}

TEST_CASE("packets: pose, force and heartbeat fill the object and the controller state")
{
	rig r;
	r.pkt({scene_msg(), heartbeat(3, 0)});
	swell_msg p, f;
	memset(&p, 0, sizeof(p));
	memset(&f, 0, sizeof(f));
	p.type = SWELL_MSG_OBJECT_POSE;
	p.u.object_pose.x_10um = 12000;
	p.u.object_pose.y_10um = -500;
	p.u.object_pose.z_10um = -1234;
	p.u.object_pose.submersion_halfpct = 101;
	p.u.object_pose.seq = 5;
	f.type = SWELL_MSG_OBJECT_FORCE;
	f.u.object_force.fx_cN = -250;
	f.u.object_force.fz_cN = 981;
	f.u.object_force.seq = 5;
	r.pkt({p, f});
	REQUIRE(r.vm.obj.valid);
	CHECK(r.vm.obj.x_um == 120000);
	CHECK(r.vm.obj.y_um == -5000);
	CHECK(r.vm.obj.z_um == -12340);
	CHECK(r.vm.obj.fx_cN == -250);
	CHECK(r.vm.obj.fz_cN == 981);
	CHECK(r.f.submersion_halfpct == 101);
	CHECK(std::string(r.vm.ctrl_state) == "RUNNING");
	CHECK(r.vm.ctrl_overruns == 7);
	// an older pose (reordered) does not move the object back; a force of another pose is ignored
	p.u.object_pose.seq = 4;
	p.u.object_pose.x_10um = 1;
	f.u.object_force.seq = 4;
	f.u.object_force.fx_cN = 1;
	r.pkt({p, f});
	CHECK(r.vm.obj.x_um == 120000);
	CHECK(r.vm.obj.fx_cN == -250);
}

TEST_CASE("CTL_INFO: the object size and firmware version come from the controller, the fallback only before it")
{
	rig r;
	r.f.obj_a_um = r.f.obj_b_um = r.f.obj_h_um = 30000; // the viewer's --object 30x30x30
	swell_msg p, info;
	memset(&p, 0, sizeof(p));
	memset(&info, 0, sizeof(info));
	p.type = SWELL_MSG_OBJECT_POSE;
	p.u.object_pose.seq = 1;
	info.type = SWELL_MSG_CTL_INFO;
	info.u.ctl_info.fw_major = 4;
	info.u.ctl_info.fw_minor = 0;
	info.u.ctl_info.fw_patch = 12;
	info.u.ctl_info.obj_a_100um = 1234; // 123.4 mm
	info.u.ctl_info.obj_b_100um = 55; // 5.5 mm
	info.u.ctl_info.obj_h_100um = 8191; // 819.1 mm, the largest the wire carries
	r.pkt({scene_msg(), p});
	REQUIRE(r.vm.obj.valid);
	CHECK(r.vm.obj.a_um == 30000u); // nothing from the controller yet: the fallback
	CHECK_FALSE(r.vm.have_info);
	CHECK_FALSE(r.f.obj_from_wire);
	r.pkt({info});
	CHECK(r.vm.have_info);
	CHECK(r.f.obj_from_wire);
	CHECK(r.vm.fw_version[0] == 4);
	CHECK(r.vm.fw_version[1] == 0);
	CHECK(r.vm.fw_version[2] == 12);
	CHECK(r.vm.obj.a_um == 123400u); // at once, without waiting for the next pose
	CHECK(r.vm.obj.b_um == 5500u);
	CHECK(r.vm.obj.h_um == 819100u);
	p.u.object_pose.seq = 2;
	r.pkt({p});
	CHECK(r.vm.obj.a_um == 123400u); // and the next pose keeps it
	CHECK(r.vm.obj.h_um == 819100u);
	// the same CTL_INFO on classic CAN
	rig c;
	c.can(scene_msg());
	c.can(info);
	CHECK(c.vm.have_info);
	CHECK(c.vm.obj.b_um == 5500u);
}

TEST_CASE("heartbeat back in BOOT is a controller restart")
{
	rig r;
	r.pkt({scene_msg(), heartbeat(3, 0), quad(0, 0, 0, 0, 64, 64, 64, 64)});
	REQUIRE(r.h(0, 0) == Approx(1.0));
	r.pkt({heartbeat(0, 0)});
	CHECK(r.vm.st.restarts == 1);
	CHECK_FALSE(r.vm.have_scene);
	r.pkt({scene_msg(2)});
	REQUIRE(r.vm.have_scene);
	CHECK(r.h(0, 0) == 0.0f);
}

TEST_CASE("rejected packets are counted by reason and change nothing")
{
	rig r;
	r.pkt({scene_msg()});
	uint8_t p[SWELL_PKT_MAX];
	size_t len = 0, used = 0;
	swell_msg q = quad(0, 0, 0, 0, 64, 64, 64, 64);
	REQUIRE(swell_pkt_encode(0, 9, &q, 1, p, sizeof(p), &len, &used) == SWELL_OK);
	p[len - 1] ^= 0x40; // CRC
	feed_packet(&r.f, p, len, 1);
	feed_packet(&r.f, p, 3, 1); // truncated
	uint8_t junk[17] = {1, 2, 3};
	feed_packet(&r.f, junk, sizeof(junk), 1);
	CHECK(r.vm.st.bad == 3);
	CHECK(swell_proto_rejected_total(&r.f.st) == 3);
	CHECK(r.f.st.rejected[SWELL_ECRC] == 1);
	CHECK(r.h(0, 0) == 0.0f);
	CHECK(r.vm.st.pieces == 0);
}

TEST_CASE("a node filter shows one controller of several")
{
	rig r(3);
	r.pkt({scene_msg()}, 2);
	CHECK_FALSE(r.vm.have_scene);
	CHECK(r.f.other_node == 1);
	r.pkt({scene_msg()}, 3);
	CHECK(r.vm.have_scene);
}

TEST_CASE("classic CAN: the same messages, arrival order, loss counted on the pose sequence")
{
	rig r;
	r.can(scene_msg());
	REQUIRE(r.vm.have_scene);
	r.can(quad(1, 0, 3, 0, -64, 0, 0, 128));
	CHECK(r.h(8, 3) == Approx(-1.0));
	CHECK(r.h(11, 3) == Approx(2.0));
	swell_msg p;
	memset(&p, 0, sizeof(p));
	p.type = SWELL_MSG_OBJECT_POSE;
	for (uint8_t s : {10, 11, 14}) { // 12 and 13 lost
		p.u.object_pose.seq = s;
		r.can(p);
	}
	CHECK(r.vm.st.dropped == 2);
	CHECK(r.vm.st.frames == 5);
	// a frame the decoder refuses: unknown type
	uint8_t d[8] = {0};
	feed_can(&r.f, SWELL_CAN_ID(0x7f, 0), d, 8, false, 1);
	CHECK(r.vm.st.bad == 1);
}

TEST_CASE("100 000 random packets and CAN frames: nothing crashes, packets change no height")
{
	rig r;
	r.pkt({scene_msg()});
	uint32_t s = 2024;
	auto rnd = [&s] {
		s ^= s << 13;
		s ^= s >> 17;
		s ^= s << 5;
		return s;
	};
	uint8_t buf[80];
	for (int k = 0; k < 50000; k++) {
		size_t len = rnd() % sizeof(buf);
		for (size_t i = 0; i < len; i++)
			buf[i] = uint8_t(rnd());
		if (k % 2 && len > 4) { // a plausible header: the right magic and version
			buf[0] = SWELL_PKT_MAGIC;
			buf[1] = SWELL_PROTO_VERSION;
		}
		feed_packet(&r.f, buf, len, 1000 + k);
	}
	size_t changed = 0;
	for (int j = 0; j < r.vm.scene.ny; j++)
		for (int i = 0; i < r.vm.scene.nx; i++)
			changed += r.h(i, j) != 0.0f;
	CHECK(changed == 0);
	CHECK(r.vm.st.bad == 50000);
	// CAN has no CRC of its own here: random frames may decode; only the bounds are at stake (ASan)
	for (int k = 0; k < 50000; k++) {
		size_t len = rnd() % 65;
		for (size_t i = 0; i < len; i++)
			buf[i] = uint8_t(rnd());
		feed_can(&r.f, rnd() & 0x7ff, buf, len, k % 3 == 0, 2000 + k);
	}
	// whatever decoded, the model stays consistent: the dirty count matches the dirty flags
	uint32_t dirty = 0;
	for (uint16_t ty = 0; ty < r.vm.tiles_y; ty++)
		for (uint16_t tx = 0; tx < r.vm.tiles_x; tx++)
			dirty += vm_tile_dirty(&r.vm, tx, ty);
	CHECK(dirty == r.vm.dirty_count);
	CHECK(r.vm.st.bad + r.vm.st.frames >= 50001);
}

TEST_CASE("classic CAN: a pose count that starts again is taken after 8 stale poses and is not counted as loss")
{
	rig r;
	r.can(scene_msg());
	REQUIRE(r.vm.have_scene);
	swell_msg p;
	memset(&p, 0, sizeof(p));
	p.type = SWELL_MSG_OBJECT_POSE;
	p.u.object_pose.seq = 100;
	r.can(p);
	// the sender counts again from 100 (a repeat 8 times), then from 0 (behind by 100)
	for (int k = 0; k < 8; k++)
		r.can(p);
	INFO("dropped after 8 repeats of one sequence number: " << r.vm.st.dropped);
	CHECK(r.vm.st.dropped == 0);
	for (uint8_t s = 0; s < 8; s++) {
		p.u.object_pose.seq = s;
		p.u.object_pose.x_10um = (int16_t)(1000 + s);
		r.can(p);
	}
	INFO("dropped after a count that went back: " << r.vm.st.dropped);
	CHECK(r.vm.st.dropped == 0);
	CHECK(r.vm.obj.x_um == 10070); // the 8th older pose is taken: the new count
	p.u.object_pose.seq = 10; // 8 and 9 lost in the new count
	r.can(p);
	CHECK(r.vm.st.dropped == 2);
}

TEST_CASE("a replay's latency comes from the recording's own receive times, not from when the display read it")
{
	// A recording (the link's file format: "SWELLREC", version 1, the packet carrier; then per frame
	// u64 ns, u32 id, u16 length, u8 flags, u8 0, the bytes) of 55 heartbeats 100 ms apart, the
	// last 25 received 50 ms late: the link slowed down while it was recorded.
	const std::string path = std::string(SWELL_VIEW_TEST_DIR) + "/latency.rec";
	FILE *out = fopen(path.c_str(), "wb");
	REQUIRE(out);
	auto le = [&](uint64_t v, int n) {
		for (int i = 0; i < n; i++)
			fputc(int((v >> (8 * i)) & 0xff), out);
	};
	fwrite("SWELLREC", 1, 8, out);
	le(1, 4);
	le(SWELL_CARRIER_PKT, 4);
	for (int k = 0; k < 55; k++) {
		swell_msg hb = heartbeat(3, uint8_t(k));
		uint8_t p[SWELL_PKT_MAX];
		size_t len = 0, used = 0;
		REQUIRE(swell_pkt_encode(0, uint8_t(k), &hb, 1, p, sizeof(p), &len, &used) == SWELL_OK);
		le(uint64_t(k) * 100000000u + (k >= 30 ? 50000000u : 0u), 8);
		le(0, 4);
		le(len, 2);
		le(0, 2);
		fwrite(p, 1, len, out);
	}
	REQUIRE(fclose(out) == 0);

	view_model vm;
	vm_init(&vm, 1000000);
	view_feed f;
	feed_init(&f, &vm, FEED_NODE_ANY);
	char err[160] = "";
	// the display reads it all in one go, 1 s after it started: its own clock says nothing
	const uint32_t n = replay_drain(("replay-fast:" + path).c_str(), &f, 1000000u, err, sizeof(err));
	INFO(err << "frames " << n << ", latency valid " << vm.st.latency_valid << ", " << vm.st.latency_ms << " ms");
	CHECK(n == 55);
	REQUIRE(vm.st.latency_valid);
	CHECK(f.rec_clock);
	// 25 samples 50 ms over the best, smoothed by 1/20 a sample: 50 (1 - 0.95^25) = 36.1 ms
	CHECK(vm.st.latency_ms == Approx(50.0 * (1.0 - std::pow(0.95, 25))).margin(0.5));
	vm_free(&vm);
	remove(path.c_str());
}
