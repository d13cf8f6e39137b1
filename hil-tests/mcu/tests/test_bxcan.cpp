// The bxCAN model (hil-tests/mcu/bxcan.h) against RM0090 section 32, driven the way the STM32F405
// driver (firmware/stm32f405/src/can.c) drives CAN1, with the driver's own filter plan and bit timing.
#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

extern "C" {
#include "bxcan.h"
#include "can_filter.h"
#include "can_timing.h"
}

namespace
{

const uint32_t PCLK1_HZ = 42000000; // APB1 of the image at 168 MHz

struct Sent {
	bxcan_frame f;
	uint64_t t_ns;
};

void on_tx(void *user, const bxcan_frame *f, uint64_t t_ns)
{
	static_cast<std::vector<Sent> *>(user)->push_back({ *f, t_ns });
}

// One node with its own clock.
struct Node {
	bxcan c{};
	uint64_t t = 0;
	std::vector<Sent> sent;

	Node()
	{
		REQUIRE(bxcan_init(&c, PCLK1_HZ) == 0);
		bxcan_set_tx_callback(&c, on_tx, &sent);
	}
	uint32_t rd(uint32_t off)
	{
		return bxcan_read(&c, off, t);
	}
	void wr(uint32_t off, uint32_t v)
	{
		bxcan_write(&c, off, v, t);
	}
	void at(uint64_t t_ns)
	{
		t = t_ns;
		bxcan_advance(&c, t);
	}
	void later(uint64_t dt_ns)
	{
		at(t + dt_ns);
	}
	// Run every pending event (bounded).
	void settle()
	{
		for (int i = 0; i < 10000; i++) {
			uint64_t n = bxcan_next_event_ns(&c);
			if (n == UINT64_MAX)
				return;
			at(n);
		}
		FAIL("events never settle");
	}
	uint32_t tec()
	{
		return (rd(BXCAN_ESR) >> BXCAN_ESR_TEC_SHIFT) & 0xFFu;
	}
	uint32_t rec()
	{
		return rd(BXCAN_ESR) >> BXCAN_ESR_REC_SHIFT;
	}
	uint32_t lec()
	{
		return (rd(BXCAN_ESR) & BXCAN_ESR_LEC_MASK) >> BXCAN_ESR_LEC_SHIFT;
	}
	// Initialisation mode, a bit timing, leave it and wait the 11 recessive bits.
	void start(uint32_t btr, uint32_t mcr_extra = 0)
	{
		wr(BXCAN_MCR, BXCAN_MCR_INRQ | mcr_extra);
		REQUIRE((rd(BXCAN_MSR) & (BXCAN_MSR_INAK | BXCAN_MSR_SLAK)) == BXCAN_MSR_INAK);
		wr(BXCAN_BTR, btr);
		REQUIRE(rd(BXCAN_BTR) == btr);
		wr(BXCAN_MCR, mcr_extra);
		later(bxcan_bits_ns(&c, 11));
		REQUIRE((rd(BXCAN_MSR) & (BXCAN_MSR_INAK | BXCAN_MSR_SLAK)) == 0);
	}
	// Bank 0: 32-bit mask 0, everything into FIFO 0.
	void accept_all()
	{
		wr(BXCAN_FMR, rd(BXCAN_FMR) | BXCAN_FMR_FINIT);
		wr(BXCAN_FS1R, 1);
		wr(BXCAN_FR1(0), 0);
		wr(BXCAN_FR2(0), 0);
		wr(BXCAN_FA1R, 1);
		wr(BXCAN_FMR, rd(BXCAN_FMR) & ~BXCAN_FMR_FINIT);
	}
	// Fill mailbox m with a standard data frame and request it.
	void queue(unsigned m, uint32_t id, uint8_t dlc, uint32_t lo = 0, uint32_t hi = 0, bool ext = false)
	{
		wr(BXCAN_TDTR(m), dlc);
		wr(BXCAN_TDLR(m), lo);
		wr(BXCAN_TDHR(m), hi);
		if (ext)
			wr(BXCAN_TIR(m), id << BXCAN_TIR_EXID_SHIFT | BXCAN_TIR_IDE | BXCAN_TIR_TXRQ);
		else
			wr(BXCAN_TIR(m), id << BXCAN_TIR_STID_SHIFT | BXCAN_TIR_TXRQ);
	}
	bool empty(unsigned m)
	{
		return (rd(BXCAN_TSR) & BXCAN_TSR_TME(m)) != 0;
	}
};

bxcan_frame std_frame(uint32_t id, uint8_t dlc = 0, uint8_t first = 0)
{
	bxcan_frame f{};
	f.id = id;
	f.dlc = dlc;
	for (unsigned i = 0; i < 8; i++)
		f.data[i] = static_cast<uint8_t>(first + i);
	return f;
}

// The driver's bit timing for 1 Mbit/s at 42 MHz (can_start: can_timing_compute, 87.5 % wanted).
uint32_t driver_btr()
{
	can_timing t{};
	REQUIRE(can_timing_compute(PCLK1_HZ, 1000000, 875, &t) == SWELL_OK);
	return can_timing_btr(&t);
}

} // namespace

TEST_CASE("bxcan: every register reads its RM0090 reset value", "[bxcan]")
{
	Node n;
	CHECK(n.rd(BXCAN_MCR) == 0x00010002u);
	CHECK(n.rd(BXCAN_MSR) == 0x00000C02u);
	CHECK(n.rd(BXCAN_TSR) == 0x1C000000u);
	CHECK(n.rd(BXCAN_RF0R) == 0u);
	CHECK(n.rd(BXCAN_RF1R) == 0u);
	CHECK(n.rd(BXCAN_IER) == 0u);
	CHECK(n.rd(BXCAN_ESR) == 0u);
	CHECK(n.rd(BXCAN_BTR) == 0x01230000u);
	CHECK(n.rd(BXCAN_FMR) == 0x2A1C0E01u);
	CHECK(n.rd(BXCAN_FM1R) == 0u);
	CHECK(n.rd(BXCAN_FS1R) == 0u);
	CHECK(n.rd(BXCAN_FFA1R) == 0u);
	CHECK(n.rd(BXCAN_FA1R) == 0u);
	CHECK(bxcan_next_event_ns(&n.c) == UINT64_MAX);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	// A master reset (MCR.RESET) brings the core back and keeps the filters.
	n.wr(BXCAN_FR1(3), 0x12345678u);
	n.start(driver_btr());
	n.wr(BXCAN_MCR, BXCAN_MCR_RESET);
	CHECK(n.rd(BXCAN_MCR) == 0x00010002u);
	CHECK(n.rd(BXCAN_MSR) == 0x00000C02u);
	CHECK(n.rd(BXCAN_BTR) == 0x01230000u);
	CHECK(n.rd(BXCAN_FR1(3)) == 0x12345678u);
}

TEST_CASE("bxcan: initialisation is acknowledged at once, normal mode after 11 recessive bits", "[bxcan]")
{
	Node n;
	const uint32_t btr = driver_btr();
	// Out of sleep into initialisation: INAK set, SLAK cleared (the driver's can_probe and can_start).
	n.wr(BXCAN_MCR, BXCAN_MCR_INRQ);
	CHECK((n.rd(BXCAN_MSR) & 3u) == BXCAN_MSR_INAK);
	n.wr(BXCAN_BTR, btr);
	n.wr(BXCAN_MCR, 0);
	const uint64_t t0 = n.t, bit = bxcan_bits_ns(&n.c, 1);
	CHECK(bit == 1000u);
	CHECK(bxcan_next_event_ns(&n.c) == t0 + 11 * bit);
	n.at(t0 + 11 * bit - 1);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) != 0);
	n.at(t0 + 11 * bit);
	CHECK((n.rd(BXCAN_MSR) & 3u) == 0u);
	// Sleep request: SLAK at once, SLAKI only with SLKIE, which raises the SCE line.
	n.wr(BXCAN_IER, BXCAN_IER_SLKIE);
	n.wr(BXCAN_MCR, BXCAN_MCR_SLEEP);
	CHECK((n.rd(BXCAN_MSR) & (BXCAN_MSR_SLAK | BXCAN_MSR_SLAKI | BXCAN_MSR_INAK)) ==
	      (BXCAN_MSR_SLAK | BXCAN_MSR_SLAKI));
	CHECK(bxcan_irq_lines(&n.c) == BXCAN_IRQ_SCE);
	n.wr(BXCAN_MSR, BXCAN_MSR_SLAKI); // rc_w1
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_SLAKI) == 0u);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	// INRQ and SLEEP together: no change.
	n.wr(BXCAN_MCR, BXCAN_MCR_SLEEP | BXCAN_MCR_INRQ);
	CHECK((n.rd(BXCAN_MSR) & 3u) == BXCAN_MSR_SLAK);
	// Automatic wake-up: a frame's SOF sets WKUI and clears SLEEP; the frame itself is lost and the
	// node is in normal mode 11 bits later.
	n.wr(BXCAN_MCR, BXCAN_MCR_SLEEP | BXCAN_MCR_AWUM);
	n.accept_all();
	n.later(5000);
	bxcan_frame f = std_frame(0x55, 2);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_OFF);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_WKUI) != 0u);
	CHECK((n.rd(BXCAN_MCR) & BXCAN_MCR_SLEEP) == 0u);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_SLAK) != 0u);
	CHECK((n.rd(BXCAN_RF0R) & 3u) == 0u);
	n.later(11 * bit);
	CHECK((n.rd(BXCAN_MSR) & 3u) == 0u);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FIFO0);
	// Without AWUM a frame only sets WKUI.
	n.wr(BXCAN_MCR, BXCAN_MCR_SLEEP);
	n.wr(BXCAN_MSR, BXCAN_MSR_WKUI);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_OFF);
	CHECK((n.rd(BXCAN_MCR) & BXCAN_MCR_SLEEP) != 0u);
	CHECK((n.rd(BXCAN_MSR) & (BXCAN_MSR_WKUI | BXCAN_MSR_SLAK)) == (BXCAN_MSR_WKUI | BXCAN_MSR_SLAK));
}

TEST_CASE("bxcan: an initialisation request waits for the frame on the wire", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.queue(0, 0x123, 8, 0x04030201u, 0x08070605u);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_TXM) != 0u);
	const uint64_t t0 = n.t;
	n.later(20000);
	n.wr(BXCAN_MCR, BXCAN_MCR_INRQ);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) == 0u);
	n.at(t0 + 116000); // the frame's 116 bits at 1 us
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) != 0u);
	CHECK(n.sent.size() == 1u);
}

TEST_CASE("bxcan: BTR and the filter configuration are write protected as RM0090 says", "[bxcan]")
{
	Node n;
	// BTR outside initialisation mode (sleep after reset, then normal): ignored.
	n.wr(BXCAN_BTR, 0x011A0002u);
	CHECK(n.rd(BXCAN_BTR) == 0x01230000u);
	n.start(0x011A0002u);
	n.wr(BXCAN_BTR, 0x00000005u);
	CHECK(n.rd(BXCAN_BTR) == 0x011A0002u);
	// FM1R, FS1R, FFA1R need FINIT = 1; FA1R does not; a bank's registers need FINIT or FACT = 0.
	n.wr(BXCAN_FMR, 0x2A1C0E00u);
	n.wr(BXCAN_FM1R, 1);
	n.wr(BXCAN_FS1R, 1);
	n.wr(BXCAN_FFA1R, 1);
	CHECK(n.rd(BXCAN_FM1R) == 0u);
	CHECK(n.rd(BXCAN_FS1R) == 0u);
	CHECK(n.rd(BXCAN_FFA1R) == 0u);
	n.wr(BXCAN_FR1(2), 0xAAAA5555u);
	CHECK(n.rd(BXCAN_FR1(2)) == 0xAAAA5555u);
	n.wr(BXCAN_FA1R, 1u << 2);
	CHECK(n.rd(BXCAN_FA1R) == 1u << 2);
	n.wr(BXCAN_FR1(2), 0x11112222u);
	CHECK(n.rd(BXCAN_FR1(2)) == 0xAAAA5555u);
	n.wr(BXCAN_FMR, 0x2A1C0E01u);
	n.wr(BXCAN_FR1(2), 0x11112222u);
	CHECK(n.rd(BXCAN_FR1(2)) == 0x11112222u);
}

TEST_CASE("bxcan: the driver's 16-bit mask bank for node 5 takes every type of node 5 and nothing else", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	// As app.c and can_start program it: id = type << 4 | node, mask 0x00F, FIFO 0.
	can_filter_spec spec{ 5, 0x00F, CAN_FILTER_MASK, 0 };
	can_filter_bank bank[CAN_FILTER_BANKS_CAN1];
	unsigned nb = 0;
	REQUIRE(can_filter_plan(&spec, 1, bank, CAN_FILTER_BANKS_CAN1, &nb) == SWELL_OK);
	REQUIRE(nb == 1u);
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) | BXCAN_FMR_FINIT);
	n.wr(BXCAN_FA1R, 0);
	n.wr(BXCAN_FS1R, 0);
	n.wr(BXCAN_FM1R, 0);
	n.wr(BXCAN_FFA1R, 0);
	n.wr(BXCAN_FR1(0), bank[0].fr1);
	n.wr(BXCAN_FR2(0), bank[0].fr2);
	n.wr(BXCAN_FA1R, 1);
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) & ~BXCAN_FMR_FINIT);
	unsigned taken = 0, refused = 0;
	for (uint32_t id = 0; id <= 0x7FF; id++) {
		bxcan_frame f = std_frame(id, 1);
		enum bxcan_rx r = bxcan_bus_rx(&n.c, &f, n.t);
		if ((id & 0xF) == 5) {
			INFO("id " << id);
			REQUIRE(r == BXCAN_RX_FIFO0);
			REQUIRE((n.rd(BXCAN_RIR(0)) >> 21) == id);
			REQUIRE(((n.rd(BXCAN_RDTR(0)) >> 8) & 0xFFu) == 0u); // FMI 0
			n.wr(BXCAN_RF0R, BXCAN_RFR_RFOM);
			taken++;
		} else {
			INFO("id " << id);
			REQUIRE(r == BXCAN_RX_FILTERED);
			refused++;
		}
		unsigned fifo = 9;
		REQUIRE(can_filter_match(bank, nb, static_cast<uint16_t>(id), 0, 0, &fifo) ==
			(r == BXCAN_RX_FIFO0 ? 1 : 0));
	}
	CHECK(taken == 128u);
	CHECK(refused == 2048u - 128u);
	// The mask compares RTR and IDE: a remote or an extended frame of node 5 is refused.
	bxcan_frame rtr = std_frame(0x15, 0);
	rtr.rtr = 1;
	CHECK(bxcan_bus_rx(&n.c, &rtr, n.t) == BXCAN_RX_FILTERED);
	bxcan_frame ext = std_frame(0x15, 0);
	ext.ide = 1;
	CHECK(bxcan_bus_rx(&n.c, &ext, n.t) == BXCAN_RX_FILTERED);
}

TEST_CASE("bxcan: list and 32-bit filters, FIFO assignment, match index numbered per FIFO", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) | BXCAN_FMR_FINIT);
	// Bank 0: 16-bit list, FIFO 0, filters 0..3 of FIFO 0 (inactive: numbers still count).
	// Bank 1: 16-bit list, FIFO 1, filters 0..3 of FIFO 1: ids 0x100, 0x101, 0x102, 0x103.
	// Bank 2: 32-bit mask, FIFO 0, filter 4 of FIFO 0: extended ids 0x1ABCDE00..0x1ABCDEFF.
	// Bank 3: 32-bit list, FIFO 0, filters 5 and 6 of FIFO 0: std 0x321, extended 0x00000042.
	// Bank 4: 16-bit mask, FIFO 1, filters 4 and 5 of FIFO 1: 0x100..0x1FF and 0x700..0x7FF.
	n.wr(BXCAN_FM1R, 1u << 0 | 1u << 1 | 1u << 3);
	n.wr(BXCAN_FS1R, 1u << 2 | 1u << 3);
	n.wr(BXCAN_FFA1R, 1u << 1 | 1u << 4);
	n.wr(BXCAN_FR1(1), (0x101u << 5) << 16 | 0x100u << 5);
	n.wr(BXCAN_FR2(1), (0x103u << 5) << 16 | 0x102u << 5);
	n.wr(BXCAN_FR1(2), 0x1ABCDE00u << 3 | 4u);
	n.wr(BXCAN_FR2(2), 0x1FFFFF00u << 3 | 6u); // compare IDE and RTR too
	n.wr(BXCAN_FR1(3), 0x321u << 21);
	n.wr(BXCAN_FR2(3), 0x42u << 3 | 4u);
	const uint32_t m16 = (0x700u << 5 | 0x18u) << 16; // top 3 id bits, RTR, IDE
	n.wr(BXCAN_FR1(4), m16 | 0x100u << 5);
	n.wr(BXCAN_FR2(4), m16 | 0x700u << 5);
	n.wr(BXCAN_FA1R, 0x1E); // bank 0 inactive
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) & ~BXCAN_FMR_FINIT);

	struct Case {
		uint32_t id;
		uint8_t ide;
		enum bxcan_rx fifo;
		unsigned fmi;
	};
	const Case cases[] = {
		{ 0x102, 0, BXCAN_RX_FIFO1, 2 }, // list beats the 16-bit mask of bank 4 (equal scale)
		{ 0x103, 0, BXCAN_RX_FIFO1, 3 },      { 0x150, 0, BXCAN_RX_FIFO1, 4 }, { 0x7AB, 0, BXCAN_RX_FIFO1, 5 },
		{ 0x1ABCDE7F, 1, BXCAN_RX_FIFO0, 4 }, { 0x321, 0, BXCAN_RX_FIFO0, 5 }, { 0x42, 1, BXCAN_RX_FIFO0, 6 },
	};
	for (const Case &k : cases) {
		bxcan_frame f = std_frame(k.id, 3);
		f.ide = k.ide;
		INFO("id 0x" << std::hex << k.id);
		CHECK(bxcan_bus_rx(&n.c, &f, n.t) == k.fifo);
		const unsigned q = k.fifo == BXCAN_RX_FIFO1 ? 1u : 0u;
		CHECK(((n.rd(BXCAN_RDTR(q)) >> 8) & 0xFFu) == k.fmi);
		CHECK((n.rd(BXCAN_RDTR(q)) & 0xFu) == 3u);
		if (k.ide)
			CHECK(n.rd(BXCAN_RIR(q)) == (k.id << 3 | BXCAN_TIR_IDE));
		else
			CHECK(n.rd(BXCAN_RIR(q)) == k.id << 21);
		n.wr(q ? BXCAN_RF1R : BXCAN_RF0R, BXCAN_RFR_RFOM);
	}
	// Not matched anywhere: 0x322, extended 0x43, the standard 0x42 (IDE compared), 0x1ABCDF00.
	for (auto [id, ide] :
	     { std::pair<uint32_t, uint8_t>{ 0x322, 0 }, { 0x43, 1 }, { 0x42, 0 }, { 0x1ABCDF00, 1 } }) {
		bxcan_frame f = std_frame(id, 0);
		f.ide = ide;
		INFO("id 0x" << std::hex << id);
		CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FILTERED);
	}
	// A 32-bit filter beats a 16-bit one: a 32-bit mask taking every standard frame in bank 5
	// (FIFO 0, filter 7) wins over the FIFO 1 list for 0x100.
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) | BXCAN_FMR_FINIT);
	n.wr(BXCAN_FS1R, n.rd(BXCAN_FS1R) | 1u << 5);
	n.wr(BXCAN_FR1(5), 0);
	n.wr(BXCAN_FR2(5), 4u); // IDE must be 0
	n.wr(BXCAN_FA1R, n.rd(BXCAN_FA1R) | 1u << 5);
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) & ~BXCAN_FMR_FINIT);
	bxcan_frame f = std_frame(0x100, 0);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FIFO0);
	CHECK(((n.rd(BXCAN_RDTR(0)) >> 8) & 0xFFu) == 7u);
	// Banks from CAN2SB on belong to CAN2: with CAN2SB = 5, bank 5 no longer filters for CAN1.
	n.wr(BXCAN_RF0R, BXCAN_RFR_RFOM);
	n.wr(BXCAN_FMR, 0x2A1C0500u);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FIFO1);
	// Filters in initialisation mode (FINIT = 1) take nothing.
	n.wr(BXCAN_FMR, 0x2A1C0E01u);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FILTERED);
}

TEST_CASE("bxcan: a FIFO holds 3 frames, then FULL, then FOVR: RFLM 0 keeps the newest, RFLM 1 the oldest", "[bxcan]")
{
	for (uint32_t rflm : { 0u, BXCAN_MCR_RFLM }) {
		Node n;
		n.start(driver_btr(), rflm);
		n.accept_all();
		n.wr(BXCAN_IER, BXCAN_IER_FMPIE0 | BXCAN_IER_FFIE0 | BXCAN_IER_FOVIE0);
		for (uint32_t k = 0; k < 3; k++) {
			bxcan_frame f = std_frame(0x10 + k, 1);
			CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FIFO0);
			CHECK((n.rd(BXCAN_RF0R) & 3u) == k + 1);
		}
		CHECK((n.rd(BXCAN_RF0R) & (BXCAN_RFR_FULL | BXCAN_RFR_FOVR)) == BXCAN_RFR_FULL);
		bxcan_frame f4 = std_frame(0x13, 1);
		CHECK(bxcan_bus_rx(&n.c, &f4, n.t) == (rflm ? BXCAN_RX_LOST : BXCAN_RX_FIFO0));
		CHECK(n.rd(BXCAN_RF0R) == (3u | BXCAN_RFR_FULL | BXCAN_RFR_FOVR));
		CHECK(bxcan_irq_lines(&n.c) == BXCAN_IRQ_RX0);
		std::vector<uint32_t> ids;
		for (int k = 0; k < 3; k++) {
			ids.push_back(n.rd(BXCAN_RIR(0)) >> 21);
			n.wr(BXCAN_RF0R, BXCAN_RFR_RFOM);
		}
		INFO("RFLM " << rflm);
		if (rflm)
			CHECK(ids == std::vector<uint32_t>{ 0x10, 0x11, 0x12 });
		else
			CHECK(ids == std::vector<uint32_t>{ 0x10, 0x11, 0x13 });
		// FULL and FOVR stay until written 1 (rc_w1); releasing an empty FIFO does nothing.
		CHECK(n.rd(BXCAN_RF0R) == (BXCAN_RFR_FULL | BXCAN_RFR_FOVR));
		n.wr(BXCAN_RF0R, BXCAN_RFR_RFOM);
		CHECK((n.rd(BXCAN_RF0R) & 3u) == 0u);
		n.wr(BXCAN_RF0R, BXCAN_RFR_FOVR);
		CHECK(n.rd(BXCAN_RF0R) == BXCAN_RFR_FULL);
		n.wr(BXCAN_RF0R, BXCAN_RFR_FULL);
		CHECK(n.rd(BXCAN_RF0R) == 0u);
		CHECK(bxcan_irq_lines(&n.c) == 0u);
	}
}

TEST_CASE("bxcan: RFOM releases frames oldest first, with their data", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.accept_all();
	for (uint32_t round = 0; round < 4; round++) {
		bxcan_frame a = std_frame(0x200 + 2 * round, 8, static_cast<uint8_t>(16 * round));
		bxcan_frame b = std_frame(0x201 + 2 * round, 5, static_cast<uint8_t>(16 * round + 8));
		CHECK(bxcan_bus_rx(&n.c, &a, n.t) == BXCAN_RX_FIFO0);
		CHECK(bxcan_bus_rx(&n.c, &b, n.t) == BXCAN_RX_FIFO0);
		for (const bxcan_frame *f : { &a, &b }) {
			CHECK(n.rd(BXCAN_RIR(0)) >> 21 == f->id);
			CHECK((n.rd(BXCAN_RDTR(0)) & 0xFu) == f->dlc);
			uint32_t lo = n.rd(BXCAN_RDLR(0)), hi = n.rd(BXCAN_RDHR(0));
			uint8_t d[8];
			for (unsigned i = 0; i < 4; i++) {
				d[i] = static_cast<uint8_t>(lo >> (8 * i));
				d[4 + i] = static_cast<uint8_t>(hi >> (8 * i));
			}
			CHECK(std::memcmp(d, f->data, 8) == 0);
			n.wr(BXCAN_RF0R, BXCAN_RFR_RFOM);
		}
		CHECK((n.rd(BXCAN_RF0R) & 3u) == 0u);
	}
}

TEST_CASE("bxcan: the lowest identifier goes first with TXFP 0, request order with TXFP 1", "[bxcan]")
{
	for (uint32_t txfp : { 0u, BXCAN_MCR_TXFP }) {
		Node n;
		n.start(driver_btr(), txfp);
		n.wr(BXCAN_MCR, BXCAN_MCR_INRQ | txfp); // queue all three before any can start
		n.queue(0, 0x300, 0);
		n.queue(1, 0x100, 0);
		n.queue(2, 0x200, 0);
		// CODE with all three pending names the lowest priority one; LOW marks it.
		const uint32_t tsr = n.rd(BXCAN_TSR);
		const unsigned last = txfp ? 2u : 0u;
		CHECK(((tsr >> BXCAN_TSR_CODE_SHIFT) & 3u) == last);
		CHECK((tsr >> 29) == (1u << last));
		CHECK((tsr & (7u << 26)) == 0u);
		n.wr(BXCAN_MCR, txfp);
		n.settle();
		REQUIRE(n.sent.size() == 3u);
		std::vector<uint32_t> order;
		for (const Sent &s : n.sent)
			order.push_back(s.f.id);
		INFO("TXFP " << txfp);
		if (txfp)
			CHECK(order == std::vector<uint32_t>{ 0x300, 0x100, 0x200 });
		else
			CHECK(order == std::vector<uint32_t>{ 0x100, 0x200, 0x300 });
		CHECK(n.rd(BXCAN_TSR) == (0x1C000000u | 0x030303u)); // all empty, RQCP and TXOK
	}
	// Equal identifiers: the lower mailbox first; a standard frame beats an extended one of the same
	// base identifier.
	Node n;
	n.start(driver_btr());
	n.wr(BXCAN_MCR, BXCAN_MCR_INRQ);
	n.queue(2, 0x50, 1);
	n.queue(1, 0x50u << 18, 1, 0, 0, true);
	n.queue(0, 0x50, 2);
	n.wr(BXCAN_MCR, 0);
	n.settle();
	REQUIRE(n.sent.size() == 3u);
	CHECK(n.sent[0].f.dlc == 2u);
	CHECK(n.sent[1].f.dlc == 1u);
	CHECK(n.sent[1].f.ide == 0u);
	CHECK(n.sent[2].f.ide == 1u);
}

TEST_CASE("bxcan: an abort empties a pending mailbox at once, a frame on the wire completes", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.queue(0, 0x10, 8);
	n.queue(1, 0x20, 8);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_TXM) != 0u);
	CHECK(((n.rd(BXCAN_TSR) >> BXCAN_TSR_CODE_SHIFT) & 3u) == 2u); // the next free mailbox
	n.later(10000);
	n.wr(BXCAN_TSR, BXCAN_TSR_ABRQ(1) | BXCAN_TSR_ABRQ(0) | BXCAN_TSR_ABRQ(2));
	uint32_t tsr = n.rd(BXCAN_TSR);
	CHECK((tsr & BXCAN_TSR_TME(1)) != 0u);
	CHECK((tsr & (BXCAN_TSR_RQCP(1) | BXCAN_TSR_TXOK(1))) == BXCAN_TSR_RQCP(1));
	CHECK((tsr & BXCAN_TSR_TME(0)) == 0u); // on the wire: still pending
	CHECK((tsr & BXCAN_TSR_ABRQ(0)) != 0u);
	CHECK((tsr & BXCAN_TSR_ABRQ(2)) == 0u); // empty: no effect
	n.settle();
	REQUIRE(n.sent.size() == 1u);
	CHECK(n.sent[0].f.id == 0x10u);
	tsr = n.rd(BXCAN_TSR);
	CHECK((tsr & (BXCAN_TSR_TME(0) | BXCAN_TSR_RQCP(0) | BXCAN_TSR_TXOK(0) | BXCAN_TSR_ABRQ(0))) ==
	      (BXCAN_TSR_TME(0) | BXCAN_TSR_RQCP(0) | BXCAN_TSR_TXOK(0)));
	// An attempt that fails while an abort is requested ends the request, TXOK clear.
	bxcan_inject_no_ack(&n.c, true);
	n.queue(2, 0x30, 0);
	n.at(bxcan_next_event_ns(&n.c)); // after the intermission: on the wire
	REQUIRE((n.rd(BXCAN_MSR) & BXCAN_MSR_TXM) != 0u);
	n.wr(BXCAN_TSR, BXCAN_TSR_ABRQ(2));
	n.settle();
	tsr = n.rd(BXCAN_TSR);
	CHECK((tsr & (BXCAN_TSR_TME(2) | BXCAN_TSR_RQCP(2) | BXCAN_TSR_TXOK(2) | BXCAN_TSR_TERR(2))) ==
	      (BXCAN_TSR_TME(2) | BXCAN_TSR_RQCP(2) | BXCAN_TSR_TERR(2)));
	CHECK(n.tec() == 8u);
	// Clearing RQCP clears TXOK, ALST and TERR of the mailbox.
	n.wr(BXCAN_TSR, BXCAN_TSR_RQCP(2));
	CHECK((n.rd(BXCAN_TSR) & 0xFFu << 16) == 0u);
}

TEST_CASE("bxcan: frames last their exact stuffed length at 1 Mbit/s from the driver's BTR", "[bxcan]")
{
	// CRC-15/CAN catalogue check value of "123456789".
	const uint8_t check[] = { '1', '2', '3', '4', '5', '6', '7', '8', '9' };
	CHECK(bxcan_crc15(check, 72) == 0x059Eu);
	// Id 0, no data: 34 zero bits SOF..CRC, a stuff bit after every 5: 40, + 10 = 50.
	bxcan_frame zero = std_frame(0, 0);
	uint32_t stuffed = 0;
	CHECK(bxcan_frame_bits(&zero, &stuffed) == 50u);
	CHECK(stuffed == 40u);
	// Worked out bit by bit with an independent long-division CRC: id 0x123 data 01..08: CRC 0x64EF,
	// 98 bits + 8 stuff + 10 = 116; extended 0x12345678 with 8 x 0xAA: 130; 0x100 with 8 zeros: 123.
	bxcan_frame a = std_frame(0x123, 8, 1);
	CHECK(bxcan_frame_bits(&a, nullptr) == 116u);
	bxcan_frame e = std_frame(0x12345678, 8);
	e.ide = 1;
	std::memset(e.data, 0xAA, 8);
	CHECK(bxcan_frame_bits(&e, nullptr) == 130u);
	bxcan_frame z = std_frame(0x100, 8);
	std::memset(z.data, 0, 8);
	CHECK(bxcan_frame_bits(&z, nullptr) == 123u);
	bxcan_frame bad = std_frame(0x800, 0);
	CHECK(bxcan_frame_bits(&bad, nullptr) == 0u);

	Node n;
	const uint32_t btr = driver_btr();
	CHECK(btr == 0x011A0002u); // BRP 3, TS1 11, TS2 2: 14 tq of 1/14 us
	n.start(btr);
	const uint64_t t0 = n.t;
	n.queue(0, 0x123, 8, 0x04030201u, 0x08070605u);
	n.queue(1, 0x124, 0);
	CHECK(bxcan_next_event_ns(&n.c) == t0 + 116000u);
	n.at(t0 + 115999);
	CHECK(n.sent.empty());
	CHECK(!n.empty(0));
	n.at(t0 + 116000);
	REQUIRE(n.sent.size() == 1u);
	CHECK(n.sent[0].t_ns == t0 + 116000u);
	CHECK(std::memcmp(n.sent[0].f.data, a.data, 8) == 0);
	CHECK(n.empty(0));
	// The next frame starts after 3 bits of intermission.
	bxcan_frame b = std_frame(0x124, 0);
	const uint64_t end_b = t0 + 116000u + 3000u + 1000u * bxcan_frame_bits(&b, nullptr);
	n.settle();
	REQUIRE(n.sent.size() == 2u);
	CHECK(n.sent[1].t_ns == end_b);
	// At 500 kbit/s (BRP 6) every frame takes twice as long.
	Node h;
	h.start(0x011A0005u);
	CHECK(bxcan_bits_ns(&h.c, 116) == 232000u);
}

TEST_CASE("bxcan: without ACK the frame is retried, TEC + 8 each up to error passive and no further", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.wr(BXCAN_IER, BXCAN_IER_EPVIE | BXCAN_IER_ERRIE | BXCAN_IER_BOFIE);
	bxcan_inject_no_ack(&n.c, true);
	n.queue(0, 0x40, 8);
	bxcan_frame f = std_frame(0x40, 8);
	std::memset(f.data, 0, 8);
	uint32_t stuffed = 0;
	REQUIRE(bxcan_frame_bits(&f, &stuffed) > 0u);
	for (unsigned k = 1; k <= 20; k++) {
		const uint64_t t_start = n.t;
		n.at(bxcan_next_event_ns(&n.c)); // the attempt's ACK slot
		INFO("attempt " << k);
		CHECK(n.t - t_start == 1000u * (stuffed + 2));
		CHECK(n.tec() == (k <= 16 ? 8 * k : 128u));
		CHECK(n.lec() == BXCAN_LEC_ACK);
		CHECK(!n.empty(0));
		CHECK((n.rd(BXCAN_TSR) & (BXCAN_TSR_TERR(0) | BXCAN_TSR_RQCP(0))) == BXCAN_TSR_TERR(0));
		CHECK(((n.rd(BXCAN_ESR) & BXCAN_ESR_EWGF) != 0) == (8 * k >= 96));
		CHECK(((n.rd(BXCAN_ESR) & BXCAN_ESR_EPVF) != 0) == (8 * k >= 128));
		CHECK(((n.rd(BXCAN_MSR) & BXCAN_MSR_ERRI) != 0) == (8 * k >= 128));
		CHECK(((bxcan_irq_lines(&n.c) & BXCAN_IRQ_SCE) != 0) == (8 * k >= 128));
		n.wr(BXCAN_MSR, BXCAN_MSR_ERRI);
		// The retry starts after the error frame and intermission (+ 8 suspend bits when passive).
		const uint64_t gap = bxcan_next_event_ns(&n.c) - n.t;
		CHECK(gap == 1000u * (14 + 3 + (n.tec() >= 128 ? 8 : 0)));
		n.at(bxcan_next_event_ns(&n.c));
	}
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) == 0u);
	CHECK(n.sent.empty());
	// Somebody acknowledges again: the frame goes, TEC - 1.
	bxcan_inject_no_ack(&n.c, false);
	n.settle();
	CHECK(n.sent.size() == 1u);
	CHECK(n.tec() == 127u);
	CHECK(n.lec() == 0u);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_EPVF) == 0u);
	// NART: one attempt only, then the mailbox is empty with TERR.
	Node o;
	o.start(driver_btr(), BXCAN_MCR_NART);
	bxcan_inject_no_ack(&o.c, true);
	o.queue(1, 0x41, 0);
	o.settle();
	CHECK((o.rd(BXCAN_TSR) & (BXCAN_TSR_TME(1) | BXCAN_TSR_RQCP(1) | BXCAN_TSR_TXOK(1) | BXCAN_TSR_TERR(1))) ==
	      (BXCAN_TSR_TME(1) | BXCAN_TSR_RQCP(1) | BXCAN_TSR_TERR(1)));
	CHECK(o.tec() == 8u);
}

TEST_CASE("bxcan: 32 transmit errors or an injected bus-off give BOFF, automatic recovery after 128 x 11 bits",
	  "[bxcan]")
{
	Node n;
	n.start(driver_btr(), BXCAN_MCR_ABOM);
	n.wr(BXCAN_IER, BXCAN_IER_BOFIE | BXCAN_IER_ERRIE);
	bxcan_inject_tx_errors(&n.c, 32);
	n.queue(0, 0x60, 1);
	for (int k = 0; k < 31; k++) {
		n.at(bxcan_next_event_ns(&n.c)); // the attempt's error
		n.at(bxcan_next_event_ns(&n.c)); // the retry's start
	}
	CHECK(n.tec() == 248u);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) == 0u);
	CHECK(n.lec() == BXCAN_LEC_BIT_RECESSIVE);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_ERRI) == 0u); // EWG and EPV are not enabled
	n.at(bxcan_next_event_ns(&n.c));
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	CHECK(n.tec() == 0u); // the low byte of the 9-bit counter (256)
	CHECK((bxcan_irq_lines(&n.c) & BXCAN_IRQ_SCE) != 0u);
	const uint64_t t_off = n.t;
	CHECK(!n.empty(0)); // the request waits for the recovery
	// Frames from the bus are not received while bus-off.
	bxcan_frame f = std_frame(0x1, 0);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_OFF);
	n.at(t_off + 128 * 11 * 1000 - 1);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	CHECK(n.sent.empty());
	n.at(t_off + 128 * 11 * 1000);
	CHECK((n.rd(BXCAN_ESR) & 0xFFFF0007u) == 0u); // TEC, REC, EWGF, EPVF, BOFF all 0
	n.settle();
	CHECK(n.sent.size() == 1u);

	// Injected bus-off during a frame: the attempt fails and stays pending.
	Node m;
	m.start(driver_btr(), BXCAN_MCR_ABOM);
	m.queue(2, 0x61, 8);
	m.later(30000);
	bxcan_inject_bus_off(&m.c, m.t);
	CHECK((m.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	CHECK((m.rd(BXCAN_TSR) & (BXCAN_TSR_TME(2) | BXCAN_TSR_TERR(2))) == BXCAN_TSR_TERR(2));
	CHECK((m.rd(BXCAN_MSR) & BXCAN_MSR_TXM) == 0u);
	CHECK(bxcan_next_event_ns(&m.c) == m.t + 1408000u);
	m.settle();
	CHECK(m.sent.size() == 1u);
}

TEST_CASE("bxcan: without ABOM bus-off lasts until init is left and 128 x 11 recessive bits pass", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.queue(0, 0x70, 0);
	n.settle();
	REQUIRE(n.sent.size() == 1u);
	bxcan_inject_bus_off(&n.c, n.t);
	n.queue(1, 0x71, 0);
	n.later(10000000); // 10 ms: no recovery by itself
	CHECK(bxcan_next_event_ns(&n.c) == UINT64_MAX);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	// The driver's can_poll: enter initialisation, leave it, INAK clears after 11 bits.
	n.wr(BXCAN_MCR, BXCAN_MCR_INRQ);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) != 0u);
	n.wr(BXCAN_MCR, 0);
	const uint64_t t_leave = n.t;
	n.at(t_leave + 11000);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) == 0u);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u); // recovery is still running
	n.at(t_leave + 1408000 - 1);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	n.at(t_leave + 1408000);
	CHECK((n.rd(BXCAN_ESR) & ~BXCAN_ESR_LEC_MASK) == 0u);
	n.settle();
	CHECK(n.sent.size() == 2u);
}

TEST_CASE("bxcan: receive errors count REC, a good frame takes it down (above 128: to 120)", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.accept_all();
	n.wr(BXCAN_IER, BXCAN_IER_EWGIE | BXCAN_IER_ERRIE);
	bxcan_inject_rx_errors(&n.c, 95, n.t);
	CHECK(n.rec() == 95u);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_ERRI) == 0u);
	bxcan_inject_rx_errors(&n.c, 1, n.t);
	CHECK(n.rec() == 96u);
	CHECK(n.lec() == BXCAN_LEC_CRC);
	CHECK((n.rd(BXCAN_ESR) & (BXCAN_ESR_EWGF | BXCAN_ESR_EPVF)) == BXCAN_ESR_EWGF);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_ERRI) != 0u);
	bxcan_frame f = std_frame(0x5, 0);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FIFO0);
	CHECK(n.rec() == 95u);
	CHECK(n.lec() == 0u);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_EWGF) == 0u);
	bxcan_inject_rx_errors(&n.c, 40, n.t);
	CHECK(n.rec() == 135u);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_EPVF) != 0u);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FIFO0);
	CHECK(n.rec() == 120u);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_EPVF) == 0u);
	// Only LEC is writable in ESR.
	n.wr(BXCAN_ESR, 0xFFFFFFFFu);
	CHECK(n.rd(BXCAN_ESR) == (120u << 24 | 7u << 4 | BXCAN_ESR_EWGF));
}

TEST_CASE("bxcan: each interrupt line follows its flags and enables", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	n.accept_all();
	// TX: RQCP and TMEIE.
	n.queue(0, 0x1, 0);
	n.settle();
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	n.wr(BXCAN_IER, BXCAN_IER_TMEIE);
	CHECK(bxcan_irq_lines(&n.c) == BXCAN_IRQ_TX);
	n.wr(BXCAN_TSR, BXCAN_TSR_RQCP(0));
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	// RX1: FMP1 with FMPIE1 only.
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) | BXCAN_FMR_FINIT);
	n.wr(BXCAN_FFA1R, 1);
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) & ~BXCAN_FMR_FINIT);
	bxcan_frame f = std_frame(0x2, 0);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_FIFO1);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	n.wr(BXCAN_IER, BXCAN_IER_FMPIE1);
	CHECK(bxcan_irq_lines(&n.c) == BXCAN_IRQ_RX1);
	n.wr(BXCAN_IER, BXCAN_IER_FMPIE0);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	n.wr(BXCAN_RF1R, BXCAN_RFR_RFOM);
	// SCE: an error with LECIE sets ERRI; the line needs ERRIE as well.
	n.wr(BXCAN_IER, BXCAN_IER_LECIE);
	bxcan_inject_rx_errors(&n.c, 1, n.t);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_ERRI) != 0u);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	n.wr(BXCAN_IER, BXCAN_IER_LECIE | BXCAN_IER_ERRIE);
	CHECK(bxcan_irq_lines(&n.c) == BXCAN_IRQ_SCE);
	n.wr(BXCAN_MSR, BXCAN_MSR_ERRI);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	// Without any of EWGIE/EPVIE/BOFIE/LECIE an error leaves ERRI clear.
	n.wr(BXCAN_IER, BXCAN_IER_ERRIE);
	bxcan_inject_rx_errors(&n.c, 1, n.t);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_ERRI) == 0u);
	// WKUI with WKUIE.
	n.wr(BXCAN_IER, BXCAN_IER_WKUIE);
	n.wr(BXCAN_MCR, BXCAN_MCR_SLEEP);
	CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_OFF);
	CHECK(bxcan_irq_lines(&n.c) == BXCAN_IRQ_SCE);
	n.wr(BXCAN_MSR, BXCAN_MSR_WKUI);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
}

TEST_CASE("bxcan: in loopback the node receives its own frames, silent loopback shows nothing on the bus", "[bxcan]")
{
	for (uint32_t silent : { 0u, BXCAN_BTR_SILM }) {
		Node n;
		// The driver's loopback start: LBKM | SILM on top of its timing.
		n.start(driver_btr() | BXCAN_BTR_LBKM | silent);
		n.accept_all();
		bxcan_inject_no_ack(&n.c, true); // acknowledge errors are ignored in loopback
		n.queue(0, 0x2A5, 3, 0x00C0FFEEu);
		n.settle();
		INFO("SILM " << (silent != 0));
		CHECK(n.sent.size() == (silent ? 0u : 1u));
		CHECK(n.tec() == 0u);
		CHECK((n.rd(BXCAN_TSR) & BXCAN_TSR_TXOK(0)) != 0u);
		CHECK((n.rd(BXCAN_RF0R) & 3u) == 1u);
		CHECK(n.rd(BXCAN_RIR(0)) == 0x2A5u << 21);
		CHECK(n.rd(BXCAN_RDTR(0)) == 3u);
		CHECK(n.rd(BXCAN_RDLR(0)) == 0x00C0FFEEu);
		// The bus is not listened to.
		bxcan_frame f = std_frame(0x3, 0);
		CHECK(bxcan_bus_rx(&n.c, &f, n.t) == BXCAN_RX_OFF);
	}
	// Silent mode alone receives but cannot start a transmission.
	Node s;
	s.start(driver_btr() | BXCAN_BTR_SILM);
	s.accept_all();
	s.queue(0, 0x10, 0);
	s.settle();
	CHECK(s.sent.empty());
	CHECK(!s.empty(0));
	bxcan_frame f = std_frame(0x3, 0);
	CHECK(bxcan_bus_rx(&s.c, &f, s.t) == BXCAN_RX_FIFO0);
}

TEST_CASE("bxcan: lost arbitration sets ALST and retries without counting an error", "[bxcan]")
{
	Node n;
	n.start(driver_btr());
	bxcan_inject_arbitration_lost(&n.c, 2);
	n.queue(0, 0x7F0, 0);
	const uint64_t t0 = n.t;
	bxcan_frame f = std_frame(0x7F0, 0);
	const uint32_t bits = bxcan_frame_bits(&f, nullptr);
	n.at(bxcan_next_event_ns(&n.c));
	CHECK(n.t - t0 == 1000u * bits); // the bus stays busy with the winner's frame
	CHECK((n.rd(BXCAN_TSR) & (BXCAN_TSR_ALST(0) | BXCAN_TSR_TME(0))) == BXCAN_TSR_ALST(0));
	CHECK(n.tec() == 0u);
	n.settle();
	CHECK(n.sent.size() == 1u);
	CHECK((n.rd(BXCAN_TSR) & (BXCAN_TSR_ALST(0) | BXCAN_TSR_TXOK(0))) == BXCAN_TSR_TXOK(0));
	// The flags describe the last attempt: a lost arbitration, then an error, shows TERR alone.
	bxcan_inject_arbitration_lost(&n.c, 1);
	bxcan_inject_tx_errors(&n.c, 1);
	n.queue(1, 0x7F1, 0);
	n.at(bxcan_next_event_ns(&n.c)); // start
	n.at(bxcan_next_event_ns(&n.c)); // arbitration lost
	CHECK((n.rd(BXCAN_TSR) & (BXCAN_TSR_ALST(1) | BXCAN_TSR_TERR(1))) == BXCAN_TSR_ALST(1));
	n.at(bxcan_next_event_ns(&n.c)); // retry
	n.at(bxcan_next_event_ns(&n.c)); // bit error
	CHECK((n.rd(BXCAN_TSR) & (BXCAN_TSR_ALST(1) | BXCAN_TSR_TERR(1))) == BXCAN_TSR_TERR(1));
	CHECK(n.tec() == 8u);
	n.settle();
	CHECK((n.rd(BXCAN_TSR) & (BXCAN_TSR_ALST(1) | BXCAN_TSR_TERR(1) | BXCAN_TSR_TXOK(1))) == BXCAN_TSR_TXOK(1));
	CHECK(n.tec() == 7u);
}

TEST_CASE("bxcan: on a bus stuck dominant init cannot be left and a transmitter goes bus-off", "[bxcan]")
{
	// The driver's can_start on a stuck bus: INAK never clears (its "no 11 recessive bits").
	Node n;
	n.wr(BXCAN_MCR, BXCAN_MCR_INRQ);
	n.wr(BXCAN_BTR, driver_btr());
	bxcan_inject_bus_dominant(&n.c, true, n.t);
	CHECK((n.rd(BXCAN_MSR) & (BXCAN_MSR_RX | BXCAN_MSR_SAMP)) == 0u);
	n.wr(BXCAN_MCR, 0);
	n.later(10000000);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) != 0u);
	CHECK(bxcan_next_event_ns(&n.c) == UINT64_MAX);
	bxcan_inject_bus_dominant(&n.c, false, n.t);
	CHECK((n.rd(BXCAN_MSR) & (BXCAN_MSR_RX | BXCAN_MSR_SAMP)) == (BXCAN_MSR_RX | BXCAN_MSR_SAMP));
	const uint64_t t_free = n.t;
	n.at(t_free + 10999);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) != 0u);
	n.at(t_free + 11000);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) == 0u);

	// A transmitter: the frame fails at once (TEC 8), then + 8 at the 14th dominant bit and every
	// 8 bits: bus-off (TEC 256) 14 + 30 x 8 = 254 bits later. With ABOM the recovery waits for the bus.
	Node t;
	t.start(driver_btr(), BXCAN_MCR_ABOM);
	t.queue(0, 0x99, 8);
	t.later(20000);
	const uint64_t t_stuck = t.t;
	bxcan_inject_bus_dominant(&t.c, true, t.t);
	CHECK(t.tec() == 8u);
	CHECK(t.lec() == BXCAN_LEC_BIT_RECESSIVE);
	CHECK(!t.empty(0));
	t.at(t_stuck + 253999);
	CHECK(t.tec() == 248u);
	CHECK((t.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) == 0u);
	t.at(t_stuck + 254000);
	CHECK((t.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	t.later(50000000);
	CHECK((t.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	CHECK(t.sent.empty());
	bxcan_inject_bus_dominant(&t.c, false, t.t);
	const uint64_t t_free2 = t.t;
	t.at(t_free2 + 1408000 - 1);
	CHECK((t.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	t.at(t_free2 + 1408000);
	CHECK((t.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) == 0u);
	t.settle();
	CHECK(t.sent.size() == 1u);

	// An idle node is a receiver: stuff error (REC 1), then + 8 per 8 bits up to 255, never bus-off.
	Node r;
	r.start(driver_btr());
	r.wr(BXCAN_IER, BXCAN_IER_EPVIE | BXCAN_IER_ERRIE);
	const uint64_t r_stuck = r.t;
	bxcan_inject_bus_dominant(&r.c, true, r.t);
	CHECK(r.rec() == 1u);
	CHECK(r.lec() == BXCAN_LEC_STUFF);
	r.at(r_stuck + 1000 * (14 + 15 * 8)); // 16 steps: REC 129, error passive
	CHECK(r.rec() == 129u);
	CHECK((r.rd(BXCAN_ESR) & BXCAN_ESR_EPVF) != 0u);
	CHECK(bxcan_irq_lines(&r.c) == BXCAN_IRQ_SCE);
	r.later(1000000);
	CHECK(r.rec() == 255u);
	CHECK((r.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) == 0u);
	bxcan_frame f = std_frame(0x1, 0);
	CHECK(bxcan_bus_rx(&r.c, &f, r.t) == BXCAN_RX_OFF);
}

TEST_CASE("bxcan: bad arguments change nothing", "[bxcan]")
{
	bxcan c{};
	CHECK(bxcan_init(&c, 0) == -1);
	CHECK(bxcan_init(nullptr, PCLK1_HZ) == -1);
	REQUIRE(bxcan_init(&c, PCLK1_HZ) == 0);
	CHECK(bxcan_set_pclk(&c, 0) == -1);
	CHECK(bxcan_bits_ns(&c, 1) == 191u); // reset BTR: 8 tq at 42 MHz = 190.48 ns, rounded up
	bxcan_frame f = std_frame(0x800, 0);
	CHECK(bxcan_bus_rx(&c, &f, 0) == BXCAN_RX_INVALID);
	f = std_frame(0x1, 16);
	CHECK(bxcan_bus_rx(&c, &f, 0) == BXCAN_RX_INVALID);
	CHECK(bxcan_read(&c, BXCAN_MCR + 1, 0) == 0u);
	bxcan_write(&c, BXCAN_MCR + 2, BXCAN_MCR_INRQ, 0);
	CHECK(bxcan_read(&c, BXCAN_MCR, 0) == 0x00010002u);
}

// The register sequences of firmware/stm32f405/src/can.c (can_start, can_send, isr_can1_rx0,
// isr_can1_sce, can_poll), written out against the model as the driver performs them.
TEST_CASE("bxcan: the driver's start, send, receive interrupt and bus-off recovery work on the model", "[bxcan]")
{
	Node n;
	// can_start: initialisation, timing, the filter bank for node 5, interrupts, leave init.
	n.wr(BXCAN_MCR, BXCAN_MCR_INRQ);
	REQUIRE((n.rd(BXCAN_MSR) & (BXCAN_MSR_INAK | BXCAN_MSR_SLAK)) == BXCAN_MSR_INAK);
	n.wr(BXCAN_BTR, driver_btr());
	can_filter_spec spec{ 5, 0x00F, CAN_FILTER_MASK, 0 };
	can_filter_bank bank[CAN_FILTER_BANKS_CAN1];
	unsigned nb = 0;
	REQUIRE(can_filter_plan(&spec, 1, bank, CAN_FILTER_BANKS_CAN1, &nb) == SWELL_OK);
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) | BXCAN_FMR_FINIT);
	n.wr(BXCAN_FA1R, 0);
	n.wr(BXCAN_FS1R, 0);
	n.wr(BXCAN_FM1R, 0);
	n.wr(BXCAN_FFA1R, 0);
	for (unsigned b = 0; b < nb; b++) {
		n.wr(BXCAN_FR1(b), bank[b].fr1);
		n.wr(BXCAN_FR2(b), bank[b].fr2);
	}
	n.wr(BXCAN_FA1R, (1u << nb) - 1u);
	n.wr(BXCAN_FMR, n.rd(BXCAN_FMR) & ~BXCAN_FMR_FINIT);
	n.wr(BXCAN_IER, BXCAN_IER_FMPIE0 | BXCAN_IER_FOVIE0 | BXCAN_IER_BOFIE | BXCAN_IER_EPVIE | BXCAN_IER_ERRIE);
	n.wr(BXCAN_MCR, n.rd(BXCAN_MCR) & ~BXCAN_MCR_INRQ);
	n.later(11000);
	REQUIRE((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) == 0u);

	// can_send into the free mailbox TSR names, id << 21 | TXRQ.
	const uint32_t code = (n.rd(BXCAN_TSR) >> BXCAN_TSR_CODE_SHIFT) & 3u;
	n.queue(code, 0x215, 8, 0x11223344u, 0x55667788u);
	n.settle();
	REQUIRE(n.sent.size() == 1u);
	CHECK(n.sent[0].f.id == 0x215u);

	// Four frames for node 5 arrive before the receive interrupt runs: FMP 3, FOVR, the line is up.
	for (uint32_t type = 1; type <= 4; type++) {
		bxcan_frame f = std_frame(type << 4 | 5, 2, static_cast<uint8_t>(type));
		bxcan_bus_rx(&n.c, &f, n.t);
	}
	REQUIRE(bxcan_irq_lines(&n.c) == BXCAN_IRQ_RX0);
	// isr_can1_rx0: clear FOVR, then at most 3 frames, each released with RFOM.
	std::vector<uint32_t> got;
	if (n.rd(BXCAN_RF0R) & BXCAN_RFR_FOVR)
		n.wr(BXCAN_RF0R, BXCAN_RFR_FOVR);
	for (int k = 0; k < 3 && (n.rd(BXCAN_RF0R) & BXCAN_RFR_FMP_MASK); k++) {
		got.push_back(n.rd(BXCAN_RIR(0)) >> 21);
		n.wr(BXCAN_RF0R, BXCAN_RFR_RFOM);
	}
	CHECK(got == std::vector<uint32_t>{ 0x15, 0x25, 0x45 });
	CHECK(bxcan_irq_lines(&n.c) == 0u); // FULL stays set but FFIE0 is off

	// A bus-off: the status interrupt sees BOFF and clears ERRI; the line drops.
	bxcan_inject_bus_off(&n.c, n.t);
	REQUIRE(bxcan_irq_lines(&n.c) == BXCAN_IRQ_SCE);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	n.wr(BXCAN_MSR, BXCAN_MSR_ERRI);
	CHECK(bxcan_irq_lines(&n.c) == 0u);
	// can_send refuses while BOFF; can_poll after the hold-off: enter and leave init. Its success test
	// (INAK clear) comes after 11 bits; BOFF itself clears after 128 x 11 bits from leaving init.
	n.later(100000000);
	n.wr(BXCAN_MCR, n.rd(BXCAN_MCR) | BXCAN_MCR_INRQ);
	REQUIRE((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) != 0u);
	n.wr(BXCAN_MCR, n.rd(BXCAN_MCR) & ~BXCAN_MCR_INRQ);
	const uint64_t t_leave = n.t;
	n.at(t_leave + 11000);
	CHECK((n.rd(BXCAN_MSR) & BXCAN_MSR_INAK) == 0u);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) != 0u);
	n.at(t_leave + 1408000);
	CHECK((n.rd(BXCAN_ESR) & BXCAN_ESR_BOFF) == 0u);
	n.queue(0, 0x215, 1);
	n.settle();
	CHECK(n.sent.size() == 2u);
}
