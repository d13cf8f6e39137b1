/* The command-line table: each kind of option takes its value, a value out of range or malformed is
 * refused with a reason that names it and leaves the destination as it was, and swell_cli_parse exits 2
 * with one "prog: reason" line on stderr (0 and the usage on stdout for --help). */
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <utility>
#include <vector>

extern "C" {
#include "swell/cli.h"
}

namespace {

struct opts {
	int flag = 0;
	bool off = true;
	const char *name = "none";
	const char *host = "127.0.0.1";
	double rate = 5;
	float gain = 1.0f;
	double timeout = 1;
	double any = 4;
	uint16_t port = 7;
	int8_t offset = 3;
	long big = 9;
	uint16_t vid = 1;
	double at[3] = {1, 2, 3};
	int view = 5;
	double hook_val = -1;
	int hook_calls = 0;
	std::vector<std::string> operands;
};

int hook(struct swell_cli *c, const char *opt, const char *val)
{
	opts *o = static_cast<opts *>(c->ctx);
	double x;

	o->hook_calls++;
	if (!val) { /* the optional value is not there */
		o->hook_val = 0;
		return 0;
	}
	if (swell_cli_number(c, opt, val, 1, 10, "", &x) < 0)
		return -1;
	o->hook_val = x;
	return 0;
}

int operand(struct swell_cli *c, const char *arg)
{
	opts *o = static_cast<opts *>(c->ctx);

	if (std::string(arg) == "bad")
		return swell_cli_refuse(c, "'%s' is not a file", arg);
	o->operands.push_back(arg);
	return 0;
}

/* argv from a list, and the table over o */
struct cli_run {
	opts o;
	std::vector<swell_cli_opt> table;
	swell_cli cli{};
	std::vector<std::string> args; /* the strings the options point at */
	int result;
	explicit cli_run(std::vector<std::string> given, bool with_operands = false) : args(std::move(given))
	{
		table = {
			SWELL_CLI_FLAG("--flag", o.flag),
			SWELL_CLI_SET("--off", o.off, 0),
			SWELL_CLI_STR("--name", o.name),
			SWELL_CLI_IPV4("--host", o.host),
			SWELL_CLI_NUM("--rate", o.rate, 0.5, 100, "Hz"),
			SWELL_CLI_NUM("--gain", o.gain, -2, 2, ""),
			SWELL_CLI_NUM("--any", o.any, -HUGE_VAL, HUGE_VAL, ""),
			SWELL_CLI_NUM_ABOVE("--timeout", o.timeout, 0, 600, "s"),
			SWELL_CLI_WHOLE("--port", o.port, 1, 65535, ""),
			SWELL_CLI_WHOLE("--offset", o.offset, -100, 100, "mm"),
			SWELL_CLI_WHOLE("--big", o.big, -1e12, 1e12, ""),
			SWELL_CLI_HEX("--vid", o.vid, 0, 0xFFFF),
			SWELL_CLI_LIST("--at", o.at, 3, -300, 300, "mm"),
			SWELL_CLI_CHOICE("--view", o.view, "orbit|top|map"),
			SWELL_CLI_HOOK("--hook", hook, 1),
			SWELL_CLI_HOOK("--maybe", hook, 2),
		};
		cli.prog = "prog";
		cli.usage = "usage: prog\n";
		cli.opt = table.data();
		cli.n_opt = table.size();
		cli.ctx = &o;
		cli.operand = with_operands ? operand : nullptr;
		args.insert(args.begin(), "prog");
		std::vector<char *> argv;
		for (auto &a : args)
			argv.push_back(&a[0]);
		result = swell_cli_scan(&cli, (int)argv.size(), argv.data());
	}
	std::string why() const { return cli.why; }
};

} // namespace

TEST_CASE("cli: each kind of option takes its value", "[cli]")
{
	cli_run r({"--flag", "--off",          "--name",    "x.csv",         "--host", "10.1.2.3", "--rate",   "0.5",
		   "--gain", "-1.5",           "--timeout", "1e-3",          "--port", "65535",    "--offset", "-100",
		   "--big",  "-1000000000000", "--at",      "-300,0.25,300", "--view", "map",      "--hook",   "2.5"});
	INFO(r.why());
	REQUIRE(r.result == 0);
	CHECK(r.o.flag == 1);
	CHECK(r.o.off == false);
	CHECK(std::string(r.o.name) == "x.csv");
	CHECK(std::string(r.o.host) == "10.1.2.3");
	CHECK(r.o.rate == 0.5);
	CHECK(r.o.gain == -1.5f);
	CHECK(r.o.timeout == 1e-3);
	CHECK(r.o.port == 65535);
	CHECK(r.o.offset == -100);
	CHECK(r.o.big == -1000000000000L);
	CHECK(r.o.at[0] == -300);
	CHECK(r.o.at[1] == 0.25);
	CHECK(r.o.at[2] == 300);
	CHECK(r.o.view == 2);
	CHECK(r.o.hook_val == 2.5);
	CHECK(r.why().empty());
	CHECK(cli_run({"--view", "orbit"}).o.view == 0);
	CHECK(cli_run({"--any", "-1e300"}).o.any == -1e300);
	CHECK(cli_run({"--vid", "0483"}).o.vid == 0x483);
	CHECK(cli_run({"--vid", "0xFFFF"}).o.vid == 0xFFFF);
	CHECK(cli_run({"--any", "x"}).why() == "--any 'x' is not a number"); /* no range to say */
}

TEST_CASE("cli: an optional value is taken only when one follows", "[cli]")
{
	cli_run given({"--maybe", "7"});
	CHECK(given.result == 0);
	CHECK(given.o.hook_val == 7);
	cli_run last({"--maybe"});
	CHECK(last.result == 0);
	CHECK(last.o.hook_val == 0);
	cli_run before({"--maybe", "--flag"});
	CHECK(before.result == 0);
	CHECK(before.o.hook_val == 0);
	CHECK(before.o.flag == 1);
}

TEST_CASE("cli: a refused value names itself and its range and leaves the option as it was", "[cli]")
{
	struct bad {
		std::vector<std::string> args;
		std::string says;
	};
	const std::vector<bad> table = {
		{{"--rate", "0.4"}, "--rate '0.4' is not a number in [0.5, 100] Hz"},
		{{"--rate", "100.5"}, "--rate '100.5' is not a number in [0.5, 100] Hz"},
		{{"--rate", "nan"}, "--rate 'nan' is not a number"},
		{{"--rate", "5x"}, "--rate '5x' is not a number"},
		{{"--rate", ""}, "--rate '' is not a number"},
		{{"--host", "300.1.1.1"}, "--host '300.1.1.1' is not a dotted IPv4 address"},
		{{"--host", "localhost"}, "--host 'localhost' is not a dotted IPv4 address"},
		{{"--vid", "10000"}, "--vid '10000' is not a hexadecimal number in [0, ffff]"},
		{{"--vid", "xyz"}, "--vid 'xyz' is not a hexadecimal number"},
		{{"--any", "inf"}, "--any 'inf' is not a number"},
		{{"--any", "1e999"}, "--any '1e999' is not a number"},
		{{"--gain", "3"}, "--gain '3' is not a number in [-2, 2]"},
		{{"--timeout", "0"}, "--timeout '0' is not a number in (0, 600] s"},
		{{"--port", "0"}, "--port '0' is not a whole number in [1, 65535]"},
		{{"--port", "65536"}, "--port '65536' is not a whole number in [1, 65535]"},
		{{"--port", "80.5"}, "--port '80.5' is not a whole number"},
		{{"--offset", "-101"}, "--offset '-101' is not a whole number in [-100, 100] mm"},
		{{"--big", "1e13"}, "--big '1e13' is not a whole number in [-1000000000000, 1000000000000]"},
		{{"--at", "1,2"}, "--at '1,2' is not 3 comma-separated numbers in [-300, 300] mm"},
		{{"--at", "1,2,3,4"}, "--at '1,2,3,4' is not 3 comma-separated numbers"},
		{{"--at", "1,2,301"}, "--at '1,2,301' is not 3 comma-separated numbers"},
		{{"--at", "1,,3"}, "--at '1,,3' is not 3 comma-separated numbers"},
		{{"--at", "1,2,3,"}, "--at '1,2,3,' is not 3 comma-separated numbers"},
		{{"--view", "side"}, "--view 'side' is not orbit, top or map"},
		{{"--view", "orbi"}, "--view 'orbi' is not orbit, top or map"},
		{{"--hook", "11"}, "--hook '11' is not a number in [1, 10]"},
		{{"--port"}, "--port needs a value (see --help)"},
		{{"--bogus"}, "unknown option '--bogus' (see --help)"},
		{{"--bogus", "1"}, "unknown option '--bogus' (see --help)"},
		{{"stray"}, "unexpected argument 'stray' (see --help)"},
		{{"-"}, "unexpected argument '-' (see --help)"},
		{{"-5"}, "unexpected argument '-5' (see --help)"},
		{{"-x"}, "unknown option '-x' (see --help)"},
	};
	for (const auto &b : table) {
		cli_run r(b.args);
		INFO(b.args[0] << " -> " << r.why());
		CHECK(r.result == -1);
		CHECK(r.why().rfind(b.says, 0) == 0); /* the reason starts so */
		/* untouched */
		CHECK(r.o.rate == 5);
		CHECK(r.o.gain == 1.0f);
		CHECK(r.o.timeout == 1);
		CHECK(r.o.any == 4);
		CHECK(r.o.vid == 1);
		CHECK(std::string(r.o.host) == "127.0.0.1");
		CHECK(r.o.port == 7);
		CHECK(r.o.offset == 3);
		CHECK(r.o.big == 9);
		CHECK(r.o.at[0] == 1);
		CHECK(r.o.at[1] == 2);
		CHECK(r.o.at[2] == 3);
		CHECK(r.o.view == 5);
		CHECK(r.o.hook_val == -1);
	}
}

TEST_CASE("cli: the scan stops at the first refusal and at --help", "[cli]")
{
	cli_run r({"--port", "80", "--port", "x", "--flag"});
	CHECK(r.result == -1);
	CHECK(r.o.port == 80); /* what came before is taken */
	CHECK(r.o.flag == 0); /* what came after is not looked at */
	cli_run h({"--flag", "-h", "--bogus"});
	CHECK(h.result == 1);
	CHECK(h.o.flag == 1);
	cli_run help({"--help"});
	CHECK(help.result == 1);
}

TEST_CASE("cli: operands go to the program's hook, which may refuse them", "[cli]")
{
	cli_run r({"a.elf", "--flag", "b.elf", "-", "-5", "-.5"}, true);
	CHECK(r.result == 0);
	CHECK(r.o.operands == std::vector<std::string>{"a.elf", "b.elf", "-", "-5", "-.5"});
	cli_run none({"a.elf"});
	CHECK(none.result == -1);
	CHECK(none.why() == "unexpected argument 'a.elf' (see --help)");
	cli_run bad({"a.elf", "bad"}, true);
	CHECK(bad.result == -1);
	CHECK(bad.why() == "'bad' is not a file");
}

TEST_CASE("cli: without an operand hook, words are kept up to their limit", "[cli]")
{
	const char *words[2] = {nullptr, nullptr};
	std::string argv0 = "prog", a = "can0", f = "--flag", b = "can1", x = "can2";
	char *argv[] = {&argv0[0], &a[0], &f[0], &b[0], &x[0]};
	int flag = 0;
	const swell_cli_opt table[] = {SWELL_CLI_FLAG("--flag", flag)};
	swell_cli c{};
	c.opt = table;
	c.n_opt = 1;
	c.words = words;
	c.max_words = 2;
	CHECK(swell_cli_scan(&c, 4, argv) == 0);
	CHECK(c.n_words == 2);
	CHECK(std::string(words[0]) == "can0");
	CHECK(std::string(words[1]) == "can1");
	CHECK(flag == 1);
	c.n_words = 0;
	CHECK(swell_cli_scan(&c, 5, argv) == -1);
	CHECK(std::string(c.why) == "unexpected argument 'can2' (see --help)");
}

TEST_CASE("cli: a list of varying length gives its count", "[cli]")
{
	swell_cli c{};
	double out[4] = {9, 9, 9, 9};
	CHECK(swell_cli_numbers(&c, "--l", "1,2", 1, 4, 0, 10, "", out) == 2);
	CHECK(out[0] == 1);
	CHECK(out[1] == 2);
	CHECK(out[2] == 9);
	CHECK(swell_cli_numbers(&c, "--l", "5", 1, 4, 0, 10, "", out) == 1);
	CHECK(out[0] == 5);
	CHECK(swell_cli_numbers(&c, "--l", "1,2,3,4,5", 1, 4, 0, 10, "s", out) == -1);
	CHECK(std::string(c.why) == "--l '1,2,3,4,5' is not 1 to 4 comma-separated numbers in [0, 10] s");
	CHECK(out[0] == 5);
}

namespace {

/* swell_cli_parse in a child: its exit status, stdout and stderr. */
struct child {
	int code = -1;
	std::string out, err;
};

std::string drain(int fd)
{
	std::string s;
	char buf[256];
	ssize_t n;
	while ((n = read(fd, buf, sizeof buf)) > 0)
		s.append(buf, (size_t)n);
	close(fd);
	return s;
}

child parse_in_child(std::vector<std::string> args)
{
	int o[2], e[2];
	REQUIRE(pipe(o) == 0);
	REQUIRE(pipe(e) == 0);
	fflush(stdout); /* nothing of ours for the child to flush again */
	fflush(stderr);
	const pid_t pid = fork();
	REQUIRE(pid >= 0);
	if (pid == 0) {
		dup2(o[1], 1);
		dup2(e[1], 2);
		close(o[0]);
		close(e[0]);
		int port = 7;
		const swell_cli_opt table[] = {SWELL_CLI_WHOLE("--port", port, 1, 65535, "")};
		swell_cli cli{};
		cli.prog = "prog";
		cli.usage = "usage: prog [--port N]\n";
		cli.opt = table;
		cli.n_opt = 1;
		args.insert(args.begin(), "prog");
		std::vector<char *> argv;
		for (auto &a : args)
			argv.push_back(&a[0]);
		swell_cli_parse(&cli, (int)argv.size(), argv.data());
		printf("ran with port %d\n", port);
		fflush(stdout);
		_exit(0);
	}
	close(o[1]);
	close(e[1]);
	child c;
	c.out = drain(o[0]);
	c.err = drain(e[0]);
	int st;
	REQUIRE(waitpid(pid, &st, 0) == pid);
	c.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
	return c;
}

} // namespace

TEST_CASE("cli: swell_cli_parse exits 2 with one line and nothing done, 0 with the usage for --help", "[cli]")
{
	const child bad = parse_in_child({"--port", "0"});
	CHECK(bad.code == 2);
	CHECK(bad.err == "prog: --port '0' is not a whole number in [1, 65535]\n");
	CHECK(bad.out.empty());
	const child help = parse_in_child({"--help"});
	CHECK(help.code == 0);
	CHECK(help.out == "usage: prog [--port N]\n");
	CHECK(help.err.empty());
	const child good = parse_in_child({"--port", "80"});
	CHECK(good.code == 0);
	CHECK(good.out == "ran with port 80\n");
}
