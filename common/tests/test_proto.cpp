#include <catch2/catch.hpp>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <random>
#include <set>
#include <string>
#include <vector>

extern "C" {
#include "swell/crc.h"
#include "swell/proto.h"
}

#include "swell_msgs.hpp"

namespace {

/* A message of descriptor d with every field drawn uniformly from its valid range. */
swell_msg random_msg(const swell_msg_desc &d, std::mt19937_64 &rng, uint8_t node)
{
	swell_msg m;
	std::memset(&m, 0, sizeof(m));
	m.type = d.type;
	m.node = node;
	for (unsigned i = 0; i < d.nfields; i++) {
		std::uniform_int_distribution<int64_t> pick(d.fields[i].min, d.fields[i].max);
		REQUIRE(swell_msg_field_set(&m, &d.fields[i], pick(rng)) == SWELL_OK);
	}
	return m;
}

/* Every field at its minimum (which = 0) or maximum (which = 1). */
swell_msg extreme_msg(const swell_msg_desc &d, int which)
{
	swell_msg m;
	std::memset(&m, 0, sizeof(m));
	m.type = d.type;
	for (unsigned i = 0; i < d.nfields; i++)
		REQUIRE(swell_msg_field_set(&m, &d.fields[i], which ? d.fields[i].max : d.fields[i].min) == SWELL_OK);
	return m;
}

std::vector<swell_msg> sample_msgs(std::mt19937_64 &rng, uint8_t node)
{
	std::vector<swell_msg> v;
	for (unsigned t = 0; t < swell_msg_desc_count; t++) {
		const swell_msg_desc &d = swell_msg_descs[t];
		swell_msg lo = extreme_msg(d, 0), hi = extreme_msg(d, 1);
		lo.node = hi.node = node;
		v.push_back(lo);
		v.push_back(hi);
		for (int k = 0; k < 50; k++)
			v.push_back(random_msg(d, rng, node));
	}
	return v;
}

std::string describe(const swell_msg &m)
{
	const swell_msg_desc *d = swell_msg_desc_find(m.type);
	std::string s = d ? d->name : "?";
	s += " node " + std::to_string(m.node);
	for (unsigned i = 0; d && i < d->nfields; i++)
		s += std::string(" ") + d->fields[i].name + "=" + std::to_string(swell_msg_field_get(&m, &d->fields[i]));
	return s;
}

} // namespace

TEST_CASE("message table: fields lie inside the payload, never overlap, ranges fit their width", "[proto]")
{
	std::set<unsigned> types;
	unsigned prev_type = 0;
	for (unsigned t = 0; t < swell_msg_desc_count; t++) {
		const swell_msg_desc &d = swell_msg_descs[t];
		INFO(d.name);
		CHECK(types.insert(d.type).second);
		CHECK(d.type > prev_type); /* listed in priority order: lower type = lower CAN id */
		prev_type = d.type;
		CHECK(d.len >= SWELL_MSG_LEN_MIN);
		CHECK(d.len <= SWELL_CAN_LEN);
		uint64_t used = 0;
		for (unsigned i = 0; i < d.nfields; i++) {
			const swell_field_desc &f = d.fields[i];
			INFO(f.name << " start " << int(f.start) << " bits " << int(f.bits));
			CHECK(int(f.start) + int(f.bits) <= 8 * int(d.len));
			uint64_t mask = ((f.bits == 64) ? ~0ull : ((1ull << f.bits) - 1)) << f.start;
			CHECK((used & mask) == 0);
			used |= mask;
			CHECK(f.min <= f.max);
			if (f.min < 0) {
				CHECK(f.min >= -(int64_t(1) << (f.bits - 1)));
				CHECK(f.max < (int64_t(1) << (f.bits - 1)));
			} else {
				CHECK(f.max < (int64_t(1) << f.bits));
			}
			CHECK(int(f.size) * 8 >= int(f.bits));
		}
	}
	CHECK(swell_msg_desc_find(0) == nullptr);
	CHECK(swell_msg_desc_find(0x7F) == nullptr);
}

TEST_CASE("every message round-trips on classic CAN, bit-exact both ways", "[proto]")
{
	std::mt19937_64 rng(1);
	for (uint8_t node : {uint8_t(0), uint8_t(7), uint8_t(15)}) {
		for (const swell_msg &m : sample_msgs(rng, node)) {
			uint32_t id = 0;
			uint8_t data[8], len = 0;
			INFO(describe(m));
			REQUIRE(swell_can_encode(&m, &id, data, &len) == SWELL_OK);
			CHECK(id == SWELL_CAN_ID(m.type, node));
			CHECK(id <= 0x7FFu);
			swell_msg back;
			std::memset(&back, 0xAB, sizeof(back));
			swell_proto_stats st = {};
			REQUIRE(swell_can_decode(id, data, len, &back, &st) == SWELL_OK);
			CHECK(swell_msg_equal(&m, &back));
			CHECK(st.ok == 1u);
			uint32_t id2;
			uint8_t data2[8], len2;
			REQUIRE(swell_can_encode(&back, &id2, data2, &len2) == SWELL_OK);
			CHECK(id2 == id);
			CHECK(len2 == len);
			CHECK(std::memcmp(data, data2, len) == 0);
		}
	}
}

TEST_CASE("CTL_INFO: the layout of docs/protocol.md byte for byte, sizes outside 0.1 .. 819.1 mm refused", "[proto]")
{
	/* version 1.2.3, object 50.0 x 50.1 x 819.1 mm: 1 | 2 << 8 | 3 << 16 | 500 << 24 | 501 << 37 |
	 * 8191 << 50, little-endian (worked out by hand from the table, not by this codec) */
	const uint8_t want[8] = {0x01, 0x02, 0x03, 0xf4, 0xa1, 0x3e, 0xfc, 0x7f};
	swell_msg m;
	std::memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_CTL_INFO;
	m.node = 5;
	m.u.ctl_info.fw_major = 1;
	m.u.ctl_info.fw_minor = 2;
	m.u.ctl_info.fw_patch = 3;
	m.u.ctl_info.obj_a_100um = 500;
	m.u.ctl_info.obj_b_100um = 501;
	m.u.ctl_info.obj_h_100um = 8191;
	uint32_t id = 0;
	uint8_t data[8] = {0}, len = 0;
	REQUIRE(swell_can_encode(&m, &id, data, &len) == SWELL_OK);
	CHECK(id == 0x235u); /* type 0x23 << 4 | node 5: after OBJECT_FORCE, before the heights */
	CHECK(len == 8);
	for (int k = 0; k < 8; k++) {
		INFO("byte " << k);
		CHECK(data[k] == want[k]);
	}
	swell_msg back;
	REQUIRE(swell_can_decode(id, data, len, &back, nullptr) == SWELL_OK);
	CHECK(swell_msg_equal(&m, &back));
	/* a size of 0 (the bits a zeroed frame has) is refused on both sides */
	m.u.ctl_info.obj_b_100um = 0;
	CHECK(swell_can_encode(&m, &id, data, &len) == SWELL_ERANGE);
	uint8_t zero_b[8];
	std::memcpy(zero_b, want, 8);
	zero_b[4] &= 0x1f; /* obj_b is bits 37..49: clear 37..39 ... */
	zero_b[5] = 0; /* ... 40..47 ... */
	zero_b[6] &= 0xfc; /* ... and 48..49 */
	swell_proto_stats st = {};
	std::memset(&back, 0xAB, sizeof(back));
	swell_msg before = back;
	CHECK(swell_can_decode(id, zero_b, 8, &back, &st) == SWELL_ERANGE);
	CHECK(std::memcmp(&back, &before, sizeof(back)) == 0);
	CHECK(st.rejected[SWELL_ERANGE] == 1u);
}

TEST_CASE("every message round-trips on CAN FD, batched up to 64 bytes per frame", "[proto]")
{
	std::mt19937_64 rng(2);
	for (unsigned t = 0; t < swell_msg_desc_count; t++) {
		const swell_msg_desc &d = swell_msg_descs[t];
		INFO(d.name);
		std::vector<swell_msg> in;
		for (int k = 0; k < 100; k++)
			in.push_back(random_msg(d, rng, 3));
		std::vector<swell_msg> out;
		size_t pos = 0, frames = 0;
		while (pos < in.size()) {
			uint32_t id;
			uint8_t data[64], len;
			size_t used = 0;
			REQUIRE(swell_canfd_encode(&in[pos], in.size() - pos, &id, data, &len, &used) == SWELL_OK);
			REQUIRE(used >= 1);
			CHECK(swell_canfd_len_valid(len));
			CHECK(len == used * ((d.len + 3u) & ~3u));
			swell_msg got[SWELL_CANFD_MSGS_MAX];
			size_t n = 0;
			REQUIRE(swell_canfd_decode(id, data, len, got, SWELL_CANFD_MSGS_MAX, &n, nullptr) == SWELL_OK);
			CHECK(n == used);
			out.insert(out.end(), got, got + n);
			pos += used;
			frames++;
		}
		REQUIRE(out.size() == in.size());
		for (size_t i = 0; i < in.size(); i++) {
			INFO(describe(in[i]));
			CHECK(swell_msg_equal(&in[i], &out[i]));
		}
		/* 64 bytes hold 8 slots of 8 bytes or 16 of 4: ceil(100 / per frame) frames */
		size_t per = 64 / ((d.len + 3u) & ~3u);
		CHECK(frames == (100 + per - 1) / per);
	}
}

TEST_CASE("every message round-trips in USB/UDP packets of at most 64 bytes with CRC", "[proto]")
{
	std::mt19937_64 rng(3);
	std::vector<swell_msg> in = sample_msgs(rng, 5);
	std::shuffle(in.begin(), in.end(), rng);
	std::vector<swell_msg> out;
	size_t pos = 0;
	uint8_t seq = 250;
	swell_seq track = {};
	while (pos < in.size()) {
		uint8_t pkt[SWELL_PKT_MAX];
		size_t len = 0, used = 0;
		REQUIRE(swell_pkt_encode(5, seq, &in[pos], in.size() - pos, pkt, sizeof(pkt), &len, &used) == SWELL_OK);
		CHECK(len <= SWELL_PKT_MAX);
		swell_msg got[SWELL_PKT_MSGS_MAX];
		size_t n = 0;
		uint8_t rseq = 0;
		REQUIRE(swell_pkt_decode(pkt, len, got, SWELL_PKT_MSGS_MAX, &n, &rseq, nullptr) == SWELL_OK);
		CHECK(n == used);
		CHECK(rseq == seq);
		CHECK(swell_seq_track(&track, rseq) == 0u);
		out.insert(out.end(), got, got + n);
		pos += used;
		seq++;
	}
	CHECK(track.lost == 0u);
	REQUIRE(out.size() == in.size());
	for (size_t i = 0; i < in.size(); i++) {
		INFO(describe(in[i]));
		CHECK(swell_msg_equal(&in[i], &out[i]));
	}
}

TEST_CASE("encoders refuse out-of-range fields and bad nodes and write nothing", "[proto]")
{
	for (unsigned t = 0; t < swell_msg_desc_count; t++) {
		const swell_msg_desc &d = swell_msg_descs[t];
		for (unsigned i = 0; i < d.nfields; i++) {
			const swell_field_desc &f = d.fields[i];
			swell_msg m = extreme_msg(d, 1);
			/* store max + 1 raw, bypassing field_set, if the C type can hold it */
			int64_t bad = f.max + 1;
			int64_t limit = f.min < 0 ? (int64_t(1) << (8 * f.size - 1)) - 1 : (int64_t(1) << (8 * f.size)) - 1;
			if (f.size == 4 && f.min >= 0)
				limit = UINT32_MAX;
			if (bad > limit)
				continue;
			uint8_t *p = reinterpret_cast<uint8_t *>(&m) + f.offset;
			uint32_t w = uint32_t(bad);
			std::memcpy(p, &w, f.size); /* little-endian host */
			INFO(d.name << "." << f.name << " = " << bad);
			CHECK(swell_msg_field_get(&m, &f) == bad);
			uint32_t id = 0x55;
			uint8_t data[8];
			std::memset(data, 0xEE, sizeof(data));
			uint8_t len = 0x77;
			CHECK(swell_can_encode(&m, &id, data, &len) == SWELL_ERANGE);
			CHECK(id == 0x55u);
			CHECK(len == 0x77);
			for (uint8_t b : data)
				CHECK(b == 0xEE);
		}
		swell_msg m = extreme_msg(d, 0);
		m.node = 16;
		uint32_t id;
		uint8_t data[8], len;
		CHECK(swell_can_encode(&m, &id, data, &len) == SWELL_ERANGE);
	}
}

namespace {

struct can_case {
	const char *what;
	uint32_t id;
	std::vector<uint8_t> data;
	swell_err want;
};

std::vector<uint8_t> can_bytes(const swell_msg &m)
{
	uint32_t id;
	uint8_t data[8], len;
	REQUIRE(swell_can_encode(&m, &id, data, &len) == SWELL_OK);
	return std::vector<uint8_t>(data, data + len);
}

swell_msg zero_msg(uint8_t type)
{
	swell_msg m;
	std::memset(&m, 0, sizeof(m));
	m.type = type;
	const swell_msg_desc *d = swell_msg_desc_find(type);
	for (unsigned i = 0; i < d->nfields; i++)
		REQUIRE(swell_msg_field_set(&m, &d->fields[i], d->fields[i].min > 0 ? d->fields[i].min : 0) == SWELL_OK);
	return m;
}

std::vector<uint8_t> make_pkt(const std::vector<swell_msg> &msgs)
{
	uint8_t pkt[SWELL_PKT_MAX];
	size_t len, used;
	REQUIRE(swell_pkt_encode(1, 9, msgs.data(), msgs.size(), pkt, sizeof(pkt), &len, &used) == SWELL_OK);
	REQUIRE(used == msgs.size());
	return std::vector<uint8_t>(pkt, pkt + len);
}

void fix_crc(std::vector<uint8_t> &p)
{
	uint32_t crc = swell_crc32(0, p.data(), p.size() - 4);
	for (int i = 0; i < 4; i++)
		p[p.size() - 4 + i] = uint8_t(crc >> (8 * i));
}

} // namespace

TEST_CASE("malformed CAN frames are rejected with the expected counted reason and change nothing", "[proto]")
{
	const std::vector<uint8_t> fc = can_bytes(zero_msg(SWELL_MSG_FORCE_CMD));
	const std::vector<uint8_t> hb = can_bytes(zero_msg(SWELL_MSG_HEARTBEAT));
	auto with = [](std::vector<uint8_t> v, size_t i, uint8_t b) {
		v[i] = b;
		return v;
	};
	auto cut = [](std::vector<uint8_t> v, size_t n) {
		v.resize(n);
		return v;
	};
	auto grow = [](std::vector<uint8_t> v) {
		v.push_back(0);
		return v;
	};
	std::vector<uint8_t> pv = can_bytes(zero_msg(SWELL_MSG_DEVICE_VEL));
	const std::vector<can_case> cases = {
		{"force command one byte short", SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0), cut(fc, 7), SWELL_ETRUNC},
		{"force command empty", SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0), {}, SWELL_ETRUNC},
		{"7-byte message sent as 8 bytes", SWELL_CAN_ID(SWELL_MSG_DEVICE_VEL, 0), grow(pv), SWELL_ESIZE},
		{"more than 8 bytes on classic CAN", SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0), grow(fc), SWELL_ESIZE},
		{"unknown type 0x09", SWELL_CAN_ID(0x09, 0), fc, SWELL_EUNKNOWN},
		{"reserved type 0", SWELL_CAN_ID(0, 0), fc, SWELL_EUNKNOWN},
		{"29-bit identifier", 0x1234567u, fc, SWELL_EUNKNOWN},
		{"heartbeat of protocol version 2", SWELL_CAN_ID(SWELL_MSG_HEARTBEAT, 0), with(hb, 2, 2), SWELL_EVERSION},
		{"heartbeat of protocol version 0", SWELL_CAN_ID(SWELL_MSG_HEARTBEAT, 0), with(hb, 2, 0), SWELL_EVERSION},
		/* fx = 25001 cN = 0x61A9 */
		{"force command fx 250.01 N", SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0), with(with(fc, 0, 0xA9), 1, 0x61),
		 SWELL_ERANGE},
		/* fz = -25001 cN = 0x9E57 */
		{"force command fz -250.01 N", SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0), with(with(fc, 4, 0x57), 5, 0x9E),
		 SWELL_ERANGE},
		{"force command reserved bit 57 set", SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0), with(fc, 7, 0x02), SWELL_ERANGE},
		{"heartbeat state 5", SWELL_CAN_ID(SWELL_MSG_HEARTBEAT, 0), with(hb, 0, 5), SWELL_ERANGE},
		{"heartbeat error code past the last", SWELL_CAN_ID(SWELL_MSG_HEARTBEAT, 0), with(hb, 1, SWELL_ERR_COUNT),
		 SWELL_ERANGE},
		{"bootloader without its key",
		 SWELL_CAN_ID(SWELL_MSG_ENTER_BOOTLOADER, 0),
		 {0x53, 0x57, 0x42, 0x4D},
		 SWELL_ERANGE},
		{"scene of 0 columns", SWELL_CAN_ID(SWELL_MSG_SCENE, 0), with(can_bytes(zero_msg(SWELL_MSG_SCENE)), 0, 0),
		 SWELL_ERANGE},
		{"parameter nack with error 0", SWELL_CAN_ID(SWELL_MSG_PARAM_NACK, 0), {1, 0, 0, 0}, SWELL_ERANGE},
	};
	swell_proto_stats st = {};
	uint32_t expected[SWELL_ERR_COUNT] = {};
	for (const can_case &c : cases) {
		INFO(c.what << ": want " << swell_err_str(c.want));
		swell_msg out, before;
		std::memset(&out, 0x5A, sizeof(out));
		before = out;
		swell_err got = swell_can_decode(c.id, c.data.data(), c.data.size(), &out, &st);
		CHECK(std::string(swell_err_str(got)) == swell_err_str(c.want));
		CHECK(std::memcmp(&out, &before, sizeof(out)) == 0);
		expected[c.want]++;
	}
	CHECK(st.ok == 0u);
	for (unsigned e = 0; e < SWELL_ERR_COUNT; e++) {
		INFO("reason " << swell_err_str(swell_err(e)));
		CHECK(st.rejected[e] == expected[e]);
	}
	CHECK(swell_proto_rejected_total(&st) == cases.size());
	/* and the untouched originals decode */
	swell_msg out;
	CHECK(swell_can_decode(SWELL_CAN_ID(SWELL_MSG_FORCE_CMD, 0), fc.data(), fc.size(), &out, &st) == SWELL_OK);
	CHECK(swell_can_decode(SWELL_CAN_ID(SWELL_MSG_HEARTBEAT, 0), hb.data(), hb.size(), &out, &st) == SWELL_OK);
	CHECK(st.ok == 2u);
}

TEST_CASE("malformed packets and CAN FD frames are rejected with the expected counted reason", "[proto]")
{
	const std::vector<uint8_t> good = make_pkt({zero_msg(SWELL_MSG_FORCE_CMD), zero_msg(SWELL_MSG_PARAM_GET)});
	/* layout: 5 header, 1+8 force, 1+3 get, 4 crc = 22 */
	REQUIRE(good.size() == 22);
	auto edit = [](std::vector<uint8_t> p, size_t i, uint8_t b, bool crc) {
		p[i] = b;
		if (crc)
			fix_crc(p);
		return p;
	};
	std::vector<uint8_t> longer = good;
	longer.insert(longer.end() - 4, 0x00);
	fix_crc(longer);
	std::vector<uint8_t> shorter = good;
	shorter.erase(shorter.end() - 5);
	fix_crc(shorter);
	std::vector<uint8_t> oversize(65, 0);
	struct pcase {
		const char *what;
		std::vector<uint8_t> p;
		swell_err want;
	};
	const std::vector<pcase> cases = {
		{"shorter than header + CRC", std::vector<uint8_t>(good.begin(), good.begin() + 8), SWELL_ETRUNC},
		{"longer than 64 bytes", oversize, SWELL_ESIZE},
		{"wrong magic", edit(good, 0, 0x58, true), SWELL_EUNKNOWN},
		{"one payload bit flipped", edit(good, 7, good[7] ^ 0x10, false), SWELL_ECRC},
		{"CRC byte changed", edit(good, 21, good[21] ^ 1, false), SWELL_ECRC},
		{"version 2 (CRC valid)", edit(good, 1, 2, true), SWELL_EVERSION},
		{"node 16", edit(good, 2, 16, true), SWELL_ERANGE},
		{"count 0", edit(good, 4, 0, true), SWELL_ESIZE},
		{"count 3 with 2 records", edit(good, 4, 3, true), SWELL_ETRUNC},
		{"count 1 with 2 records", edit(good, 4, 1, true), SWELL_ESIZE},
		{"last record one byte short", shorter, SWELL_ETRUNC},
		{"a byte after the last record", longer, SWELL_ESIZE},
		{"unknown record type", edit(good, 14, 0x7E, true), SWELL_EUNKNOWN},
		{"record force out of range (fx high byte 0x7F)", edit(good, 7, 0x7F, true), SWELL_ERANGE},
	};
	swell_proto_stats st = {};
	for (const pcase &c : cases) {
		INFO(c.what << ": want " << swell_err_str(c.want));
		swell_msg out[SWELL_PKT_MSGS_MAX];
		std::memset(out, 0x5A, sizeof(out));
		size_t n = 99;
		uint8_t seq = 77;
		swell_err got = swell_pkt_decode(c.p.data(), c.p.size(), out, SWELL_PKT_MSGS_MAX, &n, &seq, &st);
		CHECK(std::string(swell_err_str(got)) == swell_err_str(c.want));
		CHECK(n == 99u);
		CHECK(seq == 77);
		for (const swell_msg &m : out)
			CHECK(m.type == 0x5A);
	}
	CHECK(swell_proto_rejected_total(&st) == cases.size());
	CHECK(st.ok == 0u);

	/* a decoder given too little room refuses rather than overflowing */
	swell_msg one[1];
	size_t n;
	uint8_t seq;
	CHECK(swell_pkt_decode(good.data(), good.size(), one, 1, &n, &seq, nullptr) == SWELL_ESIZE);

	/* CAN FD */
	std::vector<swell_msg> four(4, zero_msg(SWELL_MSG_DEVICE_POS));
	uint32_t id;
	uint8_t data[64], len;
	size_t used;
	REQUIRE(swell_canfd_encode(four.data(), 4, &id, data, &len, &used) == SWELL_OK);
	REQUIRE(len == 32);
	swell_msg got[SWELL_CANFD_MSGS_MAX];
	CHECK(swell_canfd_decode(id, data, 40, got, SWELL_CANFD_MSGS_MAX, &n, nullptr) == SWELL_ESIZE); /* not an FD length */
	CHECK(swell_canfd_decode(id, data, 65, got, SWELL_CANFD_MSGS_MAX, &n, nullptr) == SWELL_ESIZE);
	CHECK(swell_canfd_decode(id, data, 7, got, SWELL_CANFD_MSGS_MAX, &n, nullptr) == SWELL_ETRUNC);
	CHECK(swell_canfd_decode(id, data, 32, got, 3, &n, nullptr) == SWELL_ESIZE);
	data[25] = 0x80; /* 4th message: y = -32768+ .. out of range */
	CHECK(swell_canfd_decode(id, data, 32, got, SWELL_CANFD_MSGS_MAX, &n, nullptr) == SWELL_ERANGE);
	data[25] = 0;
	data[31] = 0x10; /* reserved bits of the 4th slot */
	CHECK(swell_canfd_decode(id, data, 32, got, SWELL_CANFD_MSGS_MAX, &n, nullptr) == SWELL_ERANGE);
	/* 7-byte messages take 8-byte slots: 5 of them go as 4 (32 bytes), 40 is no FD length */
	std::vector<swell_msg> vel(5, zero_msg(SWELL_MSG_DEVICE_VEL));
	REQUIRE(swell_canfd_encode(vel.data(), 5, &id, data, &len, &used) == SWELL_OK);
	CHECK(used == 4);
	CHECK(len == 32);
	data[7] = 1; /* padding byte of the first slot */
	CHECK(swell_canfd_decode(id, data, 32, got, SWELL_CANFD_MSGS_MAX, &n, nullptr) == SWELL_ERANGE);
}

TEST_CASE("sequence tracking counts lost and repeated numbers across the 8-bit wrap", "[proto]")
{
	swell_seq t = {};
	CHECK(swell_seq_track(&t, 254) == 0u);
	CHECK(swell_seq_track(&t, 255) == 0u);
	CHECK(swell_seq_track(&t, 2) == 2u); /* 0 and 1 lost */
	CHECK(swell_seq_track(&t, 2) == 0u); /* duplicate */
	CHECK(swell_seq_track(&t, 1) == 0u); /* late */
	CHECK(swell_seq_track(&t, 3) == 0u);
	CHECK(t.received == 6u);
	CHECK(t.lost == 2u);
	CHECK(t.repeated == 2u);
}

TEST_CASE("a sequence jump beyond the window is one resynchronisation, never hundreds lost", "[proto]")
{
	swell_seq t = {};
	for (unsigned k = 0; k < 10; k++)
		CHECK(swell_seq_track(&t, uint8_t(k)) == 0u);
	CHECK(swell_seq_track(&t, 10 + SWELL_SEQ_WINDOW) == SWELL_SEQ_WINDOW); /* the widest gap still lost */
	CHECK(swell_seq_track(&t, 200) == 0u); /* 157 ahead: another sender, or a count started over */
	CHECK(swell_seq_track(&t, 201) == 0u);
	CHECK(swell_seq_track(&t, 120) == 0u); /* 81 behind: a restart, taken as the new reference */
	CHECK(swell_seq_track(&t, 121) == 0u);
	CHECK(swell_seq_track(&t, 119) == 0u); /* 2 behind: late */
	INFO("lost " << t.lost << ", repeated " << t.repeated << ", resyncs " << t.resyncs);
	CHECK(t.lost == SWELL_SEQ_WINDOW);
	CHECK(t.resyncs == 2u);
	CHECK(t.repeated == 1u);
	CHECK(swell_seq_loss(SWELL_SEQ_WINDOW + 1u, &t.resyncs) == 0u);
	CHECK(t.resyncs == 3u);
}

TEST_CASE("a count started again a little behind is one resynchronisation after a run of late ones", "[proto]")
{
	swell_seq t = {};
	for (unsigned k = 0; k < 20; k++)
		swell_seq_track(&t, uint8_t(k));
	/* the sender restarts at 0: 0..6 look late (repeated), the 8th older one in a row is a restart */
	for (unsigned k = 0; k < SWELL_SEQ_BACK_RUN; k++)
		CHECK(swell_seq_track(&t, uint8_t(k)) == 0u);
	CHECK(t.repeated == SWELL_SEQ_BACK_RUN - 1u);
	CHECK(t.resyncs == 1u);
	CHECK(swell_seq_track(&t, SWELL_SEQ_BACK_RUN) == 0u); /* and it goes on from there without loss */
	CHECK(t.lost == 0u);
}

TEST_CASE("the window's edges hold across the 8-bit wrap: 32 missing are lost, 33 are one resync", "[proto]")
{
	/* forward from 250: 33 ahead (27) stands for the 32 in between lost; 34 ahead (28) for a count
	 * that started elsewhere, never 33 lost */
	swell_seq t = {};
	swell_seq_track(&t, 250);
	CHECK(swell_seq_track(&t, uint8_t(250 + SWELL_SEQ_WINDOW + 1u)) == SWELL_SEQ_WINDOW);
	CHECK(t.lost == SWELL_SEQ_WINDOW);
	CHECK(t.resyncs == 0u);
	swell_seq u = {};
	swell_seq_track(&u, 250);
	CHECK(swell_seq_track(&u, uint8_t(250 + SWELL_SEQ_WINDOW + 2u)) == 0u);
	CHECK(u.lost == 0u);
	CHECK(u.resyncs == 1u);
	CHECK(u.last == uint8_t(250 + SWELL_SEQ_WINDOW + 2u)); /* the new reference */
	CHECK(swell_seq_track(&u, uint8_t(250 + SWELL_SEQ_WINDOW + 3u)) == 0u); /* goes on from there */
	CHECK(u.lost == 0u);
	/* backward from 5: 32 behind (229) is late, 33 behind (228) is a restart */
	swell_seq b = {};
	swell_seq_track(&b, 5);
	CHECK(swell_seq_track(&b, uint8_t(5 - SWELL_SEQ_WINDOW)) == 0u);
	CHECK(b.repeated == 1u);
	CHECK(b.resyncs == 0u);
	CHECK(b.last == 5u);
	CHECK(swell_seq_track(&b, uint8_t(5 - SWELL_SEQ_WINDOW - 1u)) == 0u);
	CHECK(b.repeated == 1u);
	CHECK(b.resyncs == 1u);
	CHECK(b.last == uint8_t(5 - SWELL_SEQ_WINDOW - 1u));
	CHECK(b.lost == 0u);
}

TEST_CASE("heights go to the wire rounded to nearest 1/64 mm and saturate at -32 / +31.98 mm", "[proto]")
{
	/* every solver value in a band around zero and at the edges: error <= half a wire LSB */
	const int32_t lsb = 1 << (16 - SWELL_PROTO_H_SHIFT);
	int32_t worst = 0;
	for (int64_t h = -2049LL * lsb; h <= 2048LL * lsb; h += 37) {
		int16_t s = swell_height_to_sample(int32_t(h));
		REQUIRE(s >= -2048);
		REQUIRE(s <= 2047);
		int64_t back = swell_sample_to_height(s);
		if (h >= -2048LL * lsb && h <= 2047LL * lsb) {
			int64_t e = back - h;
			INFO("h = " << h << " sample " << s << " back " << back);
			REQUIRE(e <= lsb / 2);
			REQUIRE(e > -lsb / 2 - 1);
			worst = std::max<int32_t>(worst, int32_t(e < 0 ? -e : e));
		}
	}
	CHECK(worst <= lsb / 2);
	CHECK(swell_height_to_sample(INT32_MAX) == 2047);
	CHECK(swell_height_to_sample(INT32_MIN) == -2048);
	CHECK(swell_height_to_sample(lsb / 2) == 1); /* tie goes up */
	CHECK(swell_height_to_sample(-lsb / 2) == 0); /* tie goes up */
	CHECK(swell_height_to_sample(-lsb / 2 - 1) == -1);
}

TEST_CASE("a grid of any size 1..256 survives tiles of quads on the wire within half an LSB", "[proto]")
{
	std::mt19937_64 rng(11);
	const int32_t lsb = 1 << (16 - SWELL_PROTO_H_SHIFT);
	for (auto dims : {std::pair<unsigned, unsigned>{1, 1}, {20, 13}, {64, 64}, {256, 256}, {9, 256}}) {
		unsigned nx = dims.first, ny = dims.second;
		std::uniform_int_distribution<int32_t> pick(-2048 * lsb, 2047 * lsb);
		std::vector<int32_t> h(size_t(nx) * ny), back(size_t(nx) * ny, INT32_MIN);
		for (int32_t &v : h)
			v = pick(rng);
		const unsigned tiles_x = SWELL_TILES(nx), quads = tiles_x * SWELL_TILES(ny) * SWELL_QUADS_PER_TILE;
		for (unsigned n = 0; n < quads; n++) {
			const swell_quad_at at = swell_quad_locate(n, tiles_x);
			int16_t s[4] = {0, 0, 0, 0};
			for (unsigned k = 0; k < 4; k++)
				if (at.y < ny && at.x0 + k < nx)
					s[k] = swell_height_to_sample(h[(size_t)at.y * nx + at.x0 + k]);
			swell_msg q = swell_height_quad(&at, n, s);
			uint32_t id;
			uint8_t data[8], len;
			REQUIRE(swell_can_encode(&q, &id, data, &len) == SWELL_OK);
			swell_msg got;
			REQUIRE(swell_can_decode(id, data, len, &got, nullptr) == SWELL_OK);
			REQUIRE(got.type == SWELL_MSG_HEIGHT_QUAD);
			swell_test::quad_to_grid(got.u.height_quad, back.data(), nx, ny);
		}
		int64_t worst = 0;
		for (size_t k = 0; k < h.size(); k++) {
			REQUIRE(back[k] != INT32_MIN); /* every cell was covered */
			worst = std::max<int64_t>(worst, std::llabs(int64_t(back[k]) - h[k]));
		}
		INFO(nx << " x " << ny << ": worst error " << worst << " LSB 2^-16 mm");
		CHECK(worst <= lsb / 2);
	}
}
