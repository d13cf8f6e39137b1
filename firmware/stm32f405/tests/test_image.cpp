// Image header (common/ fwimage) and the timer divider of the tick.
#include <catch2/catch.hpp>

#include <vector>

extern "C" {
#include "logic/timer_div.h"
#include "swell/fwimage.h"
}

static std::vector<uint8_t> make_image(size_t len)
{
	std::vector<uint8_t> img(len);
	for (size_t i = 0; i < len; i++)
		img[i] = uint8_t(i * 131u + 7u);
	uint8_t *h = img.data() + SWELL_FWIMAGE_OFFSET;
	const uint8_t hdr[16] = {'S', 'W', 'I', 'M', 1, 0, 32, 0, 0x13, 0x04, 0, 0, 3, 2, 1, 0};
	std::copy(hdr, hdr + 16, h);
	std::fill(h + 16, h + 32, 0);
	return img;
}

TEST_CASE("a stamped image verifies and any flipped bit is refused", "[fwimage]")
{
	auto img = make_image(3000);
	REQUIRE(swell_fwimage_stamp(img.data(), img.size()) == SWELL_OK);
	swell_fwimage_hdr h{};
	REQUIRE(swell_fwimage_verify(img.data(), img.size(), SWELL_FWIMAGE_MCU_STM32F405, &h) == SWELL_OK);
	CHECK(h.length == 3000);
	CHECK(h.version == 0x00010203u);
	CHECK(h.mcu_id == 0x413u);
	unsigned accepted = 0;
	for (size_t byte = 0; byte < img.size(); byte += 7) {
		img[byte] ^= 0x10;
		if (swell_fwimage_verify(img.data(), img.size(), SWELL_FWIMAGE_MCU_STM32F405, nullptr) == SWELL_OK)
			accepted++;
		img[byte] ^= 0x10;
	}
	INFO(accepted << " corrupted images accepted");
	CHECK(accepted == 0);
}

TEST_CASE("image verification names what is wrong", "[fwimage]")
{
	auto img = make_image(1024);
	REQUIRE(swell_fwimage_stamp(img.data(), img.size()) == SWELL_OK);
	CHECK(swell_fwimage_verify(img.data(), img.size(), 0x411, nullptr) == SWELL_EINVAL);
	CHECK(swell_fwimage_verify(img.data(), 1000, 0x413, nullptr) == SWELL_ETRUNC);
	CHECK(swell_fwimage_verify(img.data(), 0x210, 0x413, nullptr) == SWELL_ETRUNC);
	// More flash readable than the image: still fine (the target passes the flash size).
	std::vector<uint8_t> big(img);
	big.resize(4096, 0xFF);
	CHECK(swell_fwimage_verify(big.data(), big.size(), 0x413, nullptr) == SWELL_OK);
	img[SWELL_FWIMAGE_OFFSET] = 'X';
	CHECK(swell_fwimage_verify(img.data(), img.size(), 0x413, nullptr) == SWELL_EUNKNOWN);
	auto v2 = make_image(1024);
	v2[SWELL_FWIMAGE_OFFSET + 4] = 2;
	CHECK(swell_fwimage_stamp(v2.data(), v2.size()) == SWELL_EVERSION);
	auto before = v2;
	CHECK(v2 == before); // nothing written on error
}

TEST_CASE("the tick divider is exact, 16-bit safe and refuses rates that do not divide", "[tick]")
{
	const uint32_t clocks[] = {84000000, 16000000, 42000000};
	const uint32_t rates[] = {250, 1000, 2500, 8000, 10};
	for (uint32_t clk : clocks) {
		for (uint32_t rate : rates) {
			uint32_t psc = 0, arr = 0;
			INFO(clk << " Hz / " << rate << " Hz");
			REQUIRE(fw_timer_div(clk, rate, &psc, &arr) == SWELL_OK);
			CHECK(uint64_t(psc + 1) * (arr + 1) * rate == clk);
			CHECK(arr <= 0xFFFF);
			CHECK(psc <= 0xFFFF);
		}
	}
	uint32_t psc = 5, arr = 6;
	CHECK(fw_timer_div(84000000, 7777, &psc, &arr) == SWELL_ERANGE);
	CHECK(fw_timer_div(84000000, 0, &psc, &arr) == SWELL_ERANGE);
	CHECK(fw_timer_div(84000000, 84000000, &psc, &arr) == SWELL_ERANGE);
	CHECK(psc == 5);
	CHECK(arr == 6);
}
