/* Scene files: the shipped ones parse, a bad file is refused whole with its line, and what is written
 * reads back to the same raw values. */
#include <catch2/catch.hpp>

#include <cstdio>
#include <fstream>
#include <string>

extern "C" {
#include "swell/scene.h"
}

namespace {

std::string write_tmp(const std::string &name, const std::string &text)
{
	const std::string path = std::string(SWELL_TEST_TMP) + "/" + name;
	std::ofstream(path) << text;
	return path;
}

std::string refused(const std::string &text)
{
	const std::string path = write_tmp("refused.scene", text);
	swell_scene sc{};
	sc.n = 99; /* untouched on refusal */
	char err[300] = "";
	CHECK(swell_scene_load(path.c_str(), &sc, err, sizeof(err)) == -1);
	CHECK(sc.n == 99);
	return err;
}

} // namespace

TEST_CASE("the shipped scenes parse, with the pool and object each describes", "[scene]")
{
	struct {
		const char *file;
		int32_t nx, depth_um, mass_g, a_um;
	} want[] = {{"pool", 64, 50000, 100, 50000}, {"heavy", 64, 50000, 150, 50000}, {"shallow", 128, 20000, 100, 80000}};
	for (auto &w : want) {
		const std::string path = std::string(SWELL_SCENES_DIR) + "/" + w.file + ".scene";
		swell_scene sc{};
		char err[300] = "";
		INFO(path << ": " << err);
		REQUIRE(swell_scene_load(path.c_str(), &sc, err, sizeof(err)) == 0);
		CHECK(swell_scene_get(&sc, SWELL_SCENE_NX)->raw == w.nx);
		CHECK(swell_scene_get(&sc, SWELL_SCENE_DEPTH_UM)->raw == w.depth_um);
		CHECK(swell_scene_get(&sc, SWELL_PARAM_BODY_MASS_G)->raw == w.mass_g);
		CHECK(swell_scene_get(&sc, SWELL_PARAM_BODY_A_UM)->raw == w.a_um);
	}
	swell_scene sc{};
	char err[300];
	REQUIRE(swell_scene_load((std::string(SWELL_SCENES_DIR) + "/pool.scene").c_str(), &sc, err, sizeof(err)) == 0);
	CHECK(swell_scene_get(&sc, SWELL_PARAM_WAVE_E)->raw == SWELL_PARAM_DEF_WAVE_E); /* the built-in reference */
	/* frame.scene: the frame's values as the controller takes them */
	REQUIRE(swell_scene_load((std::string(SWELL_SCENES_DIR) + "/frame.scene").c_str(), &sc, err, sizeof(err)) == 0);
	CHECK(swell_scene_get(&sc, SWELL_PARAM_FRAME_X0)->raw == 170000);
	CHECK(swell_scene_get(&sc, SWELL_PARAM_FRAME_Y0)->raw == 230000);
	CHECK(swell_scene_get(&sc, SWELL_PARAM_FRAME_Z0)->raw == 35000);
	CHECK(swell_scene_get(&sc, SWELL_PARAM_FRAME_AXES)->raw == 213);
}

TEST_CASE("a bad scene file is refused whole and the reason names its line", "[scene]")
{
	CHECK(refused("# ok\nbody.mass = 80 g\nbody.mass = 90 g\n")
		      .find("refused.scene:3: body.mass given twice "
			    "(first on line 2)") != std::string::npos);
	CHECK(refused("body.mass = 80 g\nbody.weight = 1 kg\n").find(":2: no parameter 'body.weight'") != std::string::npos);
	CHECK(refused("\n\npool.nx = 512 cells\n").find(":3: pool.nx: 512 cells is outside 2 cells .. 256 cells") !=
	      std::string::npos);
	CHECK(refused("wave.damping 0.1\n").find(":1: 'wave.damping 0.1' is not 'name = value unit'") != std::string::npos);
	CHECK(refused("body.h = 4 kg\n").find(":1: body.h: unit 'kg' is not mm") != std::string::npos);
	CHECK(refused("body.mass = 80 g\ndev.rate = 100 Hz\n").find(":2: dev.rate is read only") != std::string::npos);
}

TEST_CASE("a written scene reads back to the same raw values (12 digits are enough for Q1.30)", "[scene]")
{
	swell_scene sc{};
	REQUIRE(swell_scene_put(&sc, SWELL_SCENE_DX_UM, 6250) == 0);
	REQUIRE(swell_scene_put(&sc, SWELL_PARAM_WAVE_E, 215723192) == 0);
	REQUIRE(swell_scene_put(&sc, SWELL_PARAM_WAVE_DAMPING, 1073742) == 0);
	REQUIRE(swell_scene_put(&sc, SWELL_PARAM_FORCE_GAIN, 65537) == 0);
	REQUIRE(swell_scene_put(&sc, SWELL_PARAM_BODY_H_UM, 12345) == 0);
	CHECK(swell_scene_put(&sc, SWELL_PARAM_BODY_MASS_G, 0) == -1); /* out of range */
	const std::string path = std::string(SWELL_TEST_TMP) + "/written.scene";
	FILE *f = std::fopen(path.c_str(), "w");
	REQUIRE(f != nullptr);
	REQUIRE(swell_scene_write(f, &sc, "test") == 0);
	std::fclose(f);
	swell_scene back{};
	char err[300] = "";
	INFO(err);
	REQUIRE(swell_scene_load(path.c_str(), &back, err, sizeof(err)) == 0);
	REQUIRE(back.n == sc.n);
	for (size_t k = 0; k < sc.n; k++) {
		INFO(sc.v[k].d->name);
		CHECK(back.v[k].raw == sc.v[k].raw);
	}
}
