/* swell-tool against a real swell-ctl (and the HapticMaster model swell-hm) over UDP: what it prints,
 * what it changes and its exit status for every failure. */
#include <catch2/catch.hpp>

#include "swell_test.hpp"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using swell_test::free_udp_port;
using swell_test::reap;
using swell_test::slurp;
using swell_test::spawn;

using Clock = std::chrono::steady_clock;

void write_file(const std::string &path, const std::string &text)
{
	std::ofstream f(path);
	f << text;
	REQUIRE(f.good());
}

bool has(const std::string &s, const std::string &what) { return s.find(what) != std::string::npos; }

struct Result {
	int status;
	std::string out;
};

/* A controller (swell-ctl, real time without SCHED_FIFO) and its device (swell-hm, dropping the
 * object into the water), on free loopback ports, and swell-tool talking to it. */
struct Rig {
	int host_port = free_udp_port(), client_port = free_udp_port(), dev_port = free_udp_port();
	pid_t ctl = -1, hm = -1;
	std::string dir;
	explicit Rig(const std::string &name, const std::string &hand = "drop", const std::vector<std::string> &more = {})
	{
		dir = std::string(SWELL_TOOL_TEST_DIR) + "/" + name;
		REQUIRE(system(("mkdir -p '" + dir + "'").c_str()) == 0);
		/* silent_ticks 2500 (1 s): a loaded test machine must not fault the device link; the link
		 * supervision has its own tests, these are about the console */
		std::vector<std::string> args = {SWELL_CTL_BIN,
						 "--device",
						 "udp:" + std::to_string(dev_port),
						 "--host",
						 "udp:" + std::to_string(host_port) + ",listen=" + std::to_string(client_port),
						 "--no-rt",
						 "--quiet",
						 "--silent-ticks",
						 "2500",
						 "--seconds",
						 "60"};
		args.insert(args.end(), more.begin(), more.end());
		ctl = spawn(args, dir + "/ctl.log");
		hm = spawn({SWELL_HM_BIN, "--port", std::to_string(dev_port), "--quiet", "--seconds", "60", "--hand", hand},
			   dir + "/hm.log");
	}
	/* after RUN: the dropped object splashes (it may leave the water for a moment) and floats
	 * after about 4 s; then params says it displaces water */
	std::string floating()
	{
		std::this_thread::sleep_for(std::chrono::seconds(4));
		std::string wet;
		for (int k = 0; k < 20 && !has(wet, "displaces water"); k++) {
			std::this_thread::sleep_for(std::chrono::milliseconds(200));
			wet = tool("params").out;
		}
		return wet;
	}
	/* until the controller has heard the device (ARMED): a loaded machine starts the two slowly */
	void armed()
	{
		int st = -1;
		for (int k = 0; k < 20 && st != 0; k++)
			st = tool("arm").status;
		REQUIRE(st == 0);
	}
	~Rig()
	{
		swell_test::stop(hm, SIGTERM, 3000);
		swell_test::stop(ctl, SIGTERM, 3000);
	}
	/* the tool is a client of the host link: its clients' port */
	std::string link() const { return "udp:" + std::to_string(client_port); }
	Result tool(const std::string &args)
	{
		const std::string out = dir + "/tool.out";
		const std::string cmd = std::string(SWELL_TOOL_BIN) + " --link " + link() + " " + args + " >'" + out + "' 2>&1";
		const int st = system(cmd.c_str());
		Result r{WIFEXITED(st) ? WEXITSTATUS(st) : -1, slurp(out)};
		UNSCOPED_INFO("swell-tool " << args << " -> exit " << r.status << ":\n" << r.out);
		return r;
	}
};

} // namespace

TEST_CASE("swell-tool over UDP: status in text and JSON, get and set with units, refused sets change nothing", "[tool][udp]")
{
	Rig r("params");
	/* the first status waits longer: on a loaded machine the controller may still be starting, and
	 * the scene and info it waits for come once a second of the controller's time */
	Result st = r.tool("--timeout-ms 4000 status");
	REQUIRE(st.status == 0);
	CHECK(has(st.out, "protocol 1"));
	CHECK(has(st.out, "64 x 64 cells of 6.250 mm"));
	CHECK(has(st.out, "50.0 x 50.0 x 50.0 mm, 100 g"));
	Result js = r.tool("status --json");
	REQUIRE(js.status == 0);
	CHECK(has(js.out, "\"protocol_version\": 1,"));
	CHECK(has(js.out, "\"nx\": 64, \"ny\": 64"));
	CHECK(has(js.out, "\"mass_g\": 100,"));
	// the passivity controller is on by default (force.passivity 1)
	CHECK(has(js.out, "\"energy\": {\"created_mJ\": 0.000, \"balance_mJ\": 0.00, \"passivity\": 1"));

	Result s1 = r.tool("set force.max 5N");
	CHECK(s1.status == 0);
	CHECK(has(s1.out, "force.max = 5 N (was 10 N)"));
	Result g1 = r.tool("get force.max");
	CHECK(has(g1.out, "force.max = 5 N (raw 5000000)"));
	Result s2 = r.tool("set wave.damping 0.02");
	CHECK(has(s2.out, "wave.damping = 0.02 (was 0.001)"));

	/* refused by the controller: e above the stability limit; the value stays */
	Result bad = r.tool("set wave.e 0.6");
	CHECK(bad.status == 6);
	CHECK(has(bad.out, "refused by the controller: parameters outside the stability limit"));
	Result e = r.tool("get wave.e");
	CHECK(has(e.out, "wave.e = 0.2009079"));
	/* refused before sending: out of range, wrong unit, unknown name (bad arguments) */
	CHECK(r.tool("set body.mass 200kg").status == 2);
	CHECK(r.tool("set body.mass 80mm").status == 2);
	CHECK(r.tool("get body.weight").status == 2);
	CHECK(r.tool("frobnicate").status == 2);

	/* the object is in the water (run: the drop lands): mass and size are refused with the state */
	r.armed();
	REQUIRE(r.tool("run").status == 0);
	std::string wet = r.floating();
	CHECK(has(wet, "body.mass          100 g"));
	CHECK(has(wet, "no: the object displaces water"));
	Result dry = r.tool("set body.mass 80g");
	CHECK(dry.status == 6);
	CHECK(has(dry.out, "not allowed in this state (state running); body.mass stays 100 g"));
}

TEST_CASE("swell-tool over UDP: run, stop, clear and estop answer with the state after, log writes 100 rows a "
	  "second, plot draws them",
	  "[tool][udp]")
{
	Rig r("commands");
	r.armed();
	Result run = r.tool("run");
	CHECK(run.status == 0);
	CHECK(has(run.out, "run: acknowledged; state armed -> running"));
	Result clr = r.tool("clear");
	CHECK(clr.status == 6); /* only in fault */
	CHECK(has(clr.out, "clear refused by the controller: not allowed in this state (state running)"));
	Result w = r.tool("watch --seconds 1");
	CHECK(w.status == 0);
	CHECK(has(w.out, "running  z"));
	CHECK(has(w.out, " mJ ")); /* the energy created in the run */

	const std::string csv = r.dir + "/run.csv", png = r.dir + "/run.png";
	std::remove(png.c_str());
	Result lg = r.tool("log " + csv + " --seconds 2");
	REQUIRE(lg.status == 0);
	int rows = -1;
	{
		std::ifstream f(csv);
		std::string line;
		while (std::getline(f, line))
			rows++;
	}
	INFO("rows in 2 s: " << rows);
	/* a row a telemetry message, 100 Hz of the controller's time: its clock is swell-hm's device ticks,
	 * which a loaded machine without real-time scheduling slows (97 rows in 2 s seen), so at least a
	 * quarter of that in wall time, and never more than 100 Hz */
	CHECK(rows >= 50);
	CHECK(rows <= 210);
	Result pl = r.tool("plot " + csv);
	CHECK(pl.status == 0);
	CHECK(slurp(png).substr(1, 3) == "PNG");

	Result stop = r.tool("stop");
	CHECK(stop.status == 0);
	CHECK(has(stop.out, "state running -> armed"));
	REQUIRE(r.tool("run").status == 0);
	Result es = r.tool("estop");
	CHECK(es.status == 0);
	CHECK(has(es.out, "state running -> armed"));
	CHECK(has(r.tool("get ctl.autorun").out, "ctl.autorun = 0"));
}

TEST_CASE("swell-tool exit status: 3 with no controller, 4 for a wrong node, 5 when the controller vanishes "
	  "mid-command, 2 for bad arguments",
	  "[tool][udp]")
{
	const int nobody = free_udp_port();
	const auto t0 = Clock::now();
	const int none = system((std::string(SWELL_TOOL_BIN) + " --link udp:" + std::to_string(nobody) +
				 " --timeout-ms 300 status >/dev/null 2>&1")
					.c_str());
	const double none_s = std::chrono::duration<double>(Clock::now() - t0).count();
	CHECK(WEXITSTATUS(none) == 3);
	INFO("no controller answered in " << none_s << " s");
	CHECK(none_s < 2.0);
	CHECK(WEXITSTATUS(system((std::string(SWELL_TOOL_BIN) + " --node 16 status >/dev/null 2>&1").c_str())) == 2);
	CHECK(WEXITSTATUS(system((std::string(SWELL_TOOL_BIN) + " --link tcp:1 status >/dev/null 2>&1").c_str())) == 2);

	Rig r("vanish", "idle");
	Result wrong = r.tool("--node 3 get body.mass");
	CHECK(wrong.status == 4);
	CHECK(has(wrong.out, "no controller node 3"));
	CHECK(has(wrong.out, "node 0 is there"));

	/* a log in progress; the controller is killed: the tool stops with 5 within its silence limit
	 * and keeps the rows it had */
	const std::string csv = r.dir + "/cut.csv", out = r.dir + "/cut.out";
	pid_t tool = spawn({SWELL_TOOL_BIN, "--link", r.link(), "log", csv, "--seconds", "20"}, out);
	std::this_thread::sleep_for(std::chrono::milliseconds(1500));
	kill(r.ctl, SIGKILL);
	const auto killed = Clock::now();
	const int rc = reap(tool, 5000);
	const double gone_s = std::chrono::duration<double>(Clock::now() - killed).count();
	reap(r.ctl, 1000);
	const std::string said = slurp(out);
	INFO("swell-tool log after the kill: exit " << rc << " after " << gone_s << " s:\n" << said);
	CHECK(rc == 5);
	CHECK(gone_s < 2.5); /* 1 s of silence (--timeout-ms 1000), and the scheduling of a loaded machine */
	CHECK(has(said, "the controller went silent"));
	CHECK(has(said, "rows kept in"));
	/* and a request to a controller that is gone: no heartbeat, so no controller */
	CHECK(r.tool("--timeout-ms 300 get body.mass").status == 3);
}

TEST_CASE("swell-tool scene files over UDP: save and load back unchanged, another pool taken outside RUNNING and "
	  "refused while running with its line, a refused value puts back what was set",
	  "[tool][udp][scene]")
{
	Rig r("scene");
	const std::string saved = r.dir + "/saved.scene";
	Result sv = r.tool("scene save " + saved);
	REQUIRE(sv.status == 0);
	const std::string text = slurp(saved);
	CHECK(has(text, "pool.nx            = 64 cells"));
	CHECK(has(text, "solver.hz          = 250 Hz"));
	CHECK(has(text, "body.mass          = 100 g"));
	Result back = r.tool("scene load " + saved);
	CHECK(back.status == 0);
	CHECK(has(back.out, "0 changed"));

	/* another pool outside RUNNING: the controller restarts with it, the water at rest */
	CHECK(has(r.tool("params").out, "pool.nx            64 cells         2 cells .. 256 cells"));
	const std::string e_ref = r.tool("get wave.e").out;
	Result other = r.tool("scene load " + std::string(SWELL_SCENES_DIR) + "/shallow.scene");
	CHECK(other.status == 0);
	CHECK(has(other.out, "a new pool: the controller restarted"));
	CHECK(has(other.out, "pool.nx            64 cells -> 128 cells"));
	CHECK(has(other.out, "pool.depth         50 mm -> 20 mm"));
	CHECK(has(r.tool("get pool.ny").out, "pool.ny = 128 cells"));
	CHECK(has(r.tool("get wave.e").out, "wave.e = 0.080")); /* eq. 2 for 20 mm at 250 Hz */
	/* and the saved file puts the reference pool back, wave.e included */
	Result ref = r.tool("scene load " + saved);
	CHECK(ref.status == 0);
	CHECK(has(r.tool("get pool.nx").out, "pool.nx = 64 cells"));
	CHECK(r.tool("get wave.e").out == e_ref);

	/* a file that does not parse: its line, nothing sent */
	const std::string bad = r.dir + "/bad.scene";
	write_file(bad, "# a bad file\nwave.damping = 0.01\nbody.mass = 80 mm\n");
	Result parse = r.tool("scene load " + bad);
	CHECK(parse.status == 2);
	CHECK(has(parse.out, "bad.scene:3: body.mass: unit 'mm' is not g"));
	CHECK(has(r.tool("get wave.damping").out, "wave.damping = 0.001 "));

	/* running, the object in the water: heavy.scene's mass may not change now, so nothing is sent */
	REQUIRE(r.tool("set wave.damping 0.05").status == 0);
	r.armed();
	REQUIRE(r.tool("run").status == 0);
	std::string wet = r.floating();
	Result heavy = r.tool("scene load " + std::string(SWELL_SCENES_DIR) + "/heavy.scene");
	CHECK(heavy.status == 6);
	CHECK(has(heavy.out, "heavy.scene:9: body.mass = 150 g: not while the object displaces water (state running)"));
	CHECK(has(heavy.out, "nothing changed"));
	CHECK(has(r.tool("get wave.damping").out, "wave.damping = 0.05 "));
	CHECK(has(r.tool("get body.mass").out, "body.mass = 100 g"));

	/* a refused value puts back what was set: the stability limit refuses the last line */
	const std::string unstable = r.dir + "/unstable.scene";
	write_file(unstable, "# damping first, then an e over the limit\nwave.damping = 0.01\nforce.max = 8 N\nwave.e = 0.9\n");
	Result limit = r.tool("scene load " + unstable);
	CHECK(limit.status == 6);
	CHECK(has(limit.out, "unstable.scene:4: wave.e refused by the controller: parameters outside the stability limit"));
	CHECK(has(limit.out, "the controller is as it was"));
	CHECK(has(r.tool("get wave.damping").out, "wave.damping = 0.05 "));
	CHECK(has(r.tool("get force.max").out, "force.max = 10 N"));

	/* running: the controller refuses a new pool at its line, nothing changed */
	const std::string deeper = r.dir + "/deeper.scene";
	write_file(deeper, "# the same pool, deeper\npool.depth = 60 mm\n");
	Result busy = r.tool("scene load " + deeper);
	CHECK(busy.status == 6);
	CHECK(has(busy.out, "deeper.scene:2: pool.depth refused by the controller: not allowed in this state"));
	CHECK(has(busy.out, "the controller is as it was"));
	/* and shallow.scene, which also changes the object's size, is refused before anything is sent */
	Result shallow = r.tool("scene load " + std::string(SWELL_SCENES_DIR) + "/shallow.scene");
	CHECK(shallow.status == 6);
	CHECK(has(shallow.out, "shallow.scene:11: body.a = 80 mm: not while the object displaces water"));
	CHECK(has(r.tool("get pool.depth").out, "pool.depth = 50 mm"));
	CHECK(has(r.tool("status").out, "state running"));
	CHECK(has(r.tool("params").out, "50 mm          no: running"));
}

TEST_CASE("swell-tool scene load: a pool larger than the controller's arena is refused with its line, and the pool "
	  "already set and wave.e are put back",
	  "[tool][udp][scene]")
{
	Rig r("scene-max", "drop", {"--pool-max", "64"});
	const std::string e_ref = r.tool("get wave.e").out;
	REQUIRE(has(e_ref, "wave.e = "));
	/* the depth goes first (it lowers e), then pool.nx does not fit: the depth is put back */
	Result big = r.tool("scene load " + std::string(SWELL_SCENES_DIR) + "/shallow.scene");
	CHECK(big.status == 6);
	CHECK(has(big.out, "shallow.scene:4: pool.nx refused by the controller: size out of range"));
	CHECK(has(big.out, "the controller is as it was"));
	CHECK(has(r.tool("get pool.depth").out, "pool.depth = 50 mm"));
	CHECK(has(r.tool("get pool.nx").out, "pool.nx = 64 cells"));
	CHECK(r.tool("get wave.e").out == e_ref);
	CHECK(has(r.tool("get body.a").out, "body.a = 50 mm"));
}
