// Pure logic of the bxCAN driver: bit timing, acceptance filters, transmit mailbox choice.
#include <catch2/catch.hpp>

#include <set>
#include <vector>

extern "C" {
#include "logic/can_filter.h"
#include "logic/can_timing.h"
#include "logic/can_tx.h"
}

static void check_timing(uint32_t clk, uint32_t rate)
{
	can_timing t{};
	REQUIRE(can_timing_compute(clk, rate, 875, &t) == SWELL_OK);
	INFO("clk " << clk << " Hz, rate " << rate << " bit/s: brp " << t.brp << " ts1 " << int(t.ts1) << " ts2 " << int(t.ts2)
		    << " sjw " << int(t.sjw) << " sp " << t.sample_permille);
	// The bit rate is exact: f = rate * brp * (1 + ts1 + ts2).
	CHECK(uint64_t(rate) * t.brp * (1u + t.ts1 + t.ts2) == clk);
	CHECK(t.tq_per_bit == 1 + t.ts1 + t.ts2);
	CHECK(t.ts1 >= 1);
	CHECK(t.ts1 <= 16);
	CHECK(t.ts2 >= 1);
	CHECK(t.ts2 <= 8);
	CHECK(t.sjw >= 1);
	CHECK(t.sjw <= t.ts2);
	CHECK(t.sjw <= 4);
	// CiA sample point 87.5 %: within 2.5 % at these clocks.
	CHECK(t.sample_permille >= 850);
	CHECK(t.sample_permille <= 900);
	// The register holds the fields minus one.
	uint32_t btr = can_timing_btr(&t);
	CHECK((btr & 0x3FF) + 1 == t.brp);
	CHECK(((btr >> 16) & 0xF) + 1 == t.ts1);
	CHECK(((btr >> 20) & 0x7) + 1 == t.ts2);
	CHECK(((btr >> 24) & 0x3) + 1 == t.sjw);
	CHECK((btr & 0xC0000000u) == 0); // no loopback or silent bits
}

TEST_CASE("bit timing is exact with a CiA sample point at 1 Mbit/s and 500 kbit/s from APB1 42 MHz", "[can]")
{
	check_timing(42000000, 1000000);
	check_timing(42000000, 500000);
	check_timing(42000000, 250000);
	check_timing(42000000, 125000);
}

TEST_CASE("bit timing at 1 Mbit/s from 42 MHz is brp 3, 14 quanta, sample point 85.7 %", "[can]")
{
	can_timing t{};
	REQUIRE(can_timing_compute(42000000, 1000000, 875, &t) == SWELL_OK);
	// 42 = 1e6 * brp * tq: tq 14 (brp 3) or 21 (brp 2); 21 quanta cannot reach 87.5 % with
	// ts1 <= 16 (17/21 = 81 %), 14 quanta give 12/14 = 85.7 %.
	CHECK(t.brp == 3);
	CHECK(t.tq_per_bit == 14);
	CHECK(t.sample_permille == 857);
}

TEST_CASE("bit timing refuses rates that do not divide the clock and leaves the output alone", "[can]")
{
	can_timing t{};
	t.brp = 77;
	CHECK(can_timing_compute(42000000, 1000001, 875, &t) == SWELL_ERANGE);
	CHECK(can_timing_compute(42000000, 0, 875, &t) == SWELL_ERANGE);
	CHECK(can_timing_compute(0, 500000, 875, &t) == SWELL_ERANGE);
	CHECK(can_timing_compute(42000000, 500000, 1000, &t) == SWELL_ERANGE);
	CHECK(can_timing_compute(1000000, 1000000, 875, &t) == SWELL_ERANGE); // 1 tq per bit
	CHECK(t.brp == 77);
	CHECK(can_timing_compute(42000000, 500000, 875, nullptr) == SWELL_EINVAL);
}

// Every 11-bit id, data and remote, standard and extended: accepted exactly by the specs.
static void check_filters(const std::vector<can_filter_spec> &specs)
{
	can_filter_bank banks[CAN_FILTER_BANKS_CAN1];
	unsigned nb = 0;
	REQUIRE(can_filter_plan(specs.data(), unsigned(specs.size()), banks, CAN_FILTER_BANKS_CAN1, &nb) == SWELL_OK);
	unsigned wrong = 0, first_wrong = 0xFFFF;
	for (unsigned id = 0; id < 2048; id++) {
		int want = 0;
		unsigned want_fifo = 0;
		for (const auto &s : specs) {
			bool hit = s.kind == CAN_FILTER_EXACT ? id == s.id : ((id ^ s.id) & s.mask) == 0;
			if (hit && (!want || s.kind == CAN_FILTER_EXACT)) {
				want = 1;
				want_fifo = s.fifo;
			}
		}
		unsigned fifo = 99;
		int got = can_filter_match(banks, nb, uint16_t(id), 0, 0, &fifo);
		if (got != want || (want && fifo != want_fifo)) {
			wrong++;
			first_wrong = std::min(first_wrong, id);
		}
		// Remote and extended frames never pass.
		if (can_filter_match(banks, nb, uint16_t(id), 1, 0, nullptr) ||
		    can_filter_match(banks, nb, uint16_t(id), 0, 1, nullptr)) {
			wrong++;
			first_wrong = std::min(first_wrong, id);
		}
	}
	INFO(specs.size() << " specs in " << nb << " banks: " << wrong << " wrong ids, first 0x" << std::hex << first_wrong);
	CHECK(wrong == 0);
}

TEST_CASE("filters accept exactly the planned identifiers into the planned FIFO", "[can]")
{
	check_filters({});
	check_filters({{0x010, 0, CAN_FILTER_EXACT, 0}});
	check_filters({{0x010, 0, CAN_FILTER_EXACT, 0},
		       {0x011, 0, CAN_FILTER_EXACT, 0},
		       {0x7FF, 0, CAN_FILTER_EXACT, 1},
		       {0x000, 0, CAN_FILTER_EXACT, 0},
		       {0x123, 0, CAN_FILTER_EXACT, 0},
		       {0x200, 0x7F0, CAN_FILTER_MASK, 1},
		       {0x400, 0x700, CAN_FILTER_MASK, 0},
		       {0x081, 0x7FF, CAN_FILTER_MASK, 0}});
	// Node-id style: one mask per function code, low 4 bits the node.
	std::vector<can_filter_spec> nodes;
	for (uint16_t f = 0; f < 5; f++)
		nodes.push_back({uint16_t(f << 7), 0x780, CAN_FILTER_MASK, uint8_t(f & 1)});
	check_filters(nodes);
}

TEST_CASE("filter planning packs 4 exact ids or 2 masks per bank and refuses what does not fit", "[can]")
{
	can_filter_bank banks[CAN_FILTER_BANKS_CAN1] = {};
	unsigned nb = 123;
	std::vector<can_filter_spec> s;
	for (uint16_t i = 0; i < 9; i++)
		s.push_back({i, 0, CAN_FILTER_EXACT, 0});
	REQUIRE(can_filter_plan(s.data(), 9, banks, CAN_FILTER_BANKS_CAN1, &nb) == SWELL_OK);
	CHECK(nb == 3); // ceil(9 / 4)
	s.clear();
	for (uint16_t i = 0; i < 29; i++)
		s.push_back({uint16_t(i << 6), 0x7C0, CAN_FILTER_MASK, 0});
	nb = 123;
	CHECK(can_filter_plan(s.data(), 29, banks, CAN_FILTER_BANKS_CAN1, &nb) == SWELL_ESIZE);
	CHECK(nb == 123);
	can_filter_spec bad[] = {{0x800, 0, CAN_FILTER_EXACT, 0}};
	CHECK(can_filter_plan(bad, 1, banks, CAN_FILTER_BANKS_CAN1, &nb) == SWELL_ERANGE);
	can_filter_spec badfifo[] = {{0x100, 0, CAN_FILTER_EXACT, 2}};
	CHECK(can_filter_plan(badfifo, 1, banks, CAN_FILTER_BANKS_CAN1, &nb) == SWELL_ERANGE);
	CHECK(nb == 123);
}

// A model of the hardware's transmit order: lowest id first, then lowest mailbox.
static int next_out(uint32_t tme, const uint32_t id[3])
{
	int best = -1;
	for (int m = 0; m < 3; m++)
		if (!(tme & (1u << m)) && (best < 0 || id[m] < id[best]))
			best = m;
	return best;
}

TEST_CASE("mailbox choice keeps same-id frames in order and aborts only less urgent frames", "[can]")
{
	// Exhaustive over small ids: every occupancy pattern and pending ids 1..4, new id 1..4.
	unsigned checked = 0, bad = 0;
	for (uint32_t tme = 0; tme < 8; tme++) {
		for (uint32_t a = 1; a <= 4; a++)
			for (uint32_t b = 1; b <= 4; b++)
				for (uint32_t c = 1; c <= 4; c++) {
					for (uint32_t nid = 1; nid <= 4; nid++) {
						uint32_t id[3] = {a, b, c};
						unsigned mb = 9;
						int ab = 9;
						enum swell_err e = can_tx_pick(tme, id, nid, &mb, &ab);
						checked++;
						if (e != SWELL_OK) {
							// Refused: outputs untouched, and no valid choice existed: no mailbox above
							// every pending frame of the same id that is free or holds a less urgent one.
							unsigned lowest = 0;
							for (unsigned m = 0; m < 3; m++)
								if (!(tme & (1u << m)) && id[m] == nid)
									lowest = m + 1;
							bool possible = false;
							for (unsigned m = lowest; m < 3; m++)
								if ((tme & (1u << m)) || id[m] > nid)
									possible = true;
							if (mb != 9 || ab != 9 || possible)
								bad++;
							continue;
						}
						if (mb > 2) {
							bad++;
							continue;
						}
						if (ab) {
							// Only a busy, strictly less urgent frame is aborted, and only when full
							// (among the usable mailboxes).
							if ((tme & (1u << mb)) || id[mb] <= nid)
								bad++;
						} else if (!(tme & (1u << mb))) {
							bad++;
						}
						// Place it and drain in hardware order: the new frame leaves after every
						// pending frame of the same id.
						uint32_t t2 = tme & ~(1u << mb), id2[3] = {a, b, c};
						id2[mb] = nid;
						int same_before = 0;
						for (int m = 0; m < 3; m++)
							if (m != int(mb) && !(tme & (1u << m)) && id[m] == nid)
								same_before++;
						int out;
						int seen_same = 0;
						while ((out = next_out(t2, id2)) >= 0) {
							if (out == int(mb))
								break;
							if (id2[out] == nid)
								seen_same++;
							t2 |= 1u << out;
						}
						if (seen_same != same_before)
							bad++;
					}
				}
	}
	INFO(checked << " cases, " << bad << " wrong");
	CHECK(bad == 0);
}

TEST_CASE("mailbox choice prefers a free mailbox and displaces the least urgent when full", "[can]")
{
	uint32_t id[3] = {0x300, 0x100, 0x200};
	unsigned mb = 9;
	int ab = 9;
	REQUIRE(can_tx_pick(0x4, id, 0x050, &mb, &ab) == SWELL_OK);
	CHECK(mb == 2);
	CHECK(ab == 0);
	REQUIRE(can_tx_pick(0x0, id, 0x050, &mb, &ab) == SWELL_OK);
	CHECK(mb == 0); // 0x300 is the least urgent
	CHECK(ab == 1);
	mb = 9;
	CHECK(can_tx_pick(0x0, id, 0x400, &mb, &ab) == SWELL_ESIZE);
	CHECK(mb == 9);
}

extern "C" {
#include "logic/can_busoff.h"
}

TEST_CASE("bus-off recovery waits the hold-off, doubles it while the bus keeps failing, and resets "
	  "after a quiet second",
	  "[can]")
{
	can_busoff b;
	can_busoff_init(&b);
	CHECK_FALSE(can_busoff_due(&b, 0));
	uint32_t t = 0xFFFFFF00u; // wraps during the test
	can_busoff_event(&b, t);
	can_busoff_event(&b, t + 5); // repeated report while pending: ignored
	CHECK(b.count == 1);
	CHECK_FALSE(can_busoff_due(&b, t + CAN_BUSOFF_BASE_MS - 1));
	CHECK(can_busoff_due(&b, t + CAN_BUSOFF_BASE_MS));
	// A failed attempt waits another hold-off.
	can_busoff_attempted(&b, t + 100, 0);
	CHECK_FALSE(can_busoff_due(&b, t + 199));
	CHECK(can_busoff_due(&b, t + 200));
	can_busoff_attempted(&b, t + 200, 1);
	CHECK_FALSE(can_busoff_due(&b, t + 5000));
	// Bus-off again and again right after recovering: 200, 400, 800, 1600, 1600 ms.
	uint32_t expect[] = {200, 400, 800, 1600, 1600};
	uint32_t now = t + 300;
	for (uint32_t e : expect) {
		can_busoff_event(&b, now);
		INFO("hold-off " << b.holdoff_ms << " ms, expected " << e);
		CHECK(b.holdoff_ms == e);
		CHECK_FALSE(can_busoff_due(&b, now + e - 1));
		CHECK(can_busoff_due(&b, now + e));
		can_busoff_attempted(&b, now + e, 1);
		now += e + 10;
	}
	// A quiet second after recovery: back to the base hold-off.
	can_busoff_event(&b, now + CAN_BUSOFF_QUIET_MS);
	CHECK(b.holdoff_ms == CAN_BUSOFF_BASE_MS);
	CHECK(b.count == 7);
}
