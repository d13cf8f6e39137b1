// The OTG_FS device model (hil-tests/mcu/otgfs.c) against RM0090's programming model: a scripted
// driver (otgfs_script.hpp) initialises the core as 34.17 says, a host resets the bus, enumerates
// the device and moves bulk packets; the register-level details are checked on their own.
#include <catch2/catch.hpp>

#include <memory>

#include "otgfs_script.hpp"

using namespace otgfs_script;

constexpr uint64_t RESET_NS = 10000000u, FRAME_NS = 1000000u;

namespace
{

struct Bench {
	std::unique_ptr<otgfs> m{ new otgfs };
	uint64_t now = 1000;
	Driver drv;
	Host host;

	Bench() : drv(m.get(), &now), host(m.get(), &drv, &now)
	{
		otgfs_init(m.get(), 1000000000u); // ns
	}
	uint32_t rd(uint32_t off)
	{
		return otgfs_read(m.get(), off, now);
	}
	void wr(uint32_t off, uint32_t v)
	{
		otgfs_write(m.get(), off, v, now);
	}
	// Started, reset, addressed (5) and configured.
	void enumerate()
	{
		REQUIRE(drv.start());
		REQUIRE(host.reset());
		std::vector<uint8_t> d;
		REQUIRE(host.control_in(0x80, 6, 0x0100, 0, 64, d) == OTGFS_ACK);
		REQUIRE(host.control_nodata(0x00, 5, 5, 0) == OTGFS_ACK);
		host.addr = 5;
		REQUIRE(host.control_nodata(0x00, 9, 1, 0) == OTGFS_ACK);
	}
};

} // namespace

TEST_CASE("OTG_FS registers read their RM0090 reset values and the core answers on the AHB")
{
	Bench b;
	CHECK(b.rd(CID) == 0x00001200u);
	CHECK((b.rd(GRSTCTL) & 0x80000031u) == 0x80000000u); // AHBIDL, no reset or flush running
	CHECK(b.rd(DCFG) == 0x02200000u);
	CHECK(b.rd(GUSBCFG) == 0x00000A00u);
	CHECK(b.rd(GRXFSIZ) == 0x200u);
	CHECK((b.rd(GINTSTS) & 1u) == 0u); // CMOD: device mode
	CHECK(b.rd(DIEPCTL(0)) == USBAEP); // EP0 is always active
	CHECK(!otgfs_irq(b.m.get()));
	CHECK(!otgfs_host_attached(b.m.get()));
	CHECK(otgfs_fault(b.m.get()) == nullptr);
}

TEST_CASE("OTG_FS with its clock gated reads 0, ignores writes and stays off the bus")
{
	Bench b;
	otgfs_set_clock(b.m.get(), 0);
	CHECK(b.rd(CID) == 0u);
	CHECK(b.rd(GRSTCTL) == 0u); // no AHBIDL: usb_probe's test fails
	REQUIRE(b.drv.start() == false);
	otgfs_set_clock(b.m.get(), 1);
	CHECK(b.rd(GCCFG) == 0u);
	REQUIRE(b.drv.start());
	CHECK(otgfs_host_attached(b.m.get()));
	otgfs_set_clock(b.m.get(), 0);
	CHECK(!otgfs_host_attached(b.m.get()));
}

TEST_CASE("OTG_FS core soft reset and FIFO flushes clear after a read, and empty the FIFOs")
{
	Bench b;
	b.wr(DIEPTXF0, (16u << 16) | 128u);
	b.wr(GRXFSIZ, 128);
	b.wr(FIFO(0), 0x11223344u);
	b.wr(FIFO(0), 0x55667788u);
	CHECK(b.rd(DTXFSTS(0)) == 14u);
	b.wr(GRSTCTL, (1u << 5) | (0u << 6)); // TXFFLSH of FIFO 0
	CHECK((b.rd(GRSTCTL) & (1u << 5)) != 0u); // in progress on the first read
	CHECK((b.rd(GRSTCTL) & (1u << 5)) == 0u);
	CHECK(b.rd(DTXFSTS(0)) == 16u);
	b.wr(GINTSTS, 0xFFFFFFFFu);
	b.wr(GRSTCTL, 1u); // CSRST
	CHECK((b.rd(GRSTCTL) & 1u) == 1u);
	CHECK((b.rd(GRSTCTL) & 1u) == 0u);
	CHECK(b.rd(DIEPCTL(0)) == USBAEP);
	CHECK(otgfs_fault(b.m.get()) == nullptr);
}

TEST_CASE("OTG_FS attaches only with PHY power, VBUS, device mode and SDIS clear, and a detach ends the session")
{
	Bench b;
	b.wr(GUSBCFG, 1u << 30);
	b.wr(GCCFG, 1u << 16); // PWRDWN without VBUS sensing off: no VBUS seen
	CHECK(!otgfs_host_attached(b.m.get()));
	b.wr(GCCFG, (1u << 16) | (1u << 21)); // NOVBUSSENS
	CHECK(otgfs_host_attached(b.m.get()));
	b.wr(DCTL, 2u); // SDIS
	CHECK(!otgfs_host_attached(b.m.get()));
	CHECK(otgfs_host_reset(b.m.get(), b.now) == -1);
	b.wr(DCTL, 0u);
	b.wr(PCGCCTL, 1u); // STPPCLK
	CHECK(!otgfs_host_attached(b.m.get()));
	b.wr(PCGCCTL, 0u);
	b.wr(GCCFG, (1u << 16) | (1u << 19)); // VBUSBSEN with VBUS
	CHECK(otgfs_host_attached(b.m.get()));
	otgfs_set_vbus(b.m.get(), 0);
	CHECK(!otgfs_host_attached(b.m.get()));
}

TEST_CASE("OTG_FS bus reset raises USBRST at once and ENUMDNE 10 ms later, with full speed in DSTS")
{
	Bench b;
	REQUIRE(b.drv.start());
	b.wr(GINTMSK, USBRST | ENUMDNE); // no driver here: the test reads the flags itself
	REQUIRE(otgfs_host_reset(b.m.get(), b.now) == 0);
	CHECK((b.rd(GINTSTS) & USBRST) != 0u);
	CHECK(otgfs_irq(b.m.get()));
	CHECK(otgfs_next_event_ns(b.m.get()) == b.now + RESET_NS);
	b.wr(GINTSTS, USBRST);
	CHECK(!otgfs_irq(b.m.get()));
	b.now += RESET_NS - 1;
	CHECK((b.rd(GINTSTS) & ENUMDNE) == 0u);
	CHECK(!otgfs_host_running(b.m.get()));
	b.now += 1;
	CHECK((b.rd(GINTSTS) & ENUMDNE) != 0u);
	CHECK(((b.rd(DSTS) >> 1) & 3u) == 3u); // ENUMSPD: full speed (48 MHz PHY clock)
	CHECK(otgfs_host_running(b.m.get()));
	b.wr(GAHBCFG, 0); // the global mask gates the line
	CHECK(!otgfs_irq(b.m.get()));
}

TEST_CASE("OTG_FS counts frames in DSTS.FNSOF and raises SOF each millisecond when unmasked")
{
	Bench b;
	REQUIRE(b.drv.start());
	REQUIRE(b.host.reset());
	uint64_t t0 = b.now;
	b.wr(GINTSTS, SOF);
	b.wr(GINTMSK, b.rd(GINTMSK) | SOF);
	uint64_t next = otgfs_next_event_ns(b.m.get());
	REQUIRE(next != OTGFS_NO_EVENT);
	CHECK(next > t0);
	CHECK(next <= t0 + FRAME_NS);
	uint32_t f0 = (b.rd(DSTS) >> 8) & 0x3FFFu;
	b.now = next;
	CHECK((b.rd(GINTSTS) & SOF) != 0u);
	CHECK(((b.rd(DSTS) >> 8) & 0x3FFFu) == f0 + 1);
	CHECK(otgfs_irq(b.m.get()));
}

TEST_CASE("OTG_FS enumerates with a driver following RM0090 34.17: descriptors, SET_ADDRESS, SET_CONFIGURATION")
{
	Bench b;
	REQUIRE(b.drv.start());
	REQUIRE(b.host.reset());
	CHECK(b.drv.resets == 1);
	CHECK(b.drv.enumerations == 1);

	std::vector<uint8_t> d;
	REQUIRE(b.host.control_in(0x80, 6, 0x0100, 0, 64, d) == OTGFS_ACK);
	CHECK(d == std::vector<uint8_t>(device_desc, device_desc + 18));
	REQUIRE(b.host.control_in(0x80, 6, 0x0100, 0, 8, d) == OTGFS_ACK); // wLength cuts the reply
	CHECK(d.size() == 8);

	// SET_ADDRESS: the driver writes DAD before the status stage; address 0 still answers that
	// stage, then only the new address does.
	REQUIRE(b.host.control_nodata(0x00, 5, 5, 0) == OTGFS_ACK);
	CHECK(otgfs_host_address(b.m.get()) == 5);
	const uint8_t get_dev[8] = { 0x80, 6, 0, 1, 0, 0, 18, 0 };
	CHECK(otgfs_host_setup(b.m.get(), b.now, 0, get_dev) == OTGFS_NORESP);
	b.host.addr = 5;
	REQUIRE(b.host.control_in(0x80, 6, 0x0200, 0, 255, d) == OTGFS_ACK);
	CHECK(d == std::vector<uint8_t>(config_desc, config_desc + 32));

	REQUIRE(b.host.control_nodata(0x00, 9, 1, 0) == OTGFS_ACK);
	CHECK(b.drv.config == 1);
	CHECK((b.rd(DIEPCTL(1)) & USBAEP) != 0u);
	CHECK(b.m->stats.setups == 5);
	CHECK(b.host.naks > 0); // the driver's answers come after the host's first tokens
	CHECK(otgfs_fault(b.m.get()) == nullptr);
}

TEST_CASE("OTG_FS stalls EP0 for a refused request until the next SETUP")
{
	Bench b;
	b.enumerate();
	std::vector<uint8_t> d;
	CHECK(b.host.control_in(0x80, 6, 0x0600, 0, 10, d) == OTGFS_STALL); // device qualifier: refused
	CHECK(b.host.control_in(0x80, 6, 0x0100, 0, 18, d) == OTGFS_ACK);
	CHECK(d.size() == 18);
	CHECK(b.m->stats.stalls >= 1);
}

TEST_CASE("OTG_FS moves 1000 bulk packets of 1..64 bytes OUT and back IN intact and in order")
{
	Bench b;
	b.enumerate();
	for (unsigned i = 0; i < 1000; i++) {
		std::vector<uint8_t> p(1 + i % 64);
		for (size_t k = 0; k < p.size(); k++)
			p[k] = (uint8_t)(i * 7 + k);
		REQUIRE(b.host.out(1, p) == OTGFS_ACK);
		std::vector<uint8_t> back;
		REQUIRE(b.host.in(1, back) == OTGFS_ACK);
		REQUIRE(back == p);
	}
	CHECK(b.m->stats.out_acks >= 1000);
	CHECK(b.m->stats.in_acks >= 1000);
	CHECK(otgfs_fault(b.m.get()) == nullptr);
}

TEST_CASE("OTG_FS NAKs an endpoint that is not enabled or NAK-set, and does not answer an inactive one")
{
	Bench b;
	b.enumerate();
	uint8_t buf[64];
	uint32_t n = 99;
	CHECK(otgfs_host_in(b.m.get(), b.now, 5, 1, buf, sizeof(buf), &n) == OTGFS_NAK); // nothing queued
	CHECK(n == 0);
	CHECK(otgfs_host_in(b.m.get(), b.now, 5, 2, buf, sizeof(buf), &n) == OTGFS_NORESP); // not active
	b.wr(DOEPCTL(1), b.rd(DOEPCTL(1)) | SNAK);
	const uint8_t p[4] = { 1, 2, 3, 4 };
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p, 4) == OTGFS_NAK);
	b.wr(DOEPCTL(1), b.rd(DOEPCTL(1)) | CNAK);
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p, 4) == OTGFS_ACK);
	// Global OUT NAK (DCTL SGONAK) holds every OUT endpoint
	b.drv.isr();
	b.wr(DCTL, b.rd(DCTL) | (1u << 9));
	CHECK((b.rd(GINTSTS) & (1u << 7)) != 0u); // GONAKEFF
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p, 4) == OTGFS_NAK);
	// more than the packet size is no transaction the device takes
	uint8_t big[65] = {};
	b.wr(DCTL, b.rd(DCTL) | (1u << 10));
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, big, 65) == OTGFS_NORESP);
}

TEST_CASE("OTG_FS stalls a halted bulk endpoint and SD0PID puts its data toggle back to DATA0")
{
	Bench b;
	b.enumerate();
	REQUIRE(b.host.out(1, { 1, 2, 3 }) == OTGFS_ACK); // DATA0 used: the toggle is DATA1
	std::vector<uint8_t> back;
	REQUIRE(b.host.in(1, back) == OTGFS_ACK);
	CHECK((b.rd(DOEPCTL(1)) & DPID) != 0u);
	b.wr(DOEPCTL(1), b.rd(DOEPCTL(1)) | STALL);
	const uint8_t p[1] = { 9 };
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p, 1) == OTGFS_STALL);
	b.wr(DOEPCTL(1), (b.rd(DOEPCTL(1)) & ~STALL) | SD0PID);
	CHECK((b.rd(DOEPCTL(1)) & DPID) == 0u);
	CHECK((b.rd(DOEPCTL(1)) & STALL) == 0u);
}

TEST_CASE("OTG_FS receive FIFO: a full FIFO NAKs OUT data, entries pop in order with XFRC on the completion entry")
{
	Bench b;
	b.enumerate();
	b.wr(GAHBCFG, 0); // the driver does not run: the test reads the FIFO by hand
	// EP1 OUT armed for 3 packets of 64 bytes; the receive FIFO is 128 words
	b.wr(DOEPTSIZ(1), (3u << 19) | 192u);
	b.wr(DOEPCTL(1), b.rd(DOEPCTL(1)) | CNAK | EPENA);
	std::vector<uint8_t> p(64, 0xA5);
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p.data(), 64) == OTGFS_ACK);
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p.data(), 64) == OTGFS_ACK);
	CHECK((b.rd(DOEPTSIZ(1)) >> 19 & 0x3FFu) == 1u);
	CHECK((b.rd(DOEPTSIZ(1)) & 0x7FFFFu) == 64u);
	b.wr(GRXFSIZ, 40); // shrink: 2 x 17 words in, the next needs 18 more
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p.data(), 64) == OTGFS_NAK);
	b.wr(GRXFSIZ, 128);
	CHECK(otgfs_host_out(b.m.get(), b.now, 5, 1, p.data(), 64) == OTGFS_ACK);
	CHECK((b.rd(DOEPCTL(1)) & EPENA) == 0u); // packet count reached 0: disabled
	for (int i = 0; i < 3; i++) {
		REQUIRE((b.rd(GINTSTS) & RXFLVL) != 0u);
		uint32_t s = b.rd(GRXSTSP);
		CHECK((s & 0xF) == 1u);
		CHECK(((s >> 4) & 0x7FF) == 64u);
		CHECK(((s >> 17) & 0xF) == 2u);
		CHECK((b.rd(GINTSTS) & RXFLVL) == 0u); // data first
		for (int w = 0; w < 16; w++)
			CHECK(b.rd(FIFO(0)) == 0xA5A5A5A5u);
	}
	CHECK((b.rd(DOEPINT(1)) & XFRC) == 0u);
	uint32_t s = b.rd(GRXSTSP);
	CHECK(((s >> 17) & 0xF) == 3u); // OUT transfer completed
	CHECK((b.rd(DOEPINT(1)) & XFRC) != 0u);
	CHECK((b.rd(GINTSTS) & RXFLVL) == 0u);
	CHECK(otgfs_fault(b.m.get()) == nullptr);
}

TEST_CASE("OTG_FS records programming errors: TX FIFO overflow, FIFOs outside the RAM, reads of an empty RX FIFO")
{
	SECTION("overflow")
	{
		Bench b;
		b.wr(GRXFSIZ, 128);
		b.wr(DIEPTXF0, (16u << 16) | 128u);
		for (int i = 0; i < 16; i++)
			b.wr(FIFO(0), 0);
		CHECK(otgfs_fault(b.m.get()) == nullptr);
		CHECK(b.rd(DTXFSTS(0)) == 0u);
		b.wr(FIFO(0), 0);
		CHECK(otgfs_fault(b.m.get()) != nullptr);
	}
	SECTION("layout")
	{
		Bench b;
		b.wr(GRXFSIZ, 128);
		b.wr(DIEPTXF0, (16u << 16) | 100u); // overlaps the receive FIFO
		b.wr(FIFO(0), 0);
		CHECK(otgfs_fault(b.m.get()) != nullptr);
	}
	SECTION("empty receive FIFO")
	{
		Bench b;
		(void)b.rd(GRXSTSP);
		CHECK(otgfs_fault_count(b.m.get()) == 1u);
		(void)b.rd(FIFO(0));
		CHECK(otgfs_fault_count(b.m.get()) == 2u);
	}
}

TEST_CASE("OTG_FS CSRST takes the device off the bus until the host resets it again")
{
	Bench b;
	b.enumerate();
	b.wr(GRSTCTL, 1u);
	(void)b.rd(GRSTCTL);
	(void)b.rd(GRSTCTL);
	CHECK(!otgfs_host_running(b.m.get()));
	CHECK(otgfs_host_attached(b.m.get()));
	CHECK(b.host.reset());
}

TEST_CASE("OTG_FS with the cable pulled raises ESUSP 3 ms and USBSUSP 6 ms later, answers no token, and a host's "
	  "reset brings it back to enumeration")
{
	constexpr uint32_t ESUSP = 1u << 10, USBSUSP = 1u << 11;
	Bench b;
	b.enumerate();
	b.wr(GINTMSK, ESUSP | USBSUSP); // no driver interrupts here: the test reads the flags itself
	const uint64_t out_at = b.now;
	otgfs_host_unplug(b.m.get(), out_at);
	CHECK(!otgfs_host_plugged(b.m.get()));
	CHECK(!otgfs_host_running(b.m.get()));
	CHECK(otgfs_host_attached(b.m.get())); // the pull-up is still on
	CHECK(otgfs_next_event_ns(b.m.get()) == out_at + 3 * FRAME_NS);
	uint8_t buf[64];
	uint32_t n = 0;
	CHECK(otgfs_host_in(b.m.get(), b.now, 5, 1, buf, sizeof(buf), &n) == OTGFS_NORESP);
	b.now = out_at + 3 * FRAME_NS - 1;
	CHECK((b.rd(GINTSTS) & (ESUSP | USBSUSP)) == 0u);
	b.now += 1;
	CHECK((b.rd(GINTSTS) & (ESUSP | USBSUSP)) == ESUSP);
	CHECK((b.rd(DSTS) & 1u) == 0u);
	CHECK(otgfs_next_event_ns(b.m.get()) == out_at + 6 * FRAME_NS);
	b.now = out_at + 6 * FRAME_NS;
	CHECK((b.rd(GINTSTS) & USBSUSP) != 0u);
	CHECK((b.rd(DSTS) & 1u) == 1u); // SUSPSTS
	CHECK(otgfs_irq(b.m.get()));
	CHECK(b.m->suspend_at == out_at + 6 * FRAME_NS);
	CHECK(otgfs_next_event_ns(b.m.get()) == OTGFS_NO_EVENT); // suspended: nothing more by itself
	b.now += 5 * FRAME_NS;
	b.wr(GINTSTS, ESUSP | USBSUSP); // the driver's acknowledgment is recorded
	CHECK(b.m->stats.suspends == 1u);
	CHECK(b.m->stats.suspends_seen == 1u);
	CHECK(b.m->suspend_seen_at == b.now);
	CHECK(!otgfs_irq(b.m.get()));
	// cable in: the host resets the port; the suspend ends and the device enumerates again
	b.wr(GINTMSK, 0);
	b.enumerate();
	CHECK(otgfs_host_plugged(b.m.get()));
	CHECK((b.rd(DSTS) & 1u) == 0u);
	CHECK(b.m->stats.resets == 2u);
	std::vector<uint8_t> p{ 1, 2, 3 }, back;
	REQUIRE(b.host.out(1, p) == OTGFS_ACK);
	REQUIRE(b.host.in(1, back) == OTGFS_ACK);
	CHECK(back == p);
	CHECK(otgfs_fault(b.m.get()) == nullptr);
}

TEST_CASE("OTG_FS with the cable out and the pull-up off raises no suspend, and the idle time counts from the attach")
{
	constexpr uint32_t ESUSP = 1u << 10, USBSUSP = 1u << 11;
	Bench b;
	b.enumerate();
	b.wr(GINTMSK, ESUSP | USBSUSP);
	otgfs_host_unplug(b.m.get(), b.now);
	b.wr(DCTL, 2u); // SDIS: off the bus
	b.now += 10 * FRAME_NS;
	CHECK((b.rd(GINTSTS) & (ESUSP | USBSUSP)) == 0u);
	CHECK(otgfs_next_event_ns(b.m.get()) == OTGFS_NO_EVENT);
	b.wr(DCTL, 0u);
	const uint64_t on_at = b.now;
	b.now = on_at + 6 * FRAME_NS - 1;
	CHECK((b.rd(GINTSTS) & USBSUSP) == 0u);
	b.now += 1;
	CHECK((b.rd(GINTSTS) & USBSUSP) != 0u);
}
