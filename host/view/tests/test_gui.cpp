// swell-view rendering tests (label gui): the real program, headless under its own Xvfb, fed a known
// scene through the real encoders and decoders (pattern sources) or a recording of one; the PNG it
// writes is read back with the independent reader and its pixels checked against the scene.
//
// Geometry of --view top at 640 x 480 (render.c, camera()): the pool is fitted with a 5 % margin,
// s = 0.9 * min(640 / Lx, 480 / Ly) pixels a metre, centred; for the 0.4 m test pool s = 1080.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <netinet/in.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sstream>
#include <string>
#include <sys/types.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

extern char **environ;

#include "png_read.hpp"

extern "C" {
#include "swell/link.h"
}

namespace {

const int W = 640, H = 480;
const double OBJ = 0.05; // the object side, m: swell-view's default (the controller's default body)
const double L = 0.4, S = 0.9 * std::min(W / L, H / L);

// A loopback UDP port that was free a moment ago: the link library's socket on any free port, closed.
int free_udp_port()
{
	sockaddr_in any{}, bound{};
	any.sin_family = AF_INET;
	any.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	const int fd = swell_udp_socket(&any, 0, 0, nullptr, &bound);
	REQUIRE(fd >= 0);
	close(fd);
	return ntohs(bound.sin_port);
}

double col_of(double x_m) { return W / 2.0 + (x_m - L / 2) * S; }
double row_of(double y_m) { return H / 2.0 - (y_m - L / 2) * S; }

// The leak checker stays on for swell-view and swell-view-gen: a leak in swell's own code fails the
// run (the leak checker's exit status). Mesa's software driver is loaded from the start so that its
// dlclose at exit does not turn the blocks it still holds into leaks of an unknown module; what
// Mesa, GL, X11 and GLFW keep for themselves is suppressed by library name (lsan-gl.supp).
std::vector<std::string> leak_env()
{
	std::vector<std::string> env = {"ASAN_OPTIONS=detect_leaks=1:verify_asan_link_order=0",
					"LSAN_OPTIONS=suppressions=" SWELL_LSAN_SUPP ":print_suppressions=0"};
	if (*SWELL_GL_DRIVER)
		env.push_back("LD_PRELOAD=" SWELL_GL_DRIVER);
	return env;
}

// The same as words to put before a command in a shell line.
std::string leak_sh()
{
	std::string s;
	for (const auto &e : leak_env())
		s += e + " ";
	return s;
}

// One Xvfb for the whole test process, on a display number free at the time (ctest runs test
// processes side by side: each picks its own number from its pid and waits for the socket).
struct xserver {
	pid_t pid = -1;
	std::string display;
	xserver()
	{
		for (int attempt = 0; attempt < 20 && display.empty(); attempt++) {
			int n = 100 + int((getpid() * 7 + attempt * 13) % 800);
			std::string sock = "/tmp/.X11-unix/X" + std::to_string(n), lock = "/tmp/.X" + std::to_string(n) + "-lock";
			if (access(sock.c_str(), F_OK) == 0 || access(lock.c_str(), F_OK) == 0)
				continue;
			std::string num = ":" + std::to_string(n);
			pid = fork();
			if (pid == 0) {
				execlp("Xvfb", "Xvfb", num.c_str(), "-screen", "0", "1024x768x24", "-nolisten", "tcp",
				       (char *)nullptr);
				_exit(127);
			}
			for (int k = 0; k < 100; k++) {
				usleep(50000);
				if (access(sock.c_str(), F_OK) == 0) {
					display = num;
					break;
				}
				if (waitpid(pid, nullptr, WNOHANG) == pid) {
					pid = -1;
					break;
				}
			}
		}
	}
	~xserver()
	{
		if (pid > 0) {
			kill(pid, SIGTERM);
			waitpid(pid, nullptr, 0);
		}
	}
};

xserver &x()
{
	static xserver s;
	return s;
}

// Scratch files of this test process, removed when it ends (kept, for a look at the pictures, when
// SWELL_VIEW_TEST_KEEP is set).
struct scratch {
	std::string dir;
	~scratch()
	{
		if (dir.size() > 5 && !std::getenv("SWELL_VIEW_TEST_KEEP"))
			std::system(("rm -rf '" + dir + "'").c_str());
	}
};

std::string tmpdir()
{
	static scratch s;
	if (s.dir.empty()) {
		char t[] = "/tmp/swell-view-test-XXXXXX";
		REQUIRE(mkdtemp(t) != nullptr);
		s.dir = t;
	}
	return s.dir;
}

struct run_result {
	int status = -1;
	std::string out;
};

// Runs swell-view with args; stdout and stderr together.
run_result view(const std::string &args)
{
	run_result r;
	REQUIRE_FALSE(x().display.empty());
	// a guard against a program that never ends, not a criterion: CPU time (ulimit -t: 300 frames of
	// 1024 x 768 cost about 7 s of CPU here), which the machine's load does not stretch as it does wall
	// time (the same run took 60 s of wall time at a load of 20); and a wall limit for a program that
	// blocks (waiting for X), well above what the load stretches
	std::string cmd =
		"ulimit -t 60; DISPLAY=" + x().display + " " + leak_sh() + "timeout 600 " SWELL_VIEW_BIN " " + args + " 2>&1";
	FILE *p = popen(cmd.c_str(), "r");
	REQUIRE(p != nullptr);
	char buf[4096];
	size_t n;
	while ((n = fread(buf, 1, sizeof(buf), p)) > 0)
		r.out.append(buf, n);
	int st = pclose(p);
	r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
	return r;
}

// A recording of a known scene made by swell-view-gen (cached per test process).
std::string recording(const std::string &scene)
{
	std::string path = tmpdir() + "/" + scene + ".rec";
	if (access(path.c_str(), F_OK) != 0) {
		std::string cmd =
			leak_sh() + SWELL_VIEW_GEN_BIN " --scene " + scene + " --frames 25 --out " + path + " > /dev/null";
		REQUIRE(std::system(cmd.c_str()) == 0);
	}
	return "replay-fast:" + path;
}

struct image {
	pngr::decoded d;
	const uint8_t *at(int c, int r) const { return &d.pixels[(size_t(r) * d.w + size_t(c)) * 3]; }
};

// A top view of a source: no HUD, 640 x 480, deterministic time.
image shot(const std::string &source, const std::string &extra = "", int after = 4, run_result *out = nullptr,
	   int want_status = 0)
{
	std::string path = tmpdir() + "/shot.png";
	std::remove(path.c_str());
	// no antialiasing (cheaper on llvmpipe) unless the caller asks for it with --msaa
	std::string aa = extra.find("--msaa") == std::string::npos ? " --msaa 0" : "";
	run_result r = view("--headless --steady --view top --no-hud --size 640x480" + aa + " --source " + source + " --after " +
			    std::to_string(after) + " --screenshot " + path + " " + extra);
	INFO(r.out);
	REQUIRE(r.status == want_status);
	if (out)
		*out = r;
	image im;
	im.d = pngr::read_file(path);
	REQUIRE(im.d.error == "");
	REQUIRE(im.d.w == unsigned(W));
	REQUIRE(im.d.h == unsigned(H));
	return im;
}

bool is_water(const uint8_t *p) { return p[2] > p[0] + 40 && p[2] > 70; }
bool is_object(const uint8_t *p) { return p[0] > 150 && p[1] > 60 && p[1] < 160 && p[2] < 70; }
bool is_arrow(const uint8_t *p) { return p[0] > 90 && p[1] < 50 && p[2] > 25 && p[0] > 2 * p[2]; }

double luma(const uint8_t *p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

double mean_luma(const image &im, double x_m, double y_m, int half)
{
	double s = 0;
	int n = 0;
	for (int r = int(row_of(y_m)) - half; r <= int(row_of(y_m)) + half; r++)
		for (int c = int(col_of(x_m)) - half; c <= int(col_of(x_m)) + half; c++, n++)
			s += luma(im.at(c, r));
	return s / n;
}

struct box {
	int n = 0;
	int c0 = 1 << 30, r0 = 1 << 30, c1 = -1, r1 = -1;
	double sc = 0, sr = 0;
	void add(int c, int r)
	{
		n++;
		c0 = std::min(c0, c);
		c1 = std::max(c1, c);
		r0 = std::min(r0, r);
		r1 = std::max(r1, r);
		sc += c;
		sr += r;
	}
};

template <class F> box find(const image &im, F pred)
{
	box b;
	for (int r = 0; r < H; r++)
		for (int c = 0; c < W; c++)
			if (pred(im.at(c, r)))
				b.add(c, r);
	return b;
}

long counter(const std::string &out, const std::string &name)
{
	// the summary line: "swell-view: F frames, B bad, D dropped, ..."
	size_t at = out.find(" " + name);
	if (at == std::string::npos)
		return -1;
	size_t start = out.rfind(' ', at - 1);
	return std::atol(out.c_str() + start + 1);
}

struct scene_case {
	const char *source;
	double bump_x, bump_y; // pool fractions
	double obj_x, obj_y; // m
	double fx, fy; // N
};
const scene_case cases[] = {
	{"bump", 0.70, 0.50, 0.30 * L, 0.35 * L, 1.5, -1.0},
	{"bump2", 0.30, 0.40, 0.72 * L, 0.70 * L, -1.2, 1.6},
};

} // namespace

TEST_CASE("water fills the pool inside its walls and nothing outside them")
{
	image im = shot(recording("bump"), "--msaa 4"); // the default antialiasing, as users see it
	const double t = 0.03 * L; // wall thickness (render.c)
	long inside = 0, inside_water = 0, outside_water = 0, wall_water = 0;
	for (int r = 0; r < H; r++)
		for (int c = 0; c < W; c++) {
			const uint8_t *p = im.at(c, r);
			bool in = c > col_of(0) + 2 && c < col_of(L) - 2 && r > row_of(L) + 2 && r < row_of(0) - 2;
			bool out = c < col_of(-t) - 2 || c > col_of(L + t) + 2 || r < row_of(L + t) - 2 || r > row_of(-t) + 2;
			bool obj = is_object(p) || is_arrow(p);
			if (in && !obj) {
				inside++;
				inside_water += is_water(p);
			} else if (out) {
				outside_water += is_water(p);
			} else if (!in) {
				wall_water += is_water(p) && (c < col_of(-1.5 * t / 3) || c > col_of(L + t / 2));
			}
		}
	INFO("inside the pool: " << inside_water << " water pixels of " << inside);
	CHECK(inside_water >= inside * 99 / 100);
	CHECK(outside_water == 0);
	CHECK(wall_water == 0);
}

TEST_CASE("a raised bump is lit on its +x flank (the light's side) and red in the colour scale")
{
	for (const auto &k : cases) {
		image im = shot(recording(k.source));
		double bx = k.bump_x * L, by = k.bump_y * L, sg = 0.025;
		double east = mean_luma(im, bx + sg, by, 3), west = mean_luma(im, bx - sg, by, 3);
		double flat = mean_luma(im, k.bump_x > 0.5 ? 0.1 * L : 0.9 * L, 0.9 * L, 3);
		INFO(k.source << ": luma east flank " << east << ", west flank " << west << ", flat water " << flat);
		CHECK(east > west + 20);
		CHECK(east > flat + 20);

		image col = shot(recording(k.source), "--colour --range 2");
		const uint8_t *top = col.at(int(col_of(bx)), int(row_of(by)));
		const uint8_t *far = col.at(int(col_of(k.bump_x > 0.5 ? 0.1 * L : 0.9 * L)), int(row_of(0.9 * L)));
		INFO("bump top rgb " << int(top[0]) << "," << int(top[1]) << "," << int(top[2]) << "; flat water rgb "
				     << int(far[0]) << "," << int(far[1]) << "," << int(far[2]));
		CHECK(top[0] > top[2] + 60); // 3 mm over a 2 mm range: full red
		CHECK(std::abs(int(far[0]) - int(far[2])) < 30); // 0 mm: neutral
	}
}

TEST_CASE("the object is drawn where its pose says, at its size")
{
	for (const auto &k : cases) {
		image im = shot(recording(k.source));
		box b = find(im, is_object);
		double cc = (b.c0 + b.c1) / 2.0, cr = (b.r0 + b.r1) / 2.0;
		INFO(k.source << ": object pixels " << b.n << ", box centre (" << cc << ", " << cr << ") px, expected ("
			      << col_of(k.obj_x) << ", " << row_of(k.obj_y) << "); size " << b.c1 - b.c0 + 1 << " x "
			      << b.r1 - b.r0 + 1 << " px, expected " << OBJ * S);
		REQUIRE(b.n > 1000);
		CHECK(std::abs(cc - col_of(k.obj_x)) < 2.5);
		CHECK(std::abs(cr - row_of(k.obj_y)) < 2.5);
		CHECK(std::abs(b.c1 - b.c0 + 1 - OBJ * S) < 3);
		CHECK(std::abs(b.r1 - b.r0 + 1 - OBJ * S) < 3);
	}
}

TEST_CASE("the object's size comes from the controller's CTL_INFO, --object only until one arrives")
{
	// bump-info: the bump scene from a controller that sends CTL_INFO with a 100 x 60 x 40 mm object;
	// --object 30x30x30 must lose to it. The bump scene sends none: --object 80x80x50 is drawn.
	struct size_case {
		const char *scene, *object;
		double a, b; // m, expected on screen
		const char *said;
	};
	const size_case sizes[] = {
		{"bump-info", "30x30x30", 0.100, 0.060,
		 "swell-view: object 100.0 x 60.0 x 40.0 mm from the controller (CTL_INFO), firmware 2.7.1"},
		{"bump", "80x80x50", 0.080, 0.080,
		 "swell-view: object 80.0 x 80.0 x 50.0 mm from --object (no CTL_INFO received)"},
	};
	for (const auto &k : sizes) {
		run_result r;
		image im = shot(recording(k.scene), std::string("--object ") + k.object, 4, &r);
		box b = find(im, is_object);
		double cc = (b.c0 + b.c1) / 2.0, cr = (b.r0 + b.r1) / 2.0;
		INFO(k.scene << " with --object " << k.object << ": object " << b.c1 - b.c0 + 1 << " x " << b.r1 - b.r0 + 1
			     << " px, expected " << k.a * S << " x " << k.b * S << " px, centre (" << cc << ", " << cr
			     << "); swell-view said: " << r.out);
		REQUIRE(b.n > 500);
		CHECK(std::abs(b.c1 - b.c0 + 1 - k.a * S) < 3);
		CHECK(std::abs(b.r1 - b.r0 + 1 - k.b * S) < 3);
		CHECK(std::abs(cc - col_of(0.30 * L)) < 2.5); // the pose is the same in both
		CHECK(std::abs(cr - row_of(0.35 * L)) < 2.5);
		CHECK(r.out.find(k.said) != std::string::npos);
	}
}

TEST_CASE("the force arrow starts at the object and points the way the force does")
{
	for (const auto &k : cases) {
		image im = shot(recording(k.source));
		box a = find(im, is_arrow);
		REQUIRE(a.n > 100);
		// image rows grow downwards: flip y
		double dx = a.sc / a.n - col_of(k.obj_x), dy = -(a.sr / a.n - row_of(k.obj_y));
		double got = std::atan2(dy, dx) * 180 / M_PI, want = std::atan2(k.fy, k.fx) * 180 / M_PI;
		double err = std::remainder(got - want, 360.0);
		INFO(k.source << ": arrow centroid " << dx << ", " << dy << " px from the object; direction " << got
			      << " deg, force " << want << " deg");
		CHECK(std::abs(err) < 6);
		// its length in the picture: the horizontal part of 40 mm per newton
		double horiz = std::hypot(k.fx, k.fy) * 0.040 * S;
		double far_end = 0;
		for (int r = a.r0; r <= a.r1; r++)
			for (int c = a.c0; c <= a.c1; c++)
				if (is_arrow(im.at(c, r)))
					far_end = std::max(far_end, std::hypot(c - col_of(k.obj_x), r - row_of(k.obj_y)));
		INFO("arrow reaches " << far_end << " px, horizontal force length " << horiz << " px");
		CHECK(std::abs(far_end - horiz) < 0.08 * horiz + 3);
	}
}

TEST_CASE("late join: without a scene description nothing is drawn and the screen says so")
{
	std::string path = tmpdir() + "/late.png";
	run_result r = view("--headless --steady --view top --size 640x480 --source pattern:bump --faults noscene "
			    "--after 12 --screenshot " +
			    path);
	INFO(r.out);
	REQUIRE(r.status == 0);
	pngr::decoded d = pngr::read_file(path);
	REQUIRE(d.error == "");
	image im{d};
	box water = find(im, is_water), obj = find(im, is_object);
	// the status text, amber, in the middle of the screen where the pool would be
	box amber;
	for (int rr = H / 2 - 40; rr < H / 2 + 40; rr++)
		for (int c = 0; c < W; c++) {
			const uint8_t *p = im.at(c, rr);
			if (p[0] > 200 && p[1] > 150 && p[2] < 100)
				amber.add(c, rr);
		}
	CHECK(water.n == 0);
	CHECK(obj.n == 0);
	INFO("amber text pixels in the middle: " << amber.n);
	CHECK(amber.n > 200);
	CHECK(counter(r.out, "quads") == 0); // heights arrived, and none was taken without a scene
}

TEST_CASE("garbage between the packets changes nothing on screen and is counted")
{
	run_result clean_r, junk_r;
	image clean = shot("pattern:bump", "", 12, &clean_r);
	image junk = shot("pattern:bump", "--faults garbage", 12, &junk_r);
	long differ = 0;
	for (size_t k = 0; k < clean.d.pixels.size(); k++)
		differ += clean.d.pixels[k] != junk.d.pixels[k];
	long bad = counter(junk_r.out, "bad"), frames = counter(junk_r.out, "frames");
	INFO("bytes that differ " << differ << "; bad frames " << bad << " of " << frames << " good");
	CHECK(differ == 0);
	CHECK(bad > 100);
	CHECK(counter(clean_r.out, "bad") == 0);
}

TEST_CASE("truncated, corrupt, reordered and lost packets: no crash, no wrong heights drawn")
{
	run_result clean_r, hurt_r;
	image clean = shot("pattern:bump", "", 4, &clean_r);
	// the static scene is refreshed every 200 ms (10 frames): after 5 refreshes every quad has come
	// through at least once (what is lost shifts from one refresh to the next)
	image hurt = shot("pattern:bump", "--faults truncate,corrupt,reorder,drop", 50, &hurt_r);
	long differ = 0;
	int worst = 0;
	for (size_t k = 0; k < clean.d.pixels.size(); k++) {
		int d = std::abs(int(clean.d.pixels[k]) - int(hurt.d.pixels[k]));
		differ += d > 0;
		worst = std::max(worst, d);
	}
	INFO("bytes that differ " << differ << ", worst " << worst << "; " << hurt_r.out);
	CHECK(differ == 0);
	CHECK(counter(hurt_r.out, "bad") > 100);
	CHECK(counter(hurt_r.out, "dropped") > 10);
	CHECK(counter(hurt_r.out, "late") > 10);
}

TEST_CASE("controller restart: the old scene goes, the new one is shown")
{
	run_result r;
	image im = shot("pattern:bump", "--faults restart", 30, &r); // the restart happens at 0.4 s, frame 20
	CHECK(counter(r.out, "restarts") == 1);
	box b = find(im, is_object);
	double cc = (b.c0 + b.c1) / 2.0;
	INFO("object box centre column " << cc << ", the new run puts it at " << col_of(0.70 * L));
	CHECK(std::abs(cc - col_of(0.70 * L)) < 2.5);
	double bump_new = mean_luma(im, 0.30 * L + 0.025, 0.5 * L, 3), bump_old = mean_luma(im, 0.70 * L + 0.025, 0.5 * L, 3);
	INFO("east flank of the new bump " << bump_new << ", of the old one " << bump_old);
	CHECK(bump_new > bump_old + 20);
}

TEST_CASE("only tiles whose heights changed are uploaded")
{
	run_result still, moving;
	shot("pattern:bump", "", 32, &still); // three refreshes of the same heights
	shot("pattern:ripple", "", 32, &moving); // every tile changes every frame
	INFO(still.out << moving.out);
	// "uploaded N tiles (T texels)": 64 tiles at the scene, then nothing for identical refreshes
	size_t at = still.out.find("uploaded ");
	REQUIRE(at != std::string::npos);
	CHECK(std::atol(still.out.c_str() + at + 9) == 64);
	at = moving.out.find("uploaded ");
	REQUIRE(at != std::string::npos);
	CHECK(std::atol(moving.out.c_str() + at + 9) > 64 * 25);
}

TEST_CASE("a recording replays to the picture of the live scene, and --record keeps what was received")
{
	image live = shot("pattern:bump");
	std::string copy = tmpdir() + "/copy.rec";
	image replayed = shot(recording("bump"), "--record " + copy);
	image again = shot("replay-fast:" + copy);
	long differ = 0, differ2 = 0;
	for (size_t k = 0; k < live.d.pixels.size(); k++) {
		differ += live.d.pixels[k] != replayed.d.pixels[k];
		differ2 += replayed.d.pixels[k] != again.d.pixels[k];
	}
	INFO("bytes that differ: live against replay " << differ << ", replay against its re-recording " << differ2);
	CHECK(differ == 0);
	CHECK(differ2 == 0);
}

TEST_CASE("a cut recording shows what it holds and a recording of noise draws nothing")
{
	std::string rec = recording("bump").substr(12);
	std::ifstream in(rec, std::ios::binary);
	std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
	REQUIRE(bytes.size() > 30000);
	// cut in the middle of a record, after the first full set of tiles
	std::string cut = tmpdir() + "/cut.rec";
	std::ofstream(cut, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size() * 2 / 3 + 7));
	run_result cr;
	image part = shot("replay-fast:" + cut, "", 4, &cr, 1); // damaged: exit 1, said on stderr
	INFO(cr.out);
	CHECK(find(part, is_water).n > 100000);
	CHECK(find(part, is_object).n > 1000);
	CHECK(cr.out.find("the recording is damaged") != std::string::npos);

	// the right header, then noise: nothing decodes, nothing is drawn
	std::string noise = tmpdir() + "/noise.rec";
	{
		std::ofstream o(noise, std::ios::binary);
		o.write(bytes.data(), 16);
		uint32_t s = 99;
		for (int k = 0; k < 200000; k++) {
			s = s * 1664525u + 1013904223u;
			o.put(char(s >> 24));
		}
	}
	run_result nr;
	image none = shot("replay-fast:" + noise, "", 4, &nr, 1);
	INFO(nr.out);
	CHECK(find(none, is_water).n == 0);
	CHECK(find(none, is_object).n == 0);

	// not a recording at all: refused with a reason, exit status 2
	run_result bad = view("--headless --source replay-fast:" + cut.substr(0, cut.size() - 7) + "bump.rec.nope");
	CHECK(bad.status == 2);
}

TEST_CASE("live over UDP: the scene stays on screen when the sender stops, marked as no data")
{
	// whether the viewer holds its port yet (/proc/net/udp lists local ports in hex)
	auto held = [](int p) {
		char h[16];
		snprintf(h, sizeof(h), ":%04X ", (unsigned)p & 0xffffu);
		std::ifstream u("/proc/net/udp");
		std::string line;
		while (std::getline(u, line))
			if (line.find(h) != std::string::npos && line.find(h) < 40)
				return true;
		return false;
	};
	const int port = free_udp_port();
	std::string path = tmpdir() + "/udp.png";
	// its exit status is appended to its output ("exit N") once it has ended and the leak check is done
	const std::string log = tmpdir() + "/udp.out";
	std::string cmd = "(DISPLAY=" + x().display + " " + leak_sh() +
		SWELL_VIEW_BIN " --headless --view top --size 640x480 --msaa 0 --fps 60 --source udp:" + std::to_string(port) +
		" --after 240 --screenshot " + path + " > " + log + " 2>&1; echo \"exit $?\" >> " + log + ") &";
	REQUIRE(std::system(cmd.c_str()) == 0);
	// wait until the viewer has bound its port
	bool bound = false;
	for (int k = 0; k < 200 && !(bound = held(port)); k++)
		usleep(50000);
	REQUIRE(bound);
	// one second of the known scene, live at 50 frames a second; then silence
	std::string gen = leak_sh() + SWELL_VIEW_GEN_BIN " --frames 50 --udp " + std::to_string(port) + " > /dev/null";
	REQUIRE(std::system(gen.c_str()) == 0);
	// the viewer writes its picture at frame 240 (4 s at 60 frames a second) and exits; a sanitizer
	// build on a loaded machine can take a minute or more to get there (waited up to 4 minutes)
	std::string out;
	for (int k = 0; k < 2400 && out.find("\nexit ") == std::string::npos; k++) {
		usleep(100000);
		std::ifstream o(log);
		out.assign(std::istreambuf_iterator<char>(o), std::istreambuf_iterator<char>());
	}
	INFO(out);
	CHECK(out.find("\nexit 0\n") != std::string::npos); // and no leak
	pngr::decoded d = pngr::read_file(path);
	REQUIRE(d.error == "");
	image im{d};
	CHECK(find(im, is_water).n > 100000); // what was received stays shown
	CHECK(find(im, is_object).n > 500);
	box amber; // "NO DATA FOR x.x S", amber, top right
	for (int r = 0; r < 40; r++)
		for (int c = W / 2; c < W; c++) {
			const uint8_t *p = im.at(c, r);
			if (p[0] > 200 && p[1] > 150 && p[2] < 100)
				amber.add(c, r);
		}
	INFO("amber status pixels top right: " << amber.n);
	CHECK(amber.n > 80);
	CHECK(counter(out, "bad") == 0); // (loss is possible on a starved machine: not checked here)
}

TEST_CASE("bad arguments: a one-line reason and exit status 2, before any window")
{
	const char *bad[] = {"--size 10x10",
			     "--source nowhere",
			     "--view side",
			     "--after 0",
			     "--object 60x60",
			     "--faults garbage",
			     "--source pattern:bump --faults fire",
			     "--source pattern:plaid",
			     "--record x.rec --source pattern:bump",
			     "--bogus",
			     "--zscale",
			     "--iface 256",
			     "--iface 1",
			     "--iface 1 --source pattern:bump",
			     "--iface -1 --source usb",
			     "--force-limit 0",
			     "--csv",
			     "--source pattern:bump:4",
			     "--source pattern:ripple:x"};
	for (const char *a : bad) {
		std::string cmd = leak_sh() + "DISPLAY= " SWELL_VIEW_BIN " " + std::string(a) + " 2>&1";
		FILE *p = popen(cmd.c_str(), "r");
		REQUIRE(p != nullptr);
		std::string out;
		char buf[512];
		size_t n;
		while ((n = fread(buf, 1, sizeof(buf), p)) > 0)
			out.append(buf, n);
		int st = pclose(p);
		INFO("swell-view " << a << " said: " << out);
		CHECK(WEXITSTATUS(st) == 2);
		CHECK(std::count(out.begin(), out.end(), '\n') == 1);
	}
	std::string gen = leak_sh() + SWELL_VIEW_GEN_BIN " --scene plaid --out /dev/null > /dev/null 2>&1";
	CHECK(WEXITSTATUS(std::system(gen.c_str())) == 2);
	std::string help = leak_sh() + SWELL_VIEW_BIN " --help > /dev/null";
	CHECK(std::system(help.c_str()) == 0);
}

// ---- used as a person uses it: a real window, real X input (xdotool), pictures from its own S key ----
namespace {

// xdotool on the test's display; its exit status.
int xdo(const std::string &args)
{
	std::string cmd = "DISPLAY=" + x().display + " timeout 30 xdotool " + args + " > /dev/null 2>&1";
	return std::system(cmd.c_str());
}

std::string slurp(const std::string &path)
{
	std::ifstream in(path);
	return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// One swell-view with a window, run in its own directory (the S key writes swell-view-NNNN.png there).
struct session {
	pid_t pid = -1;
	std::string dir, out, wid;
	unsigned shots = 0;
	explicit session(const std::string &args)
	{
		static int n = 0;
		dir = tmpdir() + "/session" + std::to_string(n++);
		REQUIRE(std::system(("mkdir -p '" + dir + "'").c_str()) == 0);
		out = dir + "/out.txt";
		std::string cmd = "cd '" + dir + "' && DISPLAY=" + x().display + " " + leak_sh() + "exec " SWELL_VIEW_BIN " " +
			args + " > out.txt 2>&1";
		pid = fork();
		if (pid == 0) {
			execl("/bin/sh", "sh", "-c", cmd.c_str(), (char *)nullptr);
			_exit(127);
		}
		REQUIRE(pid > 0);
		// wait for the window (xdotool --sync), then give it the pointer and the keyboard
		std::string f = dir + "/wid";
		REQUIRE(std::system(("DISPLAY=" + x().display +
				     " timeout 60 xdotool search --sync --onlyvisible --name '^swell-view$' > '" + f +
				     "' 2> /dev/null")
					    .c_str()) == 0);
		wid = slurp(f);
		wid = wid.substr(0, wid.find('\n'));
		REQUIRE_FALSE(wid.empty());
		REQUIRE(xdo("mousemove --window " + wid + " 320 240") == 0);
		REQUIRE(xdo("windowfocus --sync " + wid) == 0);
	}
	// Press S and wait until swell-view says it wrote the picture; the picture.
	image press_s()
	{
		std::string name = "swell-view-" + std::string(4 - std::to_string(shots).size(), '0') + std::to_string(shots);
		shots++;
		REQUIRE(xdo("key s") == 0);
		bool done = false;
		for (int k = 0; k < 600 && !(done = slurp(out).find("wrote " + name + ".png") != std::string::npos); k++)
			usleep(50000);
		INFO(slurp(out));
		REQUIRE(done);
		image im;
		im.d = pngr::read_file(dir + "/" + name + ".png");
		REQUIRE(im.d.error == "");
		REQUIRE(im.d.w == unsigned(W));
		REQUIRE(im.d.h == unsigned(H));
		return im;
	}
	// A picture rendered after everything sent so far: the first S may share a frame with the input
	// before it (the frame is drawn before its events are read), the second cannot.
	image settled()
	{
		press_s();
		return press_s();
	}
	// Waits for the program to end; its exit status (-1: still running after 30 s).
	int wait_exit()
	{
		for (int k = 0; k < 300; k++) {
			int st;
			if (waitpid(pid, &st, WNOHANG) == pid) {
				pid = -1;
				return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
			}
			usleep(100000);
		}
		return -1;
	}
	~session()
	{
		if (pid > 0) {
			kill(pid, SIGKILL);
			waitpid(pid, nullptr, 0);
		}
	}
};

long bytes_differ(const image &a, const image &b)
{
	long n = 0;
	for (size_t k = 0; k < a.d.pixels.size() && k < b.d.pixels.size(); k++)
		n += a.d.pixels[k] != b.d.pixels[k];
	return n +
		long(a.d.pixels.size() > b.d.pixels.size() ? a.d.pixels.size() - b.d.pixels.size()
							   : b.d.pixels.size() - a.d.pixels.size());
}

// HUD text pixels: its light grey ink (render: 225, 232, 240 top-left; 200, 210, 220 bottom-left).
long hud_ink(const image &im)
{
	long n = 0;
	for (int r = 0; r < H; r++)
		for (int c = 0; c < W; c++) {
			const uint8_t *p = im.at(c, r);
			n += (p[0] == 225 && p[1] == 232 && p[2] == 240) || (p[0] == 200 && p[1] == 210 && p[2] == 220);
		}
	return n;
}

bool is_red_water(const uint8_t *p) { return p[0] > p[2] + 60 && p[0] > 120 && p[1] < 150 && !is_arrow(p) && !is_object(p); }
// The object seen from any side in the orbit view: orange, lit or in shade.
bool is_orange(const uint8_t *p) { return p[0] > 100 && p[0] > p[1] + 45 && p[1] > p[2] + 35; }
// The map view's footprint outline: near black, neutral.
bool is_outline(const uint8_t *p)
{
	return p[0] < 70 && p[1] < 70 && p[2] < 70 && std::abs(p[0] - p[1]) < 12 && std::abs(p[1] - p[2]) < 12;
}
// Pixels matching pred inside a rectangle of the picture.
template <class F> box find_in(const image &im, int c0, int r0, int c1, int r1, F pred)
{
	box b;
	for (int r = r0; r < r1; r++)
		for (int c = c0; c < c1; c++)
			if (pred(im.at(c, r)))
				b.add(c, r);
	return b;
}

} // namespace

TEST_CASE("a person's session: pause, orbit drag, reset, wheel zoom, HUD, colour, map view, charts, resume, quit")
{
	// the animated ripple at 640 x 480 in a real window; time advances 20 ms a frame (--steady)
	session s("--source pattern:ripple --size 640x480 --msaa 0 --steady");
	image live0 = s.settled();
	image live1 = s.press_s();
	INFO("bytes that differ between two live pictures: " << bytes_differ(live0, live1));
	CHECK(bytes_differ(live0, live1) > 1000); // the ripple moves

	// P pauses: the picture is frozen, byte for byte, while time and reception go on
	REQUIRE(xdo("key p") == 0);
	image a = s.settled();
	usleep(300000);
	image a2 = s.press_s();
	INFO("paused pictures 0.3 s apart differ in " << bytes_differ(a, a2) << " bytes");
	CHECK(bytes_differ(a, a2) == 0);
	box obj_a = find(a, is_orange);
	long water_a = find(a, is_water).n;
	REQUIRE(obj_a.n > 200);

	// a left drag of 100 px to the right orbits: the object moves across the screen
	// (at a hand's pace: events a frame apart, not all in one frame's queue)
	REQUIRE(xdo("mousemove --window " + s.wid + " 250 240 sleep 0.1 mousedown 1 sleep 0.1 mousemove --window " + s.wid +
		    " 300 240 sleep 0.1 mousemove --window " + s.wid + " 350 240 sleep 0.1 mouseup 1") == 0);
	image b = s.settled();
	box obj_b = find(b, is_orange);
	double moved = std::hypot(obj_b.sc / std::max(obj_b.n, 1) - obj_a.sc / obj_a.n,
				  obj_b.sr / std::max(obj_b.n, 1) - obj_a.sr / obj_a.n);
	INFO("after the drag: " << bytes_differ(a, b) << " bytes differ, the object (" << obj_b.n << " pixels) moved " << moved
				<< " px");
	CHECK(obj_b.n > 200);
	CHECK(moved > 20);

	// R resets the view: the paused picture of before the drag, byte for byte
	REQUIRE(xdo("key r") == 0);
	image c = s.settled();
	INFO("after R: " << bytes_differ(a, c) << " bytes differ from the picture before the drag");
	CHECK(bytes_differ(a, c) == 0);

	// the wheel zooms: three notches up bring the pool closer, six down from there take it further
	REQUIRE(xdo("click --repeat 3 --delay 30 4") == 0);
	long water_in = find(s.settled(), is_water).n;
	REQUIRE(xdo("click --repeat 6 --delay 30 5") == 0);
	long water_out = find(s.settled(), is_water).n;
	INFO("water pixels: reset " << water_a << ", zoomed in " << water_in << ", zoomed out " << water_out);
	CHECK(water_in > water_a * 13 / 10);
	CHECK(water_out < water_a * 8 / 10);
	REQUIRE(xdo("key r") == 0);

	// H hides the HUD and shows it again
	REQUIRE(xdo("key h") == 0);
	image no_hud = s.settled();
	REQUIRE(xdo("key h") == 0);
	image hud_back = s.settled();
	INFO("HUD ink pixels: shown " << hud_ink(a) << ", hidden " << hud_ink(no_hud) << "; back: " << bytes_differ(a, hud_back)
				      << " bytes differ");
	CHECK(hud_ink(a) > 1000);
	CHECK(hud_ink(no_hud) == 0);
	CHECK(bytes_differ(a, hud_back) == 0);

	// C colours the water by height and draws the legend: red crests, a bar from red (top) to blue
	REQUIRE(xdo("key c") == 0);
	image col = s.settled();
	REQUIRE(xdo("key c") == 0);
	image col_off = s.settled();
	// the legend at scale 1 (main.c, canvas.c): canvas at (8, 84); bar 6 px in, 18 wide, rows 18..161
	const uint8_t *bar_top = col.at(8 + 6 + 9, 84 + 18 + 2), *bar_bottom = col.at(8 + 6 + 9, 84 + 18 + 141);
	INFO("red water pixels: colour " << find(col, is_red_water).n << ", shaded " << find(a, is_red_water).n << "; legend top "
					 << int(bar_top[0]) << "," << int(bar_top[1]) << "," << int(bar_top[2]) << " bottom "
					 << int(bar_bottom[0]) << "," << int(bar_bottom[1]) << "," << int(bar_bottom[2])
					 << "; C again: " << bytes_differ(a, col_off) << " bytes differ");
	CHECK(find(col, is_red_water).n > 2000);
	CHECK(find(a, is_red_water).n == 0);
	CHECK(bar_top[0] > bar_top[2] + 120);
	CHECK(bar_bottom[2] > bar_bottom[0] + 120);
	CHECK(bytes_differ(a, col_off) == 0);

	// V: the height map from above (no shaded box: the footprint outlined) and back to the orbit;
	// the outline looked for inside the pool between the HUD's panels
	REQUIRE(xdo("key v") == 0);
	image map = s.settled();
	REQUIRE(xdo("key v") == 0);
	image map_off = s.settled();
	box outline = find_in(map, int(col_of(0)) + 4, 80, int(col_of(L)) - 4, 410, is_outline);
	INFO("map: object-coloured pixels " << outline.n << " in a box " << outline.c1 - outline.c0 + 1 << " x "
					    << outline.r1 - outline.r0 + 1 << "; red water " << find(map, is_red_water).n
					    << "; V again: " << bytes_differ(a, map_off) << " bytes differ");
	REQUIRE(outline.n > 50);
	CHECK(std::abs((outline.c1 - outline.c0) - (outline.r1 - outline.r0)) <= 2); // square from above
	CHECK(std::abs((outline.c0 + outline.c1) / 2.0 - col_of(0.30 * L)) < 3); // the pose of the ripple pattern
	CHECK(std::abs((outline.r0 + outline.r1) / 2.0 - row_of(0.35 * L)) < 3);
	CHECK(!is_outline(map.at((outline.c0 + outline.c1) / 2, (outline.r0 + outline.r1) / 2))); // hollow
	CHECK(find(map, is_red_water).n > 2000);
	CHECK(bytes_differ(a, map_off) == 0);

	// G shows the charts at the right (the scene moves over to make room), G again hides them
	REQUIRE(xdo("key g") == 0);
	image ch = s.settled();
	auto is_fabs = [](const uint8_t *p) { return p[0] == 255 && p[1] == 170 && p[2] == 60; };
	auto is_sub = [](const uint8_t *p) { return p[0] == 110 && p[1] == 220 && p[2] == 130; };
	box fabs_line = find(ch, is_fabs), sub_line = find(ch, is_sub);
	// (a flat line each: the ripple's force and submersion are constant; as long as the time received)
	INFO("charts: |F| pixels " << fabs_line.n << " from column " << fabs_line.c0 << ", submersion pixels " << sub_line.n);
	CHECK(fabs_line.n > 15);
	CHECK(fabs_line.c0 > W / 2);
	CHECK(sub_line.n > 15);
	REQUIRE(xdo("key g") == 0);
	CHECK(find(s.settled(), is_fabs).n == 0);

	// space resumes: the ripple moves again
	REQUIRE(xdo("key space") == 0);
	image r0 = s.settled();
	image r1 = s.press_s();
	INFO("after space: two pictures differ in " << bytes_differ(r0, r1) << " bytes");
	CHECK(bytes_differ(r0, r1) > 1000);

	// Q quits: exit status 0 and the summary
	REQUIRE(xdo("key q") == 0);
	CHECK(s.wait_exit() == 0);
	CHECK(slurp(s.out).find(" frames, ") != std::string::npos);

	// Esc quits too
	session e("--source pattern:bump --size 640x480 --msaa 0");
	REQUIRE(xdo("key Escape") == 0);
	CHECK(e.wait_exit() == 0);
}

namespace {

// The bob pattern (gen.h): received at the steady clock, frame k at 1.02 + 0.02 (k - 1) s, its pose
// and force at phase (t - 1.02 s) / 2 s.
const double BOB_T0 = 1.02;
double bob_sin(double t_s) { return std::sin(2 * M_PI * std::fmod(t_s - BOB_T0, 2.0) / 2.0); }
double bob_fz(double t_s) { return 0.8 + 1.0 * bob_sin(t_s); }
double bob_bottom_mm(double t_s) { return -10.0 + 6.0 * bob_sin(t_s); }
// its energy account (gen_energy_at), with the heartbeats: created 0.5 mJ a second, D 2 mJ sin
double bob_created_mJ(double t_s) { return 0.5 * (t_s - BOB_T0); }
double bob_balance_mJ(double t_s) { return 2.0 * bob_sin(t_s); }

} // namespace

TEST_CASE("the charts plot the force, pose and energy the pattern sends, at the values and times it sends them")
{
	// 1024 x 768: charts at scale 2; frame 300 is t = 7 s: 6 s of samples in the window
	const int w = 1024, after = 300;
	std::string path = tmpdir() + "/charts.png";
	run_result r = view("--headless --steady --no-hud --msaa 0 --size 1024x768 --source pattern:bob --charts "
			    "--force-limit 2.5 --after " +
			    std::to_string(after) + " --screenshot " + path);
	INFO(r.out);
	REQUIRE(r.status == 0);
	pngr::decoded d = pngr::read_file(path);
	REQUIRE(d.error == "");
	REQUIRE(d.w == unsigned(w));
	REQUIRE(d.h == 768u);
	auto px = [&](int c, int rr) { return &d.pixels[(size_t(rr) * w + size_t(c)) * 3]; };
	double now = 1.0 + after * 0.02;
	// layout (main.c, chart.c) at scale 2: canvas 30 cells of 12 px wide at (1024 - 360 - 16, 72); chart
	// k's plot at y 9 + 108 k + 27, 72 px tall, x from 72 to 72 + 282
	const int cx = w - 360 - 16, cy = 72, lh = 18;
	struct plot_px {
		int x0, y0, w, h;
		double lo, hi;
	};
	auto plot = [&](int k, double lo, double hi) {
		return plot_px{cx + 72, cy + lh / 2 + k * (4 * lh + lh + lh / 2 + lh / 2) + lh + lh / 2, 360 - 72 - 6, 4 * lh, lo,
			       hi};
	};
	// the curve's value in each column (mean row of its colour) against the pattern at that column's time
	auto compare = [&](const plot_px &p, const uint8_t rgb[3], double (*truth)(double), double tol, const char *what) {
		int cols = 0, seen = 0;
		double worst = 0, worst_t = 0;
		for (int c = 3; c < p.w - 3; c++) {
			double t = now - (1.0 - double(c) / (p.w - 1)) * 10.0;
			if (t < BOB_T0 + 0.1)
				continue;
			cols++;
			double sr = 0;
			int n = 0;
			for (int rr = p.y0; rr < p.y0 + p.h; rr++) {
				const uint8_t *q = px(p.x0 + c, rr);
				if (q[0] == rgb[0] && q[1] == rgb[1] && q[2] == rgb[2]) {
					sr += rr;
					n++;
				}
			}
			if (!n)
				continue;
			seen++;
			double v = p.hi - (sr / n - p.y0) / (p.h - 1) * (p.hi - p.lo);
			// the line joins samples 20 ms apart; a column spans 28 ms: compare with the nearest truth
			double best = 1e9;
			for (double dt = -0.03; dt <= 0.03; dt += 0.005)
				best = std::min(best, std::abs(v - truth(t + dt)));
			if (best > worst) {
				worst = best;
				worst_t = t;
			}
		}
		INFO(what << ": curve in " << seen << " of " << cols << " columns; worst error " << worst << " at t = " << worst_t
			  << " s (tolerance " << tol << ")");
		CHECK(seen >= cols * 95 / 100);
		CHECK(worst < tol);
	};
	// force: |F| peaks at sqrt(1.5^2 + 1^2 + 1.8^2) = 2.55 N: +-(nice(1.1 x 2.55) = 5) N; 0.14 N a pixel
	const uint8_t fz_rgb[3] = {90, 200, 255}, bottom_rgb[3] = {255, 150, 30}, sub_rgb[3] = {110, 220, 130};
	compare(plot(0, -5, 5), fz_rgb, bob_fz, 0.25, "force z (N)");
	// heights: bottom -16..-4 mm, water 0: 5 % margin, steps of nice(17.6 / 4) = 5: -20..5 mm
	compare(plot(1, -20, 5), bottom_rgb, bob_bottom_mm, 0.6, "object bottom (mm)");
	compare(
		plot(2, 0, 100), sub_rgb, [](double t) { return -bob_bottom_mm(t) / 50.0 * 100.0; }, 2.5, "submersion (%)");
	// energy: created up to 3 mJ, D +-2 mJ: +-(nice(1.1 x 3) = 5) mJ; 0.14 mJ a pixel
	const uint8_t created_rgb[3] = {255, 90, 200}, balance_rgb[3] = {120, 230, 230};
	compare(plot(5, -5, 5), created_rgb, bob_created_mJ, 0.25, "energy created (mJ)");
	compare(plot(5, -5, 5), balance_rgb, bob_balance_mJ, 0.25, "energy balance D (mJ)");
	// the limit line: dashed red at +2.5 N and -2.5 N
	plot_px f = plot(0, -5, 5);
	for (double lim : {2.5, -2.5}) {
		int row = f.y0 + int(std::lround((5 - lim) / 10 * (f.h - 1))), red = 0;
		for (int c = 0; c < f.w; c++)
			for (int dr = -1; dr <= 1; dr++) {
				const uint8_t *q = px(f.x0 + c, row + dr);
				red += q[0] == 255 && q[1] == 70 && q[2] == 70;
			}
		INFO("limit line at " << lim << " N (row " << row << "): " << red << " red pixels over " << f.w << " columns");
		CHECK(red > f.w * 2 / 3);
	}
}

TEST_CASE("the CSV file of --csv holds the pattern's pose and force as received, and the poses lost")
{
	for (const char *faults : {"", "--faults drop"}) {
		std::string csv = tmpdir() + "/bob.csv";
		run_result r =
			view("--headless --steady --no-hud --msaa 0 --size 320x240 --source pattern:bob --frames 100 --csv " +
			     csv + " " + faults);
		INFO(faults << ": " << r.out);
		REQUIRE(r.status == 0);
		std::ifstream in(csv);
		std::string line;
		REQUIRE(std::getline(in, line));
		CHECK(line ==
		      "t_s,pose_seq,bottom_mm,water_mm,submersion_pct,fz_N,f_abs_N,limited,frame_hz,latency_ms,"
		      "lost_poses,created_mJ,balance_mJ");
		int poses = 0, forces = 0, seq_gaps = 0, last_seq = -1;
		long lost = 0;
		double worst_z = 0, worst_f = 0;
		while (std::getline(in, line)) {
			std::vector<std::string> f;
			size_t at = 0;
			for (size_t c; (c = line.find(',', at)) != std::string::npos; at = c + 1)
				f.push_back(line.substr(at, c - at));
			f.push_back(line.substr(at));
			REQUIRE(f.size() == 13);
			double t = std::atof(f[0].c_str());
			if (!f[2].empty()) {
				poses++;
				worst_z = std::max(worst_z, std::abs(std::atof(f[2].c_str()) - bob_bottom_mm(t)));
				int seq = std::atoi(f[1].c_str());
				if (last_seq >= 0)
					seq_gaps += (seq - last_seq + 256) % 256 - 1;
				last_seq = seq;
				lost = std::atol(f[10].c_str());
			}
			if (!f[5].empty()) {
				forces++;
				worst_f = std::max(worst_f, std::abs(std::atof(f[5].c_str()) - bob_fz(t)));
			}
		}
		INFO(faults << ": " << poses << " poses, " << forces << " forces; worst z error " << worst_z << " mm, fz "
			    << worst_f << " N; sequence gaps " << seq_gaps << ", lost_poses " << lost);
		CHECK(worst_z < 0.011); // 10 um on the wire
		CHECK(worst_f < 0.006); // 0.01 N on the wire
		CHECK(lost == seq_gaps);
		if (*faults) {
			CHECK(lost > 5);
			CHECK(poses < 100);
		} else {
			CHECK(lost == 0);
			CHECK(poses == 100);
			CHECK(forces == 100);
		}
	}
}

TEST_CASE("the map view shows heights in the colour scale and the object's footprint where its pose says")
{
	image im = shot(recording("bump"), "--view map");
	box b = find_in(im, int(col_of(0)) + 4, int(row_of(L)) + 4, int(col_of(L)) - 4, int(row_of(0)) - 4, is_outline);
	double cc = (b.c0 + b.c1) / 2.0, cr = (b.r0 + b.r1) / 2.0;
	INFO("outline pixels " << b.n << ", box centre (" << cc << ", " << cr << ") px, expected (" << col_of(0.30 * L) << ", "
			       << row_of(0.35 * L) << "); size " << b.c1 - b.c0 + 1 << " x " << b.r1 - b.r0 + 1
			       << " px, the footprint " << OBJ * S << " px and the pen");
	REQUIRE(b.n > 100);
	CHECK(b.n < 1000); // an outline, not a filled box
	CHECK(std::abs(cc - col_of(0.30 * L)) < 2.5);
	CHECK(std::abs(cr - row_of(0.35 * L)) < 2.5);
	CHECK(std::abs(b.c1 - b.c0 + 1 - (OBJ + 2 * 0.0016) * S) < 3);
	const uint8_t *top = im.at(int(col_of(0.70 * L)), int(row_of(0.50 * L)));
	const uint8_t *flat = im.at(int(col_of(0.90 * L)), int(row_of(0.10 * L)));
	INFO("bump top rgb " << int(top[0]) << "," << int(top[1]) << "," << int(top[2]) << "; flat " << int(flat[0]) << ","
			     << int(flat[1]) << "," << int(flat[2]));
	CHECK(top[0] > top[2] + 100);
	CHECK(std::abs(int(flat[0]) - int(flat[2])) < 30);
}

// Luminance statistics of the water seen straight down, away from the object: the pool inside its
// walls less a margin, less the object's footprint, its contact ring and the shadow it casts the sun's
// way (-x, -y of it: the light comes from +x, +y, high). With near = true, only the water within
// 60 mm of the footprint's edge (the wake); otherwise all of it.
struct luma_stats {
	double sd = 0, grad = 0; // standard deviation, mean |horizontal difference| of neighbours
	long n = 0;
};
luma_stats water_luma(const image &im, double ox, double oy, bool near)
{
	const double half = OBJ / 2, m = 0.006;
	double s = 0, s2 = 0, g = 0;
	luma_stats st;
	for (int r = int(row_of(L - m)); r < int(row_of(m)); r++)
		for (int c = int(col_of(m)); c < int(col_of(L - m)) - 1; c++) {
			double x = (c - W / 2.0) / S + L / 2, y = (H / 2.0 - r) / S + L / 2;
			double ex = std::max(std::fabs(x - ox) - half, 0.0), ey = std::max(std::fabs(y - oy) - half, 0.0);
			bool shadow =
				x > ox - half - 0.05 && x < ox + half + 0.008 && y > oy - half - 0.025 && y < oy + half + 0.008;
			double e = std::hypot(ex, ey);
			if (shadow || e < 0.008 || (near && e > 0.06))
				continue;
			double l = luma(im.at(c, r));
			s += l;
			s2 += l * l;
			g += std::fabs(luma(im.at(c + 1, r)) - l);
			st.n++;
		}
	double mean = s / double(st.n);
	st.sd = std::sqrt(std::max(s2 / double(st.n) - mean * mean, 0.0));
	st.grad = g / double(st.n);
	return st;
}

TEST_CASE("the water look shows millimetre waves: a bobbing object's wake varies the light 3x a still pool's")
{
	// pattern wake: the object bobbing with 1.2 mm rings of 40 mm running out from it (the demo's
	// largest wave); pattern still: the same object on still water. Same run, same camera.
	const double ox = 0.30 * L, oy = 0.35 * L;
	image wake = shot("pattern:wake"), still = shot("pattern:still");
	image wake_flat = shot("pattern:wake", "--shading flat"), still_flat = shot("pattern:still", "--shading flat");
	luma_stats w = water_luma(wake, ox, oy, false), st = water_luma(still, ox, oy, false);
	luma_stats wn = water_luma(wake, ox, oy, true), sn = water_luma(still, ox, oy, true);
	luma_stats fw = water_luma(wake_flat, ox, oy, false), fs = water_luma(still_flat, ox, oy, false);
	INFO("water look, whole pool: luma sd " << w.sd << " with waves, " << st.sd << " still (ratio " << w.sd / st.sd
						<< "); mean gradient " << w.grad << " / " << st.grad);
	INFO("water look, within 60 mm of the object: luma sd " << wn.sd << " with its wake, " << sn.sd << " still (ratio "
								<< wn.sd / sn.sd << ")");
	INFO("flat look, whole pool: luma sd " << fw.sd << " with waves, " << fs.sd << " still");
	REQUIRE(w.n > 10000);
	REQUIRE(wn.n > 2000);
	CHECK(w.sd >= 3 * st.sd);
	CHECK(w.grad >= 2 * st.grad); // sharper edges too, though the tiles' lines have edges of their own
	CHECK(wn.sd >= 3 * sn.sd); // the wake is seen around the object
	CHECK(w.sd >= 2 * fw.sd); // and the water look shows it better than the flat one
	// the flat look is the older picture: the same waves, much less light variation
	CHECK(fw.sd > fs.sd);
}

TEST_CASE("the flat shading is one flag away: a still pool in one body colour, no floor pattern")
{
	// a still pool in the flat look is one colour (no tiles): its luminance hardly varies
	const double ox = 0.30 * L, oy = 0.35 * L;
	luma_stats fs = water_luma(shot("pattern:still", "--shading flat"), ox, oy, false);
	luma_stats ws = water_luma(shot("pattern:still"), ox, oy, false);
	INFO("still pool luma sd: flat " << fs.sd << ", water look (its floor tiles) " << ws.sd);
	CHECK(fs.sd < 3.0);
	CHECK(ws.sd > fs.sd + 1.0);
}

TEST_CASE("a 256 x 256 pool, drawn on a coarser mesh, shows its bump and object where they are")
{
	// the same 0.4 m scene in 256 x 256 cells of 1.5625 mm: the mesh has 128 x 128 quads, the
	// shading every cell
	image im = shot("pattern:bump:256");
	box b = find(im, is_object);
	double cc = (b.c0 + b.c1) / 2.0, cr = (b.r0 + b.r1) / 2.0;
	double bx = 0.70 * L, by = 0.50 * L, sg = 0.025;
	double east = mean_luma(im, bx + sg, by, 3), west = mean_luma(im, bx - sg, by, 3);
	INFO("object box centre (" << cc << ", " << cr << ") px, expected (" << col_of(0.30 * L) << ", " << row_of(0.35 * L)
				   << "); bump flanks: east luma " << east << ", west " << west);
	REQUIRE(b.n > 1000);
	CHECK(std::abs(cc - col_of(0.30 * L)) < 2.5);
	CHECK(std::abs(cr - row_of(0.35 * L)) < 2.5);
	CHECK(east > west + 20);
	CHECK(find(im, is_water).n > 100000);
}

TEST_CASE("SIGINT and SIGTERM end a run with its summary and exit 0, without a display exit 1 and nothing leaked")
{
	REQUIRE_FALSE(x().display.empty());
	for (int sig : {SIGINT, SIGTERM}) {
		const std::string out = tmpdir() + "/signal.txt";
		// swell-view itself (no shell in between: its own SigCgt is read below)
		std::vector<std::string> args = {SWELL_VIEW_BIN, "--source", "pattern:bump", "--headless", "--size", "160x120",
						 "--msaa",       "0",        "--fps",        "20"};
		std::vector<char *> argv;
		for (auto &a : args)
			argv.push_back(&a[0]);
		argv.push_back(nullptr);
		std::vector<std::string> env = leak_env();
		env.push_back("DISPLAY=" + x().display);
		for (char **e = environ; *e; e++)
			if (strncmp(*e, "DISPLAY=", 8) && strncmp(*e, "ASAN_OPTIONS=", 13) && strncmp(*e, "LSAN_OPTIONS=", 13) &&
			    strncmp(*e, "LD_PRELOAD=", 11))
				env.push_back(*e);
		std::vector<char *> envp;
		for (auto &e : env)
			envp.push_back(&e[0]);
		envp.push_back(nullptr);
		posix_spawn_file_actions_t fa;
		posix_spawn_file_actions_init(&fa);
		posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
		posix_spawn_file_actions_adddup2(&fa, 1, 2);
		pid_t pid = -1;
		REQUIRE(posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), envp.data()) == 0);
		posix_spawn_file_actions_destroy(&fa);
		// the handler is in place when the kernel says the signal is caught (SigCgt), not after a
		// guessed delay; then it draws for a while
		auto caught = [&] {
			std::ifstream st("/proc/" + std::to_string(pid) + "/status");
			std::string line;
			while (std::getline(st, line))
				if (line.rfind("SigCgt:", 0) == 0)
					return (std::stoull(line.substr(7), nullptr, 16) >> (sig - 1)) & 1u;
			return 0ull;
		};
		for (int k = 0; k < 300 && !caught(); k++)
			std::this_thread::sleep_for(std::chrono::milliseconds(20));
		std::this_thread::sleep_for(std::chrono::milliseconds(500));
		kill(pid, sig);
		int st = 0;
		waitpid(pid, &st, 0);
		std::ifstream f(out);
		std::stringstream ss;
		ss << f.rdbuf();
		const std::string text = ss.str();
		INFO("signal " << sig << ": " << text);
		CHECK(WIFEXITED(st));
		CHECK(WEXITSTATUS(st) == 0);
		CHECK(text.find(sig == SIGINT ? "stopped by SIGINT" : "stopped by SIGTERM") != std::string::npos);
		CHECK(counter(text, "frames") >= 0); /* the summary line is there */
	}
	// without a display, with leak detection on: the model's buffers and the UDP source are freed on
	// that exit too (it leaked 3 MiB there); a free port for the source
	std::string cmd =
		"ASAN_OPTIONS=detect_leaks=1 DISPLAY= " SWELL_VIEW_BIN " --source udp:" + std::to_string(free_udp_port()) +
		" 2>&1";
	FILE *p = popen(cmd.c_str(), "r");
	REQUIRE(p != nullptr);
	std::string text;
	char buf[512];
	size_t n;
	while ((n = fread(buf, 1, sizeof(buf), p)) > 0)
		text.append(buf, n);
	const int st = pclose(p);
	INFO(text);
	CHECK(WEXITSTATUS(st) == 1);
	CHECK(text.find("no display") != std::string::npos);
	CHECK(text.find("LeakSanitizer") == std::string::npos);
}

TEST_CASE("a headless replay ends by itself at the end of the recording, exit 0 with its summary")
{
	// before: it ran until killed (here: by timeout, status 124), two cores busy after the end
	const std::string rec = recording("bump");
	run_result r = view("--headless --msaa 0 --size 160x120 --source " + rec);
	INFO(r.out);
	CHECK(r.status == 0);
	CHECK(counter(r.out, "frames") > 0);
	CHECK(r.out.find("damaged") == std::string::npos);
}

TEST_CASE("a screenshot that cannot be written exits 1 with the system's reason")
{
	run_result r = view("--headless --msaa 0 --size 160x120 --source pattern:bump --after 1 --screenshot "
			    "/nonexistent/x.png");
	INFO(r.out);
	CHECK(r.status == 1);
	CHECK(r.out.find("cannot write /nonexistent/x.png: No such file or directory") != std::string::npos);
}
