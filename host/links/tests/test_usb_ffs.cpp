// FunctionFS: the descriptor and string blocks, what a rejected input leaves behind, a link that
// cannot be opened.
#include "swell_test.hpp"

#include <cerrno>
#include <cstring>
#include <string>
#include <vector>

extern "C" {
#include "swell/link.h"
}

namespace {

uint32_t le32(const uint8_t *p) { return p[0] | p[1] << 8 | p[2] << 16 | (uint32_t)p[3] << 24; }
uint16_t le16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }

swell_usb_ffs_iface vendor_iface()
{
	swell_usb_ffs_iface it{};
	it.class_code = 0xFF;
	it.ep_out = 0x01;
	it.ep_in = 0x81;
	it.fs_packet = 64;
	it.name = "swell vendor link";
	return it;
}

// Walk one descriptor set (interface + endpoints) and check its fields.
void check_set(const uint8_t *p, uint16_t packet)
{
	INFO("descriptor set for " << packet << "-byte packets");
	CHECK(p[0] == 9); // bLength
	CHECK(p[1] == 4); // INTERFACE
	CHECK(p[4] == 2); // bNumEndpoints
	CHECK(p[5] == 0xFF); // vendor class
	CHECK(p[8] == 1); // iInterface
	const uint8_t want_addr[2] = {0x01, 0x81};
	for (int e = 0; e < 2; e++) {
		const uint8_t *d = p + 9 + 7 * e;
		INFO("endpoint " << e);
		CHECK(d[0] == 7);
		CHECK(d[1] == 5); // ENDPOINT
		CHECK(d[2] == want_addr[e]);
		CHECK(d[3] == 2); // bulk
		CHECK(le16(d + 4) == packet);
	}
}

} // namespace

TEST_CASE("usb_ffs descriptor block: v2 header, full- and high-speed sets, OUT 0x01 then IN 0x81")
{
	swell_usb_ffs_iface it = vendor_iface();
	uint8_t buf[SWELL_USB_FFS_DESC_MAX];
	size_t len = 0;
	REQUIRE(swell_usb_ffs_descriptors(&it, buf, sizeof(buf), &len) == SWELL_OK);
	REQUIRE(len == 20 + 2 * 23);
	CHECK(le32(buf) == 3); // FUNCTIONFS_DESCRIPTORS_MAGIC_V2
	CHECK(le32(buf + 4) == len); // length field is the whole block
	CHECK(le32(buf + 8) == 3); // HAS_FS_DESC | HAS_HS_DESC
	CHECK(le32(buf + 12) == 3); // fs_count
	CHECK(le32(buf + 16) == 3); // hs_count
	check_set(buf + 20, 64);
	check_set(buf + 43, 512); // bulk at high speed must be 512
}

TEST_CASE("usb_ffs string block: one language 0x0409, the name NUL-terminated, length field exact")
{
	swell_usb_ffs_iface it = vendor_iface();
	uint8_t buf[SWELL_USB_FFS_STR_MAX];
	size_t len = 0;
	REQUIRE(swell_usb_ffs_strings(&it, buf, sizeof(buf), &len) == SWELL_OK);
	const std::string name = it.name;
	REQUIRE(len == 18 + name.size() + 1);
	CHECK(le32(buf) == 2); // FUNCTIONFS_STRINGS_MAGIC
	CHECK(le32(buf + 4) == len);
	CHECK(le32(buf + 8) == 1);
	CHECK(le32(buf + 12) == 1);
	CHECK(le16(buf + 16) == 0x0409);
	CHECK(std::string(reinterpret_cast<const char *>(buf + 18)) == name);
	CHECK(buf[len - 1] == 0);
}

TEST_CASE("usb_ffs rejects bad interfaces and small buffers and leaves the output untouched")
{
	struct Case {
		const char *what;
		void (*edit)(swell_usb_ffs_iface &);
		swell_err want;
	};
	const Case cases[] = {
		{"OUT address with the IN bit", [](swell_usb_ffs_iface &i) { i.ep_out = 0x81; }, SWELL_ERANGE},
		{"OUT endpoint 0", [](swell_usb_ffs_iface &i) { i.ep_out = 0x00; }, SWELL_ERANGE},
		{"IN address without the IN bit", [](swell_usb_ffs_iface &i) { i.ep_in = 0x01; }, SWELL_ERANGE},
		{"IN endpoint 0x80", [](swell_usb_ffs_iface &i) { i.ep_in = 0x80; }, SWELL_ERANGE},
		{"reserved address bits", [](swell_usb_ffs_iface &i) { i.ep_in = 0x91; }, SWELL_ERANGE},
		{"63-byte packets", [](swell_usb_ffs_iface &i) { i.fs_packet = 63; }, SWELL_ERANGE},
		{"128-byte packets at full speed", [](swell_usb_ffs_iface &i) { i.fs_packet = 128; }, SWELL_ERANGE},
		{"empty name", [](swell_usb_ffs_iface &i) { i.name = ""; }, SWELL_ERANGE},
		{"non-ASCII name", [](swell_usb_ffs_iface &i) { i.name = "caf\xc3\xa9"; }, SWELL_ERANGE},
		{"64-character name",
		 [](swell_usb_ffs_iface &i) { i.name = "0123456789012345678901234567890123456789012345678901234567890123"; },
		 SWELL_ERANGE},
		{"no name", [](swell_usb_ffs_iface &i) { i.name = nullptr; }, SWELL_EINVAL},
	};
	for (const Case &c : cases) {
		INFO(c.what);
		swell_usb_ffs_iface it = vendor_iface();
		c.edit(it);
		uint8_t buf[128];
		std::memset(buf, 0xEE, sizeof(buf));
		size_t len = 12345;
		CHECK(swell_usb_ffs_descriptors(&it, buf, sizeof(buf), &len) == c.want);
		CHECK(swell_usb_ffs_strings(&it, buf, sizeof(buf), &len) == c.want);
		CHECK(len == 12345);
		CHECK(std::vector<uint8_t>(buf, buf + sizeof(buf)) == std::vector<uint8_t>(sizeof(buf), 0xEE));
	}
	swell_usb_ffs_iface it = vendor_iface();
	uint8_t buf[65];
	size_t len = 7;
	CHECK(swell_usb_ffs_descriptors(&it, buf, sizeof(buf), &len) == SWELL_ESIZE); // needs 66
	CHECK(len == 7);
	CHECK(swell_usb_ffs_strings(&it, buf, 18 + 17, &len) == SWELL_ESIZE); // needs 36
	CHECK(len == 7);
}

TEST_CASE("FunctionFS link: a rejected argument or a missing ep0 opens nothing and says why")
{
	swell_usb_ffs_iface it = vendor_iface();
	swell_link *l = nullptr;
	const std::string long_dir(SWELL_USB_FFS_PATH_MAX, 'd');
	const int fds = swell_test::open_fds();

	CHECK(swell_link_open_ffs(&l, long_dir.c_str(), &it) == -ENAMETOOLONG);
	it.fs_packet = 65;
	CHECK(swell_link_open_ffs(&l, "/nonexistent-ffs", &it) == -EINVAL);
	it = vendor_iface();
	CHECK(swell_link_open_ffs(&l, "/nonexistent-ffs", &it) == -ENOENT);
	CHECK(swell_link_open_ffs(&l, "/dev/null", &it) == -ENOTDIR);
	CHECK(l == nullptr);
	CHECK(swell_test::open_fds() == fds); /* the failed opens left nothing open */
	CHECK(swell_link_ffs_stats(nullptr) == nullptr);
}
