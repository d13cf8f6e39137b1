/* swell-flash: check a controller image, then flash it with the standard tool of a backend
 * (dfu-util, openocd/st-flash, stm32flash, gdb-multiarch), read it back and compare, start it, and
 * optionally watch its console for the version it boots. */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "flash_boot.h"
#include "flash_image.h"
#include "flash_plan.h"
#include "swell/cli.h"
#include "swell/transport.h"

#define MAX_FILE (16u * 1024u * 1024u)

static const char usage[] =
	"usage: swell-flash IMAGE [--backend dfu|swd|uart|gdb] [--dry-run] [options]\n"
	"Checks a controller image (ELF or BIN: header magic, MCU, length, CRC-32, version) before\n"
	"anything touches a target, then flashes it at 0x08000000 with the standard tool, reads it\n"
	"back and compares, and starts it. A bad or foreign image is refused (exit 2) and no tool runs.\n"
	"  --backend B          dfu (dfu-util, ROM DfuSe bootloader), swd (openocd or st-flash),\n"
	"                       uart (stm32flash, ROM bootloader on USART1), gdb (gdb-multiarch on a\n"
	"                       GDB remote: openocd, Black Magic Probe, QEMU). Without it: auto-detect\n"
	"                       on USB (sysfs, read only): DfuSe 0483:df11 -> dfu, ST-LINK -> swd;\n"
	"                       exactly one must be found. uart and gdb are never guessed.\n"
	"  --dry-run            print the commands it would run and stop\n"
	"  --check-only         check the image and stop\n"
	"  --mcu ID             target MCU id (default 0x413, STM32F405/407)\n"
	"  --expect-version V   refuse an image whose header version is not V (major.minor.patch)\n"
	"  --dfu-device VID:PID DFU device (default 0483:df11)\n"
	"  --swd-tool T         openocd (default) or st-flash\n"
	"  --openocd-interface F  openocd interface script (default interface/stlink.cfg)\n"
	"  --serial DEV         UART of the ROM bootloader (default /dev/ttyUSB0); --baud N (115200)\n"
	"  --gdb-remote R       host:port or a Black Magic Probe tty (default localhost:3333)\n"
	"  --gdb-server S       openocd (default), qemu or bmp (default bmp when R is a /dev path)\n"
	"  --console PATH       after the start, read the target's console (a tty at 115200 or a file\n"
	"                       being appended) until it reports the image version; --console-timeout S\n"
	"  --work-dir DIR       where read-back and converted files go (default a fresh temp dir)\n"
	"  --enter-bootloader LINK  first ask a running controller to reboot into its bootloader over\n"
	"                       its host link, as a client of it. LINK (swell-view's spellings):\n"
	"                         udp[:PORT]    the controller's clients' port on 127.0.0.1 (default\n"
	"                                       47802, swell-ctl's listen=; a viewer may run beside it)\n"
	"                         can:IFACE     SocketCAN, classic frames (e.g. can:can0)\n"
	"                         usb[:VID:PID] libusb, default 1209:0001; --iface N picks the interface\n"
	"                                       (default 0; 1 when both of its links are on USB)\n"
	"                       It listens for the heartbeat; refused while the controller is RUNNING\n"
	"                       unless --force (which sends AUTORUN=0 and COMMAND=STOP first); the flash\n"
	"                       goes on only when its heartbeat stops\n"
	"  --force              see --enter-bootloader\n"
	"  --node N             the controller's node id, 0..15 (default: the one heard; several\n"
	"                       controllers on one bus and no --node: refused)\n"
	"  --iface N            USB interface of the controller's host link, 0..255 (default 0)\n"
	"  --dfu-wait S         after --enter-bootloader with --backend dfu: wait up to S s (default 5)\n"
	"                       for the DfuSe device to appear on USB\n"
	"  --find LINK          after flashing (or alone with --check-only), listen on LINK for the\n"
	"                       controller's CTL_INFO and require the image's version; on by default on\n"
	"                       the --enter-bootloader link; --find-timeout S (default 10)\n"
	"  --no-find            do not look for the controller after flashing\n"
	"Exit status: 0 flashed and verified (and the controller back with the image's version),\n"
	"1 a tool or the verify failed, or the controller did not come back with that version,\n"
	"2 bad arguments or image refused.\n";

struct cfg {
	const char *image, *work_dir, *console, *expect_version;
	int backend, dry_run, check_only, force;
	int gdb_server; /* --gdb-server, -1: by --gdb-remote */
	int boot, find; /* --enter-bootloader, --find given (find: also after boot, unless --no-find) */
	struct swell_client_spec boot_link, find_link;
	int node, iface; /* --node (-1: the one heard), --iface */
	int no_find;
	unsigned long mcu;
	double console_timeout_s, dfu_wait_s, find_timeout_s;
	struct flash_opts o;
};

static _Noreturn void die(int code, const char *fmt, ...)
{
	va_list ap;

	fputs("swell-flash: ", stderr);
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fputc('\n', stderr);
	exit(code);
}

static double now_s(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* A host link of an option (--enter-bootloader, --find): o is c->ctx. */
static int link_opt(struct swell_cli *c, const char *opt, const char *l)
{
	struct cfg *cf = c->ctx;
	const int boot = !strcmp(opt, "--enter-bootloader");
	char why[200];

	if (swell_link_spec_parse(l, SWELL_LINK_ACCEPT_HOST_SIDE, SWELL_UDP_PORT_CLIENTS,
				  boot ? &cf->boot_link.link : &cf->find_link.link, why, sizeof(why)))
		return swell_cli_refuse(c, "%s %s", opt, why);
	*(boot ? &cf->boot : &cf->find) = 1;
	return 0;
}

static int dfu_device_opt(struct swell_cli *c, const char *opt, const char *v)
{
	unsigned vid, pid;
	char tail;

	if (sscanf(v, "%4x:%4x%c", &vid, &pid, &tail) != 2)
		return swell_cli_refuse(c, "%s '%s' is not VID:PID in hex", opt, v);
	((struct cfg *)c->ctx)->o.dfu_device = v;
	return 0;
}

/* The image, the one argument that is not an option. */
static int image_arg(struct swell_cli *c, const char *a)
{
	struct cfg *cf = c->ctx;

	if (cf->image)
		return swell_cli_refuse(c, "more than one image given: '%s' and '%s'", cf->image, a);
	cf->image = a;
	return 0;
}

static void parse(int argc, char **argv, struct cfg *c)
{
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_CHOICE("--backend", c->backend, "dfu|swd|uart|gdb"),
		SWELL_CLI_FLAG("--dry-run", c->dry_run),
		SWELL_CLI_FLAG("--check-only", c->check_only),
		SWELL_CLI_WHOLE("--mcu", c->mcu, 0, 0xFFFFFFFFu, ""),
		SWELL_CLI_STR("--expect-version", c->expect_version),
		SWELL_CLI_HOOK("--dfu-device", dfu_device_opt, 1),
		SWELL_CLI_CHOICE("--swd-tool", c->o.swd_tool, "openocd|st-flash"),
		SWELL_CLI_STR("--openocd-interface", c->o.openocd_interface),
		SWELL_CLI_STR("--serial", c->o.serial),
		SWELL_CLI_WHOLE("--baud", c->o.baud, 1200, 4000000, "bit/s"),
		SWELL_CLI_STR("--gdb-remote", c->o.gdb_remote),
		SWELL_CLI_CHOICE("--gdb-server", c->gdb_server, "openocd|qemu|bmp"),
		SWELL_CLI_STR("--console", c->console),
		SWELL_CLI_NUM_ABOVE("--console-timeout", c->console_timeout_s, 0, 600, "s"),
		SWELL_CLI_HOOK("--enter-bootloader", link_opt, 1),
		SWELL_CLI_HOOK("--find", link_opt, 1),
		SWELL_CLI_WHOLE("--node", c->node, 0, 15, ""),
		SWELL_CLI_WHOLE("--iface", c->iface, 0, 255, ""),
		SWELL_CLI_NUM_ABOVE("--find-timeout", c->find_timeout_s, 0, 600, "s"),
		SWELL_CLI_FLAG("--no-find", c->no_find),
		SWELL_CLI_NUM("--dfu-wait", c->dfu_wait_s, 0, 60, "s"),
		SWELL_CLI_FLAG("--force", c->force),
		SWELL_CLI_STR("--work-dir", c->work_dir),
	};
	struct swell_cli cli = { .prog = "swell-flash",
				 .usage = usage,
				 .opt = opts,
				 .n_opt = SWELL_CLI_N(opts),
				 .ctx = c,
				 .operand = image_arg };

	swell_cli_parse(&cli, argc, argv);
	if (!c->image)
		die(2, "no image given (see --help)");
	if (c->gdb_server >= 0)
		c->o.gdb_server = (enum flash_gdb_server)c->gdb_server;
	else if (!strncmp(c->o.gdb_remote, "/dev/", 5))
		c->o.gdb_server = FLASH_GDB_BMP;
}

/* USB auto-detection: read-only look at idVendor/idProduct under <sysfs>/bus/usb/devices. */
static int usb_has(const char *root, unsigned vid, const unsigned *pids, int npids)
{
	char path[1024], buf[16];
	struct dirent *e;
	int found = 0;
	DIR *d;

	snprintf(path, sizeof(path), "%s/bus/usb/devices", root);
	d = opendir(path);
	if (!d)
		return 0;
	while ((e = readdir(d)) != NULL && !found) {
		unsigned v = 0, p = 0;
		FILE *f;
		int k;

		if (e->d_name[0] == '.')
			continue;
		snprintf(path, sizeof(path), "%s/bus/usb/devices/%s/idVendor", root, e->d_name);
		f = fopen(path, "r");
		if (!f)
			continue;
		if (fgets(buf, sizeof(buf), f))
			v = (unsigned)strtoul(buf, NULL, 16);
		fclose(f);
		snprintf(path, sizeof(path), "%s/bus/usb/devices/%s/idProduct", root, e->d_name);
		f = fopen(path, "r");
		if (!f)
			continue;
		if (fgets(buf, sizeof(buf), f))
			p = (unsigned)strtoul(buf, NULL, 16);
		fclose(f);
		for (k = 0; k < npids; k++)
			if (v == vid && p == pids[k])
				found = 1;
	}
	closedir(d);
	return found;
}

static const char *sysfs_root(void)
{
	const char *root = getenv("SWELL_FLASH_SYSFS");

	return root ? root : "/sys";
}

/* After the reboot the ROM bootloader enumerates anew: wait for its VID:PID. */
static int wait_dfu_device(const char *vid_pid, double wait_s)
{
	unsigned vid = 0, pid = 0;
	double t0 = now_s();

	if (sscanf(vid_pid, "%x:%x", &vid, &pid) != 2)
		return 0;
	do {
		if (usb_has(sysfs_root(), vid, &pid, 1))
			return 1;
		usleep(50000);
	} while (now_s() - t0 < wait_s);
	return 0;
}

static int autodetect(void)
{
	static const unsigned dfu[] = { 0xdf11 }, stlink[] = { 0x3748, 0x374b, 0x374e, 0x374f, 0x3752, 0x3753 };
	const char *root = sysfs_root();
	int has_dfu, has_stlink;

	has_dfu = usb_has(root, 0x0483, dfu, 1);
	has_stlink = usb_has(root, 0x0483, stlink, 6);
	if (has_dfu && has_stlink)
		die(2, "no --backend given and both a DfuSe device (0483:df11) and an ST-LINK are on USB: choose one");
	if (has_dfu) {
		printf("swell-flash: auto-detected a DfuSe bootloader (USB 0483:df11): backend dfu\n");
		return FLASH_DFU;
	}
	if (has_stlink) {
		printf("swell-flash: auto-detected an ST-LINK on USB (0483:%s): backend swd\n",
		       "3748/374b/374e/374f/3752/3753");
		return FLASH_SWD;
	}
	die(2, "no --backend given and no DfuSe device (0483:df11) or ST-LINK found on USB: use --backend");
	return -1;
}

static int in_path(const char *tool)
{
	const char *path = getenv("PATH");
	char buf[4096];

	if (strchr(tool, '/'))
		return access(tool, X_OK) == 0;
	while (path && *path) {
		const char *colon = strchr(path, ':');
		size_t n = colon ? (size_t)(colon - path) : strlen(path);

		snprintf(buf, sizeof(buf), "%.*s/%s", (int)n, path, tool);
		if (n && access(buf, X_OK) == 0)
			return 1;
		path = colon ? colon + 1 : NULL;
	}
	return 0;
}

static const char *package_of(const char *tool)
{
	if (!strcmp(tool, "st-flash"))
		return "stlink-tools";
	return tool;
}

static int run(const struct flash_step *s)
{
	char *argv[FLASH_MAX_ARGS + 1];
	int i, status;
	pid_t pid;

	for (i = 0; i < s->argc; i++)
		argv[i] = (char *)s->arg[i];
	argv[s->argc] = NULL;
	fflush(stdout);
	fflush(stderr);
	pid = fork();
	if (pid < 0)
		die(1, "fork: %s", strerror(errno));
	if (pid == 0) {
		execvp(argv[0], argv);
		fprintf(stderr, "swell-flash: cannot run %s: %s\n", argv[0], strerror(errno));
		_exit(127);
	}
	while (waitpid(pid, &status, 0) < 0)
		if (errno != EINTR)
			die(1, "waitpid: %s", strerror(errno));
	if (WIFEXITED(status))
		return WEXITSTATUS(status);
	return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

static void write_file(const char *path, const uint8_t *b, size_t n)
{
	FILE *f = fopen(path, "wb");

	if (!f || fwrite(b, 1, n, f) != n || fclose(f) != 0)
		die(1, "cannot write %s: %s", path, strerror(errno));
}

static int compare_readback(const char *path, const struct flash_image *img)
{
	uint8_t *rb;
	size_t n, i;
	char why[256];

	if (flash_read_file(path, MAX_FILE, &rb, &n, why, sizeof(why)))
		die(1, "verify FAILED: no read-back: %s", why);
	if (n < img->len) {
		free(rb);
		die(1, "verify FAILED: read back %zu bytes, image has %zu; target not started", n, img->len);
	}
	for (i = 0; i < img->len; i++)
		if (rb[i] != img->bytes[i])
			break;
	if (i < img->len) {
		uint8_t got = rb[i];

		free(rb);
		die(1, "verify FAILED at 0x%08lx: wrote 0x%02x, read 0x%02x; target not started", 0x08000000ul + i,
		    img->bytes[i], got);
	}
	free(rb);
	return 0;
}

struct console {
	int fd;
	double t_open; /* the start of the step that starts the image */
	char line[512];
	size_t n;
};

static void console_open(struct console *con, const char *path)
{
	struct termios t;

	con->n = 0;
	con->t_open = now_s();
	con->fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY);
	if (con->fd < 0)
		die(1, "console %s: %s", path, strerror(errno));
	if (isatty(con->fd)) {
		if (tcgetattr(con->fd, &t) == 0) {
			cfmakeraw(&t);
			cfsetispeed(&t, B115200);
			cfsetospeed(&t, B115200);
			tcsetattr(con->fd, TCSANOW, &t);
			tcflush(con->fd, TCIFLUSH);
		}
	} else {
		lseek(con->fd, 0, SEEK_END); /* only what the new start prints */
	}
}

/* Read the console until the image reports its check; 0 ok, 1 refused/other version, -1 timeout. */
static int console_watch(struct console *con, double timeout_s, uint32_t want, double *t_boot)
{
	double t0 = now_s();
	char want_s[32], got_s[32];

	flash_version_str(want, want_s, sizeof(want_s));
	while (now_s() - t0 < timeout_s) {
		char c;
		ssize_t r = read(con->fd, &c, 1);

		if (r <= 0) {
			usleep(20000);
			continue;
		}
		if (c == '\r')
			continue;
		if (c != '\n' && con->n < sizeof(con->line) - 1) {
			con->line[con->n++] = c;
			continue;
		}
		con->line[con->n] = '\0';
		con->n = 0;
		if (!strncmp(con->line, "image: REFUSED", 14)) {
			printf("swell-flash: target console: %s\n", con->line);
			return 1;
		}
		if (sscanf(con->line, "image: version %31[0-9.]", got_s) == 1) {
			*t_boot = now_s() - con->t_open;
			printf("swell-flash: target console: %s\n", con->line);
			if (strcmp(got_s, want_s)) {
				printf("swell-flash: target boots version %s, the image is %s\n", got_s, want_s);
				return 1;
			}
			return 0;
		}
	}
	return -1;
}

/* After the flash: the controller found again on its host link, running the image's version. */
static void find_step(const struct cfg *c, const struct flash_image *img, const char *ver)
{
	struct flash_found f;
	char why[300], got[32];
	uint32_t v = img->hdr.version;
	int r;

	char where[96];

	swell_link_spec_describe(&c->find_link.link, where, sizeof(where));
	printf("swell-flash: listening on %s for the controller's CTL_INFO (up to %.1f s)\n", where, c->find_timeout_s);
	fflush(stdout);
	r = flash_find_controller(&c->find_link, (int)(c->find_timeout_s * 1000 + 0.5), &f, why, sizeof(why));
	if (r)
		die(1, "%s", why);
	snprintf(got, sizeof(got), "%u.%u.%u", f.version[0], f.version[1], f.version[2]);
	printf("swell-flash: controller back, running version %s (node %u, heard %.3f s after listening began, "
	       "at %.3f s CLOCK_MONOTONIC; object %.1f x %.1f x %.1f mm)\n",
	       got, (unsigned)f.node, f.after_s, f.mono_s, f.obj_100um[0] / 10.0, f.obj_100um[1] / 10.0,
	       f.obj_100um[2] / 10.0);
	if (f.version[0] != (v >> 16) || f.version[1] != ((v >> 8) & 0xFFu) || f.version[2] != (v & 0xFFu))
		die(1,
		    "the controller runs version %s, but the image's header says %s: it did not start the "
		    "flashed image",
		    got, ver);
	printf("swell-flash: the controller runs the image's version %s\n", ver);
}

int main(int argc, char **argv)
{
	struct cfg c = { 0 };
	struct flash_image img;
	struct flash_plan plan;
	struct console con = { .fd = -1 };
	char why[512], ver[32], dir[600], bin[700], rb[700], line[8192], where[96];
	uint8_t *file;
	size_t file_len;
	double t_all;
	int i;

	for (i = 1; i < argc; i++)
		if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
			fputs(usage, stdout);
			return 0;
		}
	c.backend = c.gdb_server = -1;
	c.mcu = SWELL_FWIMAGE_MCU_STM32F405;
	c.console_timeout_s = 10;
	c.find_timeout_s = 10;
	c.dfu_wait_s = 5;
	c.o.dfu_device = "0483:df11";
	c.o.openocd_interface = "interface/stlink.cfg";
	c.o.serial = "/dev/ttyUSB0";
	c.o.baud = 115200;
	c.o.gdb_remote = "localhost:3333";
	c.node = -1;
	c.iface = -1;
	parse(argc, argv, &c);
	if (!c.find && c.boot && !c.no_find) { /* entered through the link: look for it there afterwards */
		c.find_link = c.boot_link;
		c.find = 1;
	}
	if (c.no_find)
		c.find = 0;
	if (c.iface >= 0 && !(c.boot && c.boot_link.link.kind == SWELL_LINK_USB) &&
	    !(c.find && c.find_link.link.kind == SWELL_LINK_USB))
		die(2, "--iface is for a usb link (--enter-bootloader usb or --find usb)");
	if (c.node >= 0 && !c.boot && !c.find)
		die(2, "--node is for --enter-bootloader or --find");
	c.boot_link.node = c.find_link.node = c.node;
	c.boot_link.link.iface = c.find_link.link.iface = (uint8_t)(c.iface >= 0 ? c.iface : 0);

	/* 1. The image, before anything else. */
	if (flash_read_file(c.image, MAX_FILE, &file, &file_len, why, sizeof(why)))
		die(2, "refused: %s", why);
	if (flash_image_check(file, file_len, (uint32_t)c.mcu, &img, why, sizeof(why))) {
		free(file);
		die(2, "%s: refused: %s", c.image, why);
	}
	free(file);
	flash_version_str(img.hdr.version, ver, sizeof(ver));
	if (c.expect_version && strcmp(c.expect_version, ver))
		die(2, "%s: refused: version %s, expected %s", c.image, ver, c.expect_version);
	printf("swell-flash: %s: ok: %s, version %s, %zu bytes, mcu 0x%03x, crc32 0x%08x\n", c.image,
	       img.fmt == FLASH_FMT_ELF ? "ELF" : "BIN", ver, img.len, (unsigned)img.hdr.mcu_id, (unsigned)img.hdr.crc);
	if (c.check_only) {
		if (c.find)
			find_step(&c, &img, ver);
		goto done;
	}

	/* 2. Backend and the plan. */
	if (c.backend < 0)
		c.backend = autodetect();
	c.o.backend = (enum flash_backend)c.backend;
	c.o.len = img.len;
	if (c.work_dir)
		snprintf(dir, sizeof(dir), "%s", c.work_dir);
	else if (c.dry_run)
		snprintf(dir, sizeof(dir), "/tmp/swell-flash.XXXXXX");
	else {
		const char *t = getenv("TMPDIR");

		snprintf(dir, sizeof(dir), "%s/swell-flash.XXXXXX", t && *t ? t : "/tmp");
		if (!mkdtemp(dir))
			die(1, "cannot make a work directory %s: %s", dir, strerror(errno));
	}
	snprintf(rb, sizeof(rb), "%s/readback.bin", dir);
	if (img.fmt == FLASH_FMT_ELF) {
		snprintf(bin, sizeof(bin), "%s/image.bin", dir);
		c.o.elf = c.image;
	} else {
		snprintf(bin, sizeof(bin), "%s", c.image);
	}
	c.o.bin = bin;
	c.o.readback = rb;
	if (flash_plan_build(&c.o, &plan, why, sizeof(why)))
		die(2, "%s", why);
	/* The BIN written from the ELF is only needed by commands that name it. */
	{
		int uses_bin = 0, k;

		for (i = 0; i < plan.nsteps; i++)
			for (k = 0; k < plan.step[i].argc; k++)
				if (strstr(plan.step[i].arg[k], bin) && img.fmt == FLASH_FMT_ELF)
					uses_bin = 1;
		if (uses_bin) {
			if (c.dry_run)
				printf("swell-flash: would write %s: the ELF's %zu flash bytes\n", bin, img.len);
			else
				write_file(bin, img.bytes, img.len);
		}
	}
	if (c.dry_run) {
		printf("swell-flash: dry run, backend %s, %d steps:\n", flash_backend_name(c.o.backend), plan.nsteps);
		for (i = 0; i < plan.nsteps; i++) {
			flash_step_format(&plan.step[i], line, sizeof(line));
			if (i == 0 && c.boot) {
				swell_link_spec_describe(&c.boot_link.link, where, sizeof(where));
				printf("[0/%d] send ENTER_BOOTLOADER on %s once its heartbeat is heard%s\n",
				       plan.nsteps, where,
				       c.force ? " (AUTORUN=0, COMMAND=STOP first if RUNNING)" : "");
			}
			printf("[%d/%d] %s\n%s\n", i + 1, plan.nsteps, plan.step[i].what, line);
			if (plan.step[i].kind == STEP_READBACK)
				printf("  then compare %s with the image's %zu bytes\n", rb, img.len);
		}
		if (c.console)
			printf("  then read %s until the image reports version %s\n", c.console, ver);
		if (c.find) {
			swell_link_spec_describe(&c.find_link.link, where, sizeof(where));
			printf("  then listen on %s up to %.1f s for the controller's CTL_INFO, version %s\n", where,
			       c.find_timeout_s, ver);
		}
		goto done;
	}

	/* 3. Tools present before the first one runs. */
	for (i = 0; i < plan.nsteps; i++)
		if (!in_path(plan.step[i].arg[0]))
			die(1, "%s not found in PATH (Debian package %s): nothing was done", plan.step[i].arg[0],
			    package_of(plan.step[i].arg[0]));

	/* 4. A running controller is asked to enter its bootloader first. */
	if (c.boot) {
		struct flash_boot_times bt;
		enum flash_boot_result br = flash_enter_bootloader(&c.boot_link, c.force, 1000, &bt, why, sizeof(why));

		if (br == BOOT_REFUSED_RUNNING || br == BOOT_REFUSED_NODES)
			die(2, "%s", why);
		if (br != BOOT_ENTERED)
			die(1, "%s; nothing flashed", why);
		printf("swell-flash: %s", why);
		if (bt.last_beat_s >= 0)
			printf(" (last heartbeat %.3f s after the request", bt.last_beat_s);
		else
			printf(" (no heartbeat after the request");
		if (bt.dev_gone_s >= 0)
			printf(", device left the bus %.3f s after it", bt.dev_gone_s);
		printf(")\n");
		if (c.o.backend == FLASH_DFU) {
			double t0 = now_s();

			if (!wait_dfu_device(c.o.dfu_device, c.dfu_wait_s))
				die(1, "no DfuSe device %s on USB within %.1f s of the request; nothing flashed",
				    c.o.dfu_device, c.dfu_wait_s);
			printf("swell-flash: DfuSe device %s on USB after %.3f s\n", c.o.dfu_device, now_s() - t0);
		}
	}

	/* 5. Run, compare after the read-back, start only a verified image. */
	t_all = now_s();
	for (i = 0; i < plan.nsteps; i++) {
		const struct flash_step *s = &plan.step[i];
		double t0 = now_s();
		int rc;

		if (s->kind == STEP_RESET && c.console)
			console_open(&con, c.console);
		flash_step_format(s, line, sizeof(line));
		printf("swell-flash: [%d/%d] %s: %s\n", i + 1, plan.nsteps, s->what, line);
		rc = run(s);
		if (rc != 0)
			die(1, "[%d/%d] %s failed: %s exited with %d", i + 1, plan.nsteps, s->what, s->arg[0], rc);
		printf("swell-flash: [%d/%d] done in %.3f s\n", i + 1, plan.nsteps, now_s() - t0);
		if (s->kind == STEP_READBACK) {
			compare_readback(rb, &img);
			printf("swell-flash: verify ok: %zu bytes read back at 0x08000000 equal the image\n", img.len);
		}
	}
	if (plan.verify_by_tool)
		printf("swell-flash: verify by %s (read back and compared by the tool)\n", plan.step[0].arg[0]);
	printf("swell-flash: flashed %zu bytes in %.3f s\n", img.len, now_s() - t_all);
	if (c.console) {
		double t_boot = 0;
		int r = console_watch(&con, c.console_timeout_s, img.hdr.version, &t_boot);

		close(con.fd);
		if (r < 0)
			die(1, "no image report on %s within %.1f s", c.console, c.console_timeout_s);
		if (r > 0)
			die(1, "the target did not boot the flashed image");
		printf("swell-flash: target runs version %s (crc32 0x%08x), reported %.3f s after the start step "
		       "began\n",
		       ver, (unsigned)img.hdr.crc, t_boot);
	}
	if (!c.work_dir && !c.dry_run) {
		snprintf(line, sizeof(line), "%s.leave", rb);
		unlink(line);
		unlink(rb);
		if (img.fmt == FLASH_FMT_ELF)
			unlink(bin);
		rmdir(dir);
	}
	if (c.find)
		find_step(&c, &img, ver); /* after the clean-up: it may end the program */
done:
	flash_image_free(&img);
	return 0;
}
