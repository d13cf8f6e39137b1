/* swell-fwimage: bad arguments exit 2, refused images and unreadable files exit 1, each with one line
 * that says why with the figures, nothing leaked (the test build runs it under AddressSanitizer). */
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

extern "C" {
#include "swell/fwimage.h"
}

extern char **environ;

namespace {

std::string slurp(const std::string &path)
{
	std::ifstream f(path);
	return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

void put(const std::string &path, const std::vector<uint8_t> &b)
{
	std::ofstream f(path, std::ios::binary);
	f.write(reinterpret_cast<const char *>(b.data()), (std::streamsize)b.size());
}

struct Run {
	int code = -1;
	std::string out, err;
};

Run run(std::vector<std::string> args, const std::string &dir)
{
	args.insert(args.begin(), SWELL_FWIMAGE_BIN);
	std::vector<char *> argv;
	for (auto &a : args)
		argv.push_back(&a[0]);
	argv.push_back(nullptr);
	posix_spawn_file_actions_t fa;
	posix_spawn_file_actions_init(&fa);
	posix_spawn_file_actions_addopen(&fa, 1, (dir + "/out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	posix_spawn_file_actions_addopen(&fa, 2, (dir + "/err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
	pid_t pid = -1;
	const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
	posix_spawn_file_actions_destroy(&fa);
	REQUIRE(rc == 0);
	int st = 0;
	waitpid(pid, &st, 0);
	Run r;
	r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
	r.out = slurp(dir + "/out");
	r.err = slurp(dir + "/err");
	return r;
}

/* An unstamped image of n bytes: a header with magic, version, size, MCU 0x413, version 0.1.0. */
std::vector<uint8_t> image(size_t n)
{
	std::vector<uint8_t> b(n);
	for (size_t k = 0; k < n; k++)
		b[k] = (uint8_t)(k * 7 + 3);
	uint8_t *h = b.data() + SWELL_FWIMAGE_OFFSET;
	std::fill(h, h + SWELL_FWIMAGE_HDR_SIZE, 0);
	const uint32_t v[] = {SWELL_FWIMAGE_MAGIC, SWELL_FWIMAGE_HDR_VERSION | SWELL_FWIMAGE_HDR_SIZE << 16,
			      SWELL_FWIMAGE_MCU_STM32F405, SWELL_FWIMAGE_VERSION(0, 1, 0)};
	for (int w = 0; w < 4; w++)
		for (int k = 0; k < 4; k++)
			h[4 * w + k] = (uint8_t)(v[w] >> (8 * k));
	return b;
}

} // namespace

TEST_CASE("swell-fwimage: bad arguments exit 2, refused images and unreadable files exit 1, with the figures", "[fwimage][args]")
{
	char t[] = "/tmp/swell-fwimage-test-XXXXXX";
	REQUIRE(mkdtemp(t) != nullptr);
	const std::string dir = t, good = dir + "/good.bin";
	std::vector<uint8_t> img = image(3000);
	REQUIRE(swell_fwimage_stamp(img.data(), img.size()) == SWELL_OK);
	put(good, img);
	auto variant = [&](const char *name, std::vector<uint8_t> b) {
		put(dir + "/" + name, b);
		return dir + "/" + name;
	};
	std::vector<uint8_t> z = img, c = img, m = img;
	for (size_t k = 28; k < 32; k++) /* the header CRC zeroed */
		z.at(SWELL_FWIMAGE_OFFSET + k) = 0;
	c[2000] ^= 1;
	const std::string zeroed = variant("zeroed-hdr-crc.bin", z), flipped = variant("flipped.bin", c),
			  truncated = variant("truncated.bin", std::vector<uint8_t>(img.begin(), img.begin() + 2500)),
			  small = variant("small.bin", std::vector<uint8_t>(100, 0)),
			  noheader = variant("noheader.bin", std::vector<uint8_t>(1024, 0)),
			  unstamped = variant("unstamped.bin", image(3000));

	const struct {
		std::vector<std::string> args;
		int code;
		const char *says;
	} cases[] = {
		{{}, 2, "need a command and an image"},
		{{"check"}, 2, "need a command and an image"},
		{{"frob", good}, 2, "unknown command (stamp or check): frob"},
		{{"check", good, "--mcu"}, 2, "unknown or misplaced argument: --mcu"},
		{{"check", good, "--mcu", "zz"}, 2, "--mcu is not a number: zz"},
		{{"check", good, "--header-out", "x"}, 2, "unknown or misplaced argument: --header-out"},
		{{"stamp", good, "--mcu", "0x413"}, 2, "unknown or misplaced argument: --mcu"},
		{{"check", good, "extra"}, 2, "unknown or misplaced argument: extra"},
		{{"check", dir + "/missing.bin"}, 1, "missing.bin: No such file or directory"},
		{{"check", dir}, 1, "read error"},
		{{"check", zeroed}, 1, "refused: corrupted header: header CRC-32 0x00000000, computed 0x"},
		{{"check", flipped}, 1, "refused: corrupted image: image CRC-32 0x"},
		{{"check", truncated}, 1, "refused: truncated: header length 3000 bytes, file holds 2500 bytes"},
		{{"check", small}, 1, "refused: 100 bytes cannot hold the header (it ends at byte 544)"},
		{{"check", noheader}, 1, "refused: no swell image header at 0x200"},
		{{"check", unstamped}, 1, "refused: not stamped: header length 0"},
		{{"check", good, "--mcu", "0x419"}, 1, "refused: foreign image: built for MCU 0x413, expected 0x419"},
		{{"stamp", noheader}, 1, "cannot stamp: no swell image header at 0x200"},
		{{"stamp", good, "--header-out", "/nonexistent/h.bin"}, 1, "/nonexistent/h.bin: No such file or directory"},
	};
	for (const auto &k : cases) {
		const Run r = run(k.args, dir);
		std::string joined;
		for (const auto &a : k.args)
			joined += a + " ";
		INFO(joined << "-> exit " << r.code << ", stderr '" << r.err << "', stdout '" << r.out << "'");
		CHECK(r.code == k.code);
		CHECK(r.err.find(k.says) != std::string::npos);
		CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
		CHECK(r.out.empty());
	}
	/* the positive control */
	const Run ok = run({"check", good}, dir);
	CHECK(ok.code == 0);
	CHECK(ok.out.find("ok " + good + ": 3000 bytes, version 0.1.0, mcu 0x413") != std::string::npos);
	std::system(("rm -rf '" + dir + "'").c_str());
}
