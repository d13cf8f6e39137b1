// A scripted device driver for the OTG_FS model, written from RM0090's programming model (34.17)
// and independent of the firmware's driver: 34.17.1 core initialization, 34.17.3 device
// initialization, 34.17.5 endpoint initialization on USB reset and on enumeration completion,
// 34.17.6 reading packets from the receive FIFO and writing IN packets. It answers the standard
// requests of a vendor device with bulk OUT 0x01 and bulk IN 0x81 (64 bytes) and echoes every
// bulk OUT packet on bulk IN. The tests of the model (test_otgfs) and of the USB/IP server
// (test_usbip) run it where the emulator would run the image.
#pragma once

#include <cstdint>
#include <cstring>
#include <deque>
#include <vector>

extern "C" {
#include "otgfs.h"
}

namespace otgfs_script
{

// Register offsets as the manual names them.
enum : uint32_t {
	GAHBCFG = 0x008,
	GUSBCFG = 0x00C,
	GRSTCTL = 0x010,
	GINTSTS = 0x014,
	GINTMSK = 0x018,
	GRXSTSP = 0x020,
	GRXFSIZ = 0x024,
	DIEPTXF0 = 0x028,
	GCCFG = 0x038,
	CID = 0x03C,
	DIEPTXF1 = 0x104,
	DCFG = 0x800,
	DCTL = 0x804,
	DSTS = 0x808,
	DIEPMSK = 0x810,
	DOEPMSK = 0x814,
	DAINT = 0x818,
	DAINTMSK = 0x81C,
	PCGCCTL = 0xE00,
};
inline uint32_t DIEPCTL(unsigned n)
{
	return 0x900 + 0x20 * n;
}
inline uint32_t DIEPINT(unsigned n)
{
	return 0x908 + 0x20 * n;
}
inline uint32_t DIEPTSIZ(unsigned n)
{
	return 0x910 + 0x20 * n;
}
inline uint32_t DTXFSTS(unsigned n)
{
	return 0x918 + 0x20 * n;
}
inline uint32_t DOEPCTL(unsigned n)
{
	return 0xB00 + 0x20 * n;
}
inline uint32_t DOEPINT(unsigned n)
{
	return 0xB08 + 0x20 * n;
}
inline uint32_t DOEPTSIZ(unsigned n)
{
	return 0xB10 + 0x20 * n;
}
inline uint32_t FIFO(unsigned n)
{
	return 0x1000 + 0x1000 * n;
}

constexpr uint32_t USBRST = 1u << 12, ENUMDNE = 1u << 13, RXFLVL = 1u << 4, IEPINT = 1u << 18, OEPINT = 1u << 19,
		   SOF = 1u << 3;
constexpr uint32_t EPENA = 1u << 31, CNAK = 1u << 26, SNAK = 1u << 27, STALL = 1u << 21, USBAEP = 1u << 15,
		   SD0PID = 1u << 28, DPID = 1u << 16;
constexpr uint32_t XFRC = 1u << 0, STUP = 1u << 3;

const uint8_t device_desc[18] = { 18, 1, 0x00, 0x02, 0, 0, 0, 64, 0x09, 0x12, 0x01, 0x00, 0x00, 0x01, 0, 0, 0, 1 };
// configuration, interface (class 0xFF, 2 endpoints), bulk OUT 0x01 and bulk IN 0x81 of 64 bytes
const uint8_t config_desc[32] = {
	9, 2, 32,   0, 1,  1,    0, 0x80, 50, // configuration
	9, 4, 0,    0, 2,  0xFF, 0, 0,    0, // interface
	7, 5, 0x01, 2, 64, 0,    0, // bulk OUT
	7, 5, 0x81, 2, 64, 0,    0, // bulk IN
};

struct Driver {
	otgfs *m;
	uint64_t *now; // the virtual clock the test advances
	uint8_t setup[8] = {};
	int address = 0, config = 0;
	bool in1_busy = false;
	std::deque<std::vector<uint8_t>> echo; // bulk OUT packets waiting to go back IN
	std::vector<uint8_t> out_pkt;
	unsigned resets = 0, enumerations = 0, setups = 0, bulk_outs = 0, bulk_ins = 0;

	Driver(otgfs *model, uint64_t *clock) : m(model), now(clock)
	{
	}

	uint32_t rd(uint32_t off)
	{
		return otgfs_read(m, off, *now);
	}
	void wr(uint32_t off, uint32_t v)
	{
		otgfs_write(m, off, v, *now);
	}
	bool wait_clear(uint32_t off, uint32_t bits)
	{
		for (int i = 0; i < 100; i++)
			if (!(rd(off) & bits))
				return true;
		return false;
	}

	// 34.17.1 core initialization and 34.17.3 device initialization; ends with the pull-up on.
	bool start()
	{
		if (!(rd(GRSTCTL) & (1u << 31)))
			return false; // AHBIDL
		wr(GRSTCTL, 1u); // CSRST
		if (!wait_clear(GRSTCTL, 1u))
			return false;
		wr(GAHBCFG, 1u); // GINTMSK: interrupts to the CPU
		wr(GUSBCFG, (1u << 30) | (1u << 6) | (6u << 10)); // FDMOD, PHYSEL, TRDT 6
		wr(GINTMSK, USBRST | ENUMDNE | RXFLVL | IEPINT | OEPINT);
		wr(DCFG, 3u); // DSPD full speed
		wr(GCCFG, (1u << 16) | (1u << 19)); // PWRDWN, VBUSBSEN
		wr(DCTL, 0); // SDIS clear: connect
		return true;
	}

	void arm_ep0_out()
	{
		wr(DOEPTSIZ(0), (3u << 29) | (1u << 19) | 64u);
		wr(DOEPCTL(0), rd(DOEPCTL(0)) | CNAK | EPENA);
	}
	void arm_ep1_out()
	{
		wr(DOEPTSIZ(1), (1u << 19) | 64u);
		wr(DOEPCTL(1), rd(DOEPCTL(1)) | CNAK | EPENA);
	}
	void send_in(unsigned ep, const uint8_t *d, uint32_t len)
	{
		wr(DIEPTSIZ(ep), (1u << 19) | len);
		wr(DIEPCTL(ep), rd(DIEPCTL(ep)) | CNAK | EPENA);
		for (uint32_t i = 0; i < len; i += 4) {
			uint32_t w = 0;
			for (uint32_t k = 0; k < 4 && i + k < len; k++)
				w |= (uint32_t)d[i + k] << (8 * k);
			wr(FIFO(ep), w);
		}
	}

	// 34.17.5: endpoint initialization on USB reset.
	void on_reset()
	{
		resets++;
		for (unsigned n = 0; n < OTGFS_EPS; n++)
			wr(DOEPCTL(n), rd(DOEPCTL(n)) | SNAK);
		wr(DAINTMSK, (1u << 0) | (1u << 16));
		wr(DOEPMSK, STUP | XFRC);
		wr(DIEPMSK, XFRC);
		wr(DCFG, rd(DCFG) & ~(0x7Fu << 4));
		wr(GRXFSIZ, 128);
		wr(DIEPTXF0, (16u << 16) | 128u);
		wr(DIEPTXF1, (16u << 16) | 144u);
		wr(GRSTCTL, (1u << 5) | (0x10u << 6)); // flush every TX FIFO
		wait_clear(GRSTCTL, 1u << 5);
		address = config = 0;
		in1_busy = false;
		echo.clear();
		arm_ep0_out();
	}

	// 34.17.5: endpoint initialization on enumeration completion.
	void on_enum_done()
	{
		enumerations++;
		(void)rd(DSTS); // ENUMSPD: full speed
		wr(DIEPCTL(0), rd(DIEPCTL(0)) & ~3u); // MPSIZ 64
		arm_ep0_out();
	}

	void configure(int c)
	{
		config = c;
		if (c) {
			wr(DIEPCTL(1), 64u | (2u << 18) | (1u << 22) | USBAEP | SD0PID | SNAK);
			wr(DOEPCTL(1), 64u | (2u << 18) | USBAEP | SD0PID);
			wr(DAINTMSK, rd(DAINTMSK) | (1u << 1) | (1u << 17));
			arm_ep1_out();
		} else {
			wr(DIEPCTL(1), 0);
			wr(DOEPCTL(1), 0);
		}
	}

	void handle_setup()
	{
		setups++;
		uint8_t type = setup[0], req = setup[1];
		uint16_t value = (uint16_t)(setup[2] | setup[3] << 8), len = (uint16_t)(setup[6] | setup[7] << 8);
		auto reply = [&](const uint8_t *d, uint16_t n) { send_in(0, d, n < len ? n : len); };
		if (type == 0x80 && req == 6 && value == 0x0100) {
			reply(device_desc, sizeof(device_desc));
		} else if (type == 0x80 && req == 6 && value == 0x0200) {
			reply(config_desc, sizeof(config_desc));
		} else if (type == 0x00 && req == 5) {
			address = value & 0x7F;
			wr(DCFG, (rd(DCFG) & ~(0x7Fu << 4)) | ((uint32_t)address << 4)); // before the status stage
			send_in(0, nullptr, 0);
		} else if (type == 0x00 && req == 9 && value <= 1) {
			configure(value);
			send_in(0, nullptr, 0);
		} else {
			wr(DIEPCTL(0), rd(DIEPCTL(0)) | STALL);
			wr(DOEPCTL(0), rd(DOEPCTL(0)) | STALL);
		}
		arm_ep0_out();
	}

	// 34.17.6: one receive FIFO entry, RXFLVL masked while it is read.
	void read_rx()
	{
		wr(GINTMSK, rd(GINTMSK) & ~RXFLVL);
		uint32_t s = rd(GRXSTSP), ep = s & 0xF, bcnt = (s >> 4) & 0x7FF, pkt = (s >> 17) & 0xF;
		std::vector<uint8_t> d(bcnt);
		for (uint32_t i = 0; i < (bcnt + 3) / 4; i++) {
			uint32_t w = rd(FIFO(0));
			for (uint32_t k = 0; k < 4 && i * 4 + k < bcnt; k++)
				d[i * 4 + k] = (uint8_t)(w >> (8 * k));
		}
		if (pkt == 6 && bcnt == 8)
			std::memcpy(setup, d.data(), 8);
		else if (pkt == 2 && ep == 1)
			out_pkt = d;
		wr(GINTMSK, rd(GINTMSK) | RXFLVL);
	}

	void pump_echo()
	{
		if (!in1_busy && !echo.empty()) {
			in1_busy = true;
			send_in(1, echo.front().data(), (uint32_t)echo.front().size());
			echo.pop_front();
		}
	}

	// The interrupt handler; returns false when the line was low.
	bool isr()
	{
		if (!otgfs_irq(m))
			return false;
		uint32_t g = rd(GINTSTS) & rd(GINTMSK);
		if (g & USBRST) {
			wr(GINTSTS, USBRST);
			on_reset();
		}
		if (g & ENUMDNE) {
			wr(GINTSTS, ENUMDNE);
			on_enum_done();
		}
		while (rd(GINTSTS) & RXFLVL)
			read_rx();
		uint32_t d = rd(DAINT) & rd(DAINTMSK);
		if (d & (1u << 16)) {
			uint32_t f = rd(DOEPINT(0));
			wr(DOEPINT(0), f);
			if (f & STUP)
				handle_setup();
			else if (f & XFRC)
				arm_ep0_out();
		}
		if (d & (1u << 17)) {
			uint32_t f = rd(DOEPINT(1));
			wr(DOEPINT(1), f);
			if (f & XFRC) {
				echo.push_back(out_pkt);
				bulk_outs++;
				arm_ep1_out();
			}
		}
		if (d & (1u << 0))
			wr(DIEPINT(0), rd(DIEPINT(0)));
		if (d & (1u << 1)) {
			uint32_t f = rd(DIEPINT(1));
			wr(DIEPINT(1), f);
			if (f & XFRC) {
				in1_busy = false;
				bulk_ins++;
			}
		}
		if (g & SOF)
			wr(GINTSTS, SOF);
		pump_echo();
		return true;
	}
};

// The host: runs transactions, and between NAKs lets the "CPU" (the driver's ISR) run and time
// pass, as the emulator does between a USB/IP server's retries.
struct Host {
	otgfs *m;
	Driver *drv;
	uint64_t *now;
	uint8_t addr = 0;
	unsigned naks = 0;

	Host(otgfs *model, Driver *driver, uint64_t *clock) : m(model), drv(driver), now(clock)
	{
	}

	void tick()
	{
		*now += 1000; // 1 us
		otgfs_advance(m, *now);
		drv->isr();
	}
	template <class F> otgfs_resp retry(F f, int max = 200)
	{
		otgfs_resp r = OTGFS_NAK;
		for (int i = 0; i < max; i++) {
			r = f();
			if (r != OTGFS_NAK)
				return r;
			naks++;
			tick();
		}
		return r;
	}
	bool reset()
	{
		if (otgfs_host_reset(m, *now) != 0)
			return false;
		for (int i = 0; i < 20000 && !otgfs_host_running(m); i++)
			tick();
		addr = 0;
		return otgfs_host_running(m);
	}
	otgfs_resp setup(const uint8_t s[8])
	{
		otgfs_resp r = otgfs_host_setup(m, *now, addr, s);
		tick();
		return r;
	}
	otgfs_resp in(uint8_t ep, std::vector<uint8_t> &buf)
	{
		uint8_t b[64];
		uint32_t n = 0;
		otgfs_resp r = retry([&] { return otgfs_host_in(m, *now, addr, ep, b, sizeof(b), &n); });
		buf.assign(b, b + n);
		return r;
	}
	otgfs_resp out(uint8_t ep, const std::vector<uint8_t> &d)
	{
		return retry([&] { return otgfs_host_out(m, *now, addr, ep, d.data(), (uint32_t)d.size()); });
	}
	// A control read: SETUP, IN packets until a short one, OUT status. Returns the handshake of
	// the first failing stage (or ACK).
	otgfs_resp control_in(uint8_t type, uint8_t req, uint16_t value, uint16_t index, uint16_t len,
			      std::vector<uint8_t> &data)
	{
		const uint8_t s[8] = { type,           req,
				       (uint8_t)value, (uint8_t)(value >> 8),
				       (uint8_t)index, (uint8_t)(index >> 8),
				       (uint8_t)len,   (uint8_t)(len >> 8) };
		data.clear();
		otgfs_resp r = setup(s);
		if (r != OTGFS_ACK)
			return r;
		for (;;) {
			std::vector<uint8_t> p;
			r = in(0, p);
			if (r != OTGFS_ACK)
				return r;
			data.insert(data.end(), p.begin(), p.end());
			if (p.size() < 64 || data.size() >= len)
				break;
		}
		return out(0, {});
	}
	// A control write without data: SETUP, IN status.
	otgfs_resp control_nodata(uint8_t type, uint8_t req, uint16_t value, uint16_t index)
	{
		const uint8_t s[8] = {
			type, req, (uint8_t)value, (uint8_t)(value >> 8), (uint8_t)index, (uint8_t)(index >> 8), 0, 0
		};
		otgfs_resp r = setup(s);
		if (r != OTGFS_ACK)
			return r;
		std::vector<uint8_t> p;
		r = in(0, p);
		return r == OTGFS_ACK && !p.empty() ? OTGFS_NORESP : r;
	}
};

} // namespace otgfs_script
