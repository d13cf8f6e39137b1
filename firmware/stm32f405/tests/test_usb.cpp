// USB descriptors and standard control requests (logic/usb_desc), no registers.
#include <catch2/catch.hpp>

#include <string>

extern "C" {
#include "logic/usb_desc.h"
#include "swell/transport.h"
}

static usb_ctrl_reply ask(uint8_t type, uint8_t req, uint16_t value, uint16_t index, uint16_t len, usb_dev_state st = {5, 1, 0})
{
	static uint8_t scratch[USB_STRING_MAX];
	const uint8_t raw[8] = {type,           req,
				uint8_t(value), uint8_t(value >> 8),
				uint8_t(index), uint8_t(index >> 8),
				uint8_t(len),   uint8_t(len >> 8)};
	usb_setup s;
	usb_setup_parse(raw, &s);
	usb_ctrl_reply r;
	usb_ctrl_decide(&s, &st, scratch, &r);
	return r;
}

TEST_CASE("device descriptor carries the project's VID/PID, EP0 64 bytes, one configuration", "[usb]")
{
	const uint8_t *d = usb_device_desc;
	CHECK(d[0] == 18);
	CHECK(d[1] == 1);
	CHECK((d[2] | d[3] << 8) == 0x0200);
	CHECK(d[7] == 64);
	CHECK((d[8] | d[9] << 8) == SWELL_USB_VID);
	CHECK((d[10] | d[11] << 8) == SWELL_USB_PID);
	CHECK((d[8] | d[9] << 8) == 0x1209);
	CHECK((d[10] | d[11] << 8) == 0x0001);
	CHECK(d[17] == 1);
}

TEST_CASE("configuration: one vendor interface with bulk OUT 0x01 and bulk IN 0x81 of 64 bytes", "[usb]")
{
	const uint8_t *c = usb_config_desc;
	// The descriptors chain exactly to wTotalLength.
	unsigned total = c[2] | c[3] << 8, off = 0, n = 0, ifaces = 0, eps = 0;
	while (off < USB_CONFIG_DESC_LEN && c[off] >= 2) {
		if (c[off + 1] == 4) {
			ifaces++;
			CHECK(c[off + 2] == 0); // bInterfaceNumber
			CHECK(c[off + 4] == 2); // endpoints
			CHECK(c[off + 5] == 0xFF); // vendor class
		}
		if (c[off + 1] == 5) {
			eps++;
			CHECK((c[off + 2] == 0x01 || c[off + 2] == 0x81));
			CHECK(c[off + 3] == 0x02); // bulk
			CHECK((c[off + 4] | c[off + 5] << 8) == 64);
		}
		off += c[off];
		n++;
	}
	CHECK(off == total);
	CHECK(total == USB_CONFIG_DESC_LEN);
	CHECK(c[4] == 1);
	CHECK(ifaces == 1);
	CHECK(eps == 2);
	CHECK(n == 4);
	CHECK(usb_config_desc[9 + 9 + 2] == 0x01);
	CHECK(usb_config_desc[9 + 9 + 7 + 2] == 0x81);
}

TEST_CASE("GET_DESCRIPTOR answers with at most wLength bytes in one packet", "[usb]")
{
	for (uint16_t want : {8, 18, 64, 255}) {
		auto r = ask(0x80, 6, 0x0100, 0, want);
		REQUIRE(r.action == USB_CTRL_DATA_IN);
		CHECK(r.len == std::min<uint16_t>(want, 18));
		r = ask(0x80, 6, 0x0200, 0, want);
		REQUIRE(r.action == USB_CTRL_DATA_IN);
		CHECK(r.len == std::min<uint16_t>(want, 32));
	}
	for (uint16_t idx = 0; idx < 4; idx++) {
		auto r = ask(0x80, 6, uint16_t(0x0300 | idx), 0x0409, 255);
		REQUIRE(r.action == USB_CTRL_DATA_IN);
		CHECK(r.len < 64); // fits one packet without a zero-length terminator
		CHECK(r.data[0] == r.len);
		CHECK(r.data[1] == 3);
	}
	auto r = ask(0x80, 6, 0x0302, 0x0409, 255);
	std::string s;
	for (unsigned i = 2; i < r.len; i += 2) {
		CHECK(r.data[i + 1] == 0);
		s += char(r.data[i]);
	}
	CHECK(s.find("swell") == 0);
	CHECK(ask(0x80, 6, 0x0304, 0x0409, 255).action == USB_CTRL_STALL);
	CHECK(ask(0x80, 6, 0x0600, 0, 10).action == USB_CTRL_STALL); // device qualifier: FS only
}

TEST_CASE("enumeration requests move the device through address and configured states", "[usb]")
{
	usb_dev_state fresh{0, 0, 0};
	auto r = ask(0x00, 5, 42, 0, 0, fresh);
	CHECK(r.action == USB_CTRL_SET_ADDRESS);
	CHECK(r.value == 42);
	CHECK(ask(0x00, 5, 128, 0, 0, fresh).action == USB_CTRL_STALL);
	CHECK(ask(0x00, 9, 1, 0, 0, fresh).action == USB_CTRL_STALL); // not addressed yet
	usb_dev_state addressed{42, 0, 0};
	r = ask(0x00, 9, 1, 0, 0, addressed);
	CHECK(r.action == USB_CTRL_SET_CONFIG);
	CHECK(r.value == 1);
	CHECK(ask(0x00, 9, 2, 0, 0, addressed).action == USB_CTRL_STALL);
	r = ask(0x80, 8, 0, 0, 1, {42, 1, 0});
	REQUIRE(r.action == USB_CTRL_DATA_IN);
	CHECK(r.data[0] == 1);
	CHECK(ask(0x01, 11, 0, 0, 0, {42, 1, 0}).action == USB_CTRL_STATUS);
	CHECK(ask(0x01, 11, 1, 0, 0, {42, 1, 0}).action == USB_CTRL_STALL);
}

TEST_CASE("endpoint halt is set, reported and cleared only on the bulk endpoints", "[usb]")
{
	usb_dev_state st{42, 1, 0};
	auto r = ask(0x02, 3, 0, 0x81, 0, st);
	CHECK(r.action == USB_CTRL_SET_HALT);
	CHECK(r.ep == 0x81);
	r = ask(0x02, 1, 0, 0x01, 0, st);
	CHECK(r.action == USB_CTRL_CLEAR_HALT);
	CHECK(r.ep == 0x01);
	CHECK(ask(0x02, 3, 0, 0x82, 0, st).action == USB_CTRL_STALL);
	st.halted = 2;
	r = ask(0x82, 0, 0, 0x81, 2, st);
	REQUIRE(r.action == USB_CTRL_DATA_IN);
	CHECK(r.data[0] == 1);
	r = ask(0x82, 0, 0, 0x01, 2, st);
	REQUIRE(r.action == USB_CTRL_DATA_IN);
	CHECK(r.data[0] == 0);
}

TEST_CASE("vendor and class requests on EP0 are stalled (the protocol runs on bulk)", "[usb]")
{
	CHECK(ask(0xC0, 1, 0, 0, 8).action == USB_CTRL_STALL);
	CHECK(ask(0x40, 1, 0, 0, 0).action == USB_CTRL_STALL);
	CHECK(ask(0x21, 0, 0, 0, 0).action == USB_CTRL_STALL);
}
