/* Values with units against the parameter table: what people type becomes the raw value
 * the controller takes, and a value of another kind or out of range is refused before anything is sent. */
#include <catch2/catch.hpp>

#include <string>

extern "C" {
#include "swell/param_text.h"
}

namespace {

int32_t parse_ok(const char *name, const char *text)
{
	const swell_param_desc *d = swell_param_by_name(name);
	REQUIRE(d != nullptr);
	char err[200] = "";
	int32_t raw = -12345;
	INFO(name << " '" << text << "': " << err);
	REQUIRE(swell_param_parse(d, text, &raw, err, sizeof(err)) == 0);
	return raw;
}

std::string parse_err(const char *name, const char *text)
{
	const swell_param_desc *d = swell_param_by_name(name);
	REQUIRE(d != nullptr);
	char err[200] = "";
	int32_t raw = -12345;
	CHECK(swell_param_parse(d, text, &raw, err, sizeof(err)) == -1);
	CHECK(raw == -12345); /* untouched */
	return err;
}

} // namespace

TEST_CASE("values with units and SI prefixes become the parameter's raw integers", "[param][units]")
{
	CHECK(parse_ok("body.mass", "80g") == 80);
	CHECK(parse_ok("body.mass", "80 g") == 80);
	CHECK(parse_ok("body.mass", "0.08kg") == 80);
	CHECK(parse_ok("body.mass", "120") == 120); /* no unit: the parameter's own */
	CHECK(parse_ok("body.h", "40mm") == 40000);
	CHECK(parse_ok("body.h", "4cm") == 40000);
	CHECK(parse_ok("body.h", "0.04m") == 40000);
	CHECK(parse_ok("body.h", "12500um") == 12500);
	CHECK(parse_ok("force.max", "5N") == 5000000);
	CHECK(parse_ok("force.max", "500mN") == 500000);
	CHECK(parse_ok("force.rate", "0.5kN/s") == 500000000);
	CHECK(parse_ok("body.damper", "2N*s/m") == 2000);
	CHECK(parse_ok("wave.damping", "0.02") == 21474836); /* round(0.02 * 2^30) */
	CHECK(parse_ok("wave.e", "0.2009") == 215714732); /* round(0.2009 * 2^30) */
	CHECK(parse_ok("force.gain", "0.5") == 32768);
}

TEST_CASE("a unit of another kind, a non-number or a value out of range is refused with the range in units", "[param][units]")
{
	CHECK(parse_err("body.mass", "80mm").find("unit 'mm' is not g") != std::string::npos);
	CHECK(parse_err("wave.damping", "0.02g").find("has no unit") != std::string::npos);
	CHECK(parse_err("body.mass", "heavy").find("not a number") != std::string::npos);
	const std::string r = parse_err("body.mass", "200kg");
	INFO(r);
	CHECK(r.find("outside 1 g .. 100000 g") != std::string::npos);
	CHECK(parse_err("body.h", "0.5mm").find("outside 1 mm .. 500 mm") != std::string::npos);
	CHECK(!parse_err("ctl.autorun", "2").empty());
}

TEST_CASE("raw values print in the parameter's unit", "[param][units]")
{
	char buf[64];
	swell_param_format(swell_param_by_name("body.mass"), 100, buf, sizeof(buf));
	CHECK(std::string(buf) == "100 g");
	swell_param_format(swell_param_by_name("body.h"), 50000, buf, sizeof(buf));
	CHECK(std::string(buf) == "50 mm");
	swell_param_format(swell_param_by_name("force.max"), 10000000, buf, sizeof(buf));
	CHECK(std::string(buf) == "10 N");
	swell_param_format(swell_param_by_name("force.gain"), 65536, buf, sizeof(buf));
	CHECK(std::string(buf) == "1");
}
