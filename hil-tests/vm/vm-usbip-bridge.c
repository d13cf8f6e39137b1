/* swell-vm-usbip-bridge: the VM end of the USB tunnel. The line (a virtio-serial port or a serial
 * port) carries the USB/IP protocol (the kernel's Documentation/usb/usbip_protocol.rst) to a server
 * at the other end (swell-mcu's OTG FS model, hil-tests/mcu/usbip.c). The bridge imports the server's device (OP_REQ_IMPORT),
 * hands one end of a Unix socket pair to the kernel's vhci-hcd (sysfs attach) and copies bytes
 * between the other end and the line, so the VM's USB stack enumerates the device and programs use
 * it through libusb as they would a board on a USB port. The server closing the line is an unplug:
 * the port is detached, and the device imported again when the line comes back (QEMU's socket
 * chardev reconnects; a virtio-serial port polls as hung up meanwhile). SIGUSR1 pulls the cable from
 * this end (the port detached, the session ended: a command USB/IP does not have, on which the server
 * closes the line, as USB/IP servers do), SIGUSR2 plugs it in again (imported once the line is back). */
#define _DEFAULT_SOURCE

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "swell/cli.h"
#include "vm-line.h"
#include "vm-util.h"

#define OP_HDR 8u
#define DEV_REC 312u /* the device record of OP_REP_IMPORT */
#define BUSID_LEN 32u
#define PUMP_BUF 65536u

static const char usage[] =
	"usage: swell-vm-usbip-bridge [--tty PATH] [--busid ID] [--vhci DIR] [--import-timeout-s S]\n"
	"                             [--ready-file PATH]\n"
	"Imports the USB device that the USB/IP server at the other end of the line PATH (a serial\n"
	"port, default /dev/ttyS2, or a virtio-serial port such as /dev/vport0p1) exports as bus ID\n"
	"ID (default 1-1), waiting up to S seconds (default 120) for its answer, attaches it to a\n"
	"free port of the kernel's vhci-hcd (DIR, default /sys/devices/platform/vhci_hcd.0) through\n"
	"a Unix socket pair, and copies the USB/IP stream between the socket and the line until\n"
	"SIGTERM or SIGINT (then the port is detached) or until either side closes. When the server\n"
	"closes a virtio-serial line (the device unplugged), the port is detached and the device\n"
	"imported again once the line is back. SIGUSR1 pulls the cable: the port is detached and the\n"
	"session ended (a USB/IP command of code 0, which the protocol does not have: the server closes\n"
	"the line, as a USB/IP server does on a command it does not know; swell-mcu --usb-replug takes\n"
	"that as the cable pulled); SIGUSR2 plugs it in again: the device is imported again once the\n"
	"line is back. Writes --ready-file once the device is first attached.\n"
	"At the end prints the sessions, the unplugs and the bytes moved each way.\n"
	"Exit status: 0 stopped by a signal or either side closed, 1 an import, attach or I/O\n"
	"failure, 2 bad arguments.\n";

static uint32_t be32(const uint8_t *p)
{
	return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
	while (n > 0) {
		ssize_t w = write(fd, p, n);

		if (w < 0) {
			if (errno == EINTR)
				continue;
			return -1;
		}
		p += w;
		n -= (size_t)w;
	}
	return 0;
}

/* Read exactly n bytes before the deadline; 0, or -1 (errno ETIMEDOUT at the deadline). */
static int read_all(int fd, uint8_t *p, size_t n, double deadline_s)
{
	while (n > 0 && !vm_stop) {
		struct pollfd pfd = { .fd = fd, .events = POLLIN };
		double left = deadline_s - vm_now_s();
		ssize_t r;

		if (left <= 0) {
			errno = ETIMEDOUT;
			return -1;
		}
		if (poll(&pfd, 1, (int)(left * 1000) + 1) <= 0)
			continue;
		r = read(fd, p, n);
		if (r == 0) {
			errno = ECONNRESET;
			return -1;
		}
		if (r < 0) {
			if (errno == EINTR || errno == EAGAIN)
				continue;
			return -1;
		}
		p += r;
		n -= (size_t)r;
	}
	return vm_stop ? -1 : 0;
}

struct imported {
	uint32_t busnum, devnum, speed;
	uint16_t vid, pid;
};

static const char *import_device(int line, const char *busid, double timeout_s, struct imported *d)
{
	uint8_t req[OP_HDR + BUSID_LEN] = { 0x01, 0x11, 0x80, 0x03 }, rep[OP_HDR + DEV_REC];

	memcpy(req + OP_HDR, busid, strnlen(busid, BUSID_LEN - 1));
	if (write_all(line, req, sizeof(req)) != 0)
		return "cannot write OP_REQ_IMPORT to the line";
	if (read_all(line, rep, OP_HDR, vm_now_s() + timeout_s) != 0)
		return errno == ETIMEDOUT ? "no OP_REP_IMPORT from the server in time"
					  : "the line closed before OP_REP_IMPORT";
	if (rep[2] != 0x00 || rep[3] != 0x03)
		return "the server answered something other than OP_REP_IMPORT";
	if (be32(rep + 4) != 0)
		return "the server refused the import (no such bus ID)";
	if (read_all(line, rep + OP_HDR, DEV_REC, vm_now_s() + 10) != 0)
		return "the device record of OP_REP_IMPORT did not come";
	d->busnum = be32(rep + 0x128);
	d->devnum = be32(rep + 0x12C);
	d->speed = be32(rep + 0x130);
	d->vid = (uint16_t)(rep[0x134] << 8 | rep[0x135]);
	d->pid = (uint16_t)(rep[0x136] << 8 | rep[0x137]);
	return NULL;
}

/* A free high-speed hub port of vhci-hcd (its status file: "hs  0000 004 ..." with state 4,
 * VDEV_ST_NULL); the high-speed root hub takes low, full and high speed devices. -1 if none. */
static int free_port(const char *vhci)
{
	char path[512], line[256];
	int port = -1;
	FILE *f;

	snprintf(path, sizeof(path), "%s/status", vhci);
	f = fopen(path, "r");
	if (!f)
		return -1;
	while (port < 0 && fgets(line, sizeof(line), f)) {
		char hub[8];
		unsigned p, sta;

		if (sscanf(line, "%7s %u %u", hub, &p, &sta) == 3 && !strcmp(hub, "hs") && sta == 4)
			port = (int)p;
	}
	fclose(f);
	return port;
}

static int sysfs_write(const char *vhci, const char *file, const char *text)
{
	char path[512];
	int fd, rc;

	snprintf(path, sizeof(path), "%s/%s", vhci, file);
	fd = open(path, O_WRONLY);
	if (fd < 0)
		return -1;
	rc = write_all(fd, (const uint8_t *)text, strlen(text));
	close(fd);
	return rc;
}

struct pipe_buf {
	uint8_t b[PUMP_BUF];
	size_t len;
	uint64_t moved;
};

/* Read what src has into the buffer (0, or -1 when src closed or failed). */
static int pump_in(int src, struct pipe_buf *p)
{
	ssize_t r;

	if (p->len == sizeof(p->b))
		return 0;
	r = read(src, p->b + p->len, sizeof(p->b) - p->len);
	if (r == 0)
		return -1;
	if (r < 0)
		return errno == EINTR || errno == EAGAIN ? 0 : -1;
	p->len += (size_t)r;
	return 0;
}

static int pump_out(int dst, struct pipe_buf *p)
{
	ssize_t w;

	if (!p->len)
		return 0;
	w = write(dst, p->b, p->len);
	if (w < 0)
		return errno == EINTR || errno == EAGAIN ? 0 : -1;
	memmove(p->b, p->b + w, p->len - (size_t)w);
	p->len -= (size_t)w;
	p->moved += (uint64_t)w;
	return 0;
}

static struct pipe_buf to_line, to_vhci;

static volatile sig_atomic_t unplug_asked, plug_asked; /* SIGUSR1, SIGUSR2 */

static void on_usr(int sig)
{
	if (sig == SIGUSR1)
		unplug_asked = 1;
	else
		plug_asked = 1;
}

enum pump_end {
	END_STOP,
	END_LINE,
	END_VHCI,
	END_UNPLUG,
	END_ERROR
};

/* Copies both ways until a stop signal, either side's end or an I/O error. */
static enum pump_end run_pump(int line, int sock)
{
	(void)fcntl(line, F_SETFL, fcntl(line, F_GETFL) | O_NONBLOCK);
	(void)fcntl(sock, F_SETFL, fcntl(sock, F_GETFL) | O_NONBLOCK);
	while (!vm_stop) {
		struct pollfd pfd[2] = { { .fd = line, .events = POLLIN }, { .fd = sock, .events = POLLIN } };
		int n;

		if (unplug_asked)
			return END_UNPLUG;
		if (to_line.len)
			pfd[0].events |= POLLOUT;
		if (to_vhci.len)
			pfd[1].events |= POLLOUT;
		n = poll(pfd, 2, 200);
		if (n < 0) {
			if (errno == EINTR)
				continue;
			return END_ERROR;
		}
		if ((pfd[0].revents & (POLLIN | POLLHUP | POLLERR)) && pump_in(line, &to_vhci) != 0)
			return END_LINE; /* the server closed the line: the device is unplugged */
		if ((pfd[1].revents & (POLLIN | POLLHUP | POLLERR)) && pump_in(sock, &to_line) != 0)
			return END_VHCI; /* vhci let go of the device */
		if (pump_out(line, &to_line) != 0 || pump_out(sock, &to_vhci) != 0)
			return END_ERROR;
	}
	return END_STOP;
}

/* A virtio-serial port whose host side went away polls as hung up until the host side is back
 * (QEMU's socket chardev reconnects): wait for that, or for a stop. 0 when it is back. */
static int wait_line_back(int line)
{
	while (!vm_stop) {
		struct pollfd pfd = { .fd = line, .events = POLLIN };

		if (poll(&pfd, 1, 100) >= 0 && !(pfd.revents & (POLLHUP | POLLERR)))
			return 0;
		if (pfd.revents & (POLLHUP | POLLERR)) {
			struct timespec ts = { 0, 100000000 };

			nanosleep(&ts, NULL);
		}
	}
	return -1;
}

/* SIGUSR1: the session ended from this end. USB/IP has no message for it: a command header of code 0
 * (no command), on which the server closes the line; what it still sends is dropped until the line
 * hangs up (QEMU's socket chardev lost its peer) or has been quiet for 1.5 s (QEMU dials again after
 * 1 s: a guest busy elsewhere may take the hang-up and the new connection together, and never see
 * the line hung up). The old session sends nothing after the server's close. 1 when it hung up. */
static int end_session(int line)
{
	uint8_t hdr[48] = { 0 }, junk[4096];
	double quiet_until = vm_now_s() + 1.5;

	(void)fcntl(line, F_SETFL, fcntl(line, F_GETFL) & ~O_NONBLOCK);
	/* what vhci sent before it let go goes first: the header then starts a message */
	if (write_all(line, to_line.b, to_line.len) != 0 || write_all(line, hdr, sizeof(hdr)) != 0)
		return 0; /* already gone */
	to_line.moved += to_line.len;
	to_line.len = 0;
	while (!vm_stop && vm_now_s() < quiet_until) {
		struct pollfd pfd = { .fd = line, .events = POLLIN };
		ssize_t r;

		if (poll(&pfd, 1, 100) <= 0)
			continue;
		if (pfd.revents & (POLLHUP | POLLERR))
			return 1;
		r = read(line, junk, sizeof(junk));
		if (r == 0 || (r < 0 && errno != EINTR && errno != EAGAIN))
			return 1;
		quiet_until = vm_now_s() + 1.5;
	}
	return 0;
}

/* The first attach writes the ready file. */
static void mark_ready(const char *ready)
{
	FILE *f;

	if (!ready)
		return;
	f = fopen(ready, "w");
	if (f)
		fclose(f);
}

/* One session: import, attach to a free port, copy until an end. *port is the port used (-1: none). */
static enum pump_end session(int line, const char *busid, const char *vhci, double timeout_s, const char *ready,
			     int *port, const char **err)
{
	struct imported d = { 0 };
	char text[64];
	int sv[2];
	enum pump_end end;

	*port = -1;
	*err = import_device(line, busid, timeout_s, &d);
	if (*err)
		return END_ERROR;
	*port = free_port(vhci);
	if (*port < 0) {
		*err = "no free high-speed port in the vhci status (is vhci-hcd loaded?)";
		return END_ERROR;
	}
	if (socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) {
		*err = "socketpair failed";
		return END_ERROR;
	}
	/* "port sockfd devid speed": the kernel takes its own reference to the socket */
	snprintf(text, sizeof(text), "%d %d %" PRIu32 " %" PRIu32, *port, sv[0], (d.busnum << 16) | d.devnum, d.speed);
	if (sysfs_write(vhci, "attach", text) != 0) {
		*err = "vhci-hcd refused the attach";
		close(sv[0]);
		close(sv[1]);
		*port = -1;
		return END_ERROR;
	}
	close(sv[0]);
	printf("swell-vm-usbip-bridge: %04x:%04x (bus %" PRIu32 " device %" PRIu32 ", speed %" PRIu32
	       ") attached to vhci port %d\n",
	       d.vid, d.pid, d.busnum, d.devnum, d.speed, *port);
	fflush(stdout);
	mark_ready(ready);
	to_line.len = to_vhci.len = 0;
	end = run_pump(line, sv[1]);
	if (end != END_VHCI) { /* an unplug, or the end: the port lets the device go */
		snprintf(text, sizeof(text), "%d", *port);
		(void)sysfs_write(vhci, "detach", text);
	}
	close(sv[1]);
	return end;
}

int main(int argc, char **argv)
{
	const char *tty = "/dev/ttyS2", *busid = "1-1", *vhci = "/sys/devices/platform/vhci_hcd.0", *ready = NULL,
		   *err = NULL;
	double timeout_s = 120;
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_STR("--tty", tty),
		SWELL_CLI_STR("--busid", busid),
		SWELL_CLI_STR("--vhci", vhci),
		SWELL_CLI_NUM_ABOVE("--import-timeout-s", timeout_s, 0, 3600, "s"),
		SWELL_CLI_STR("--ready-file", ready),
	};
	struct swell_cli cli = {
		.prog = "swell-vm-usbip-bridge", .usage = usage, .opt = opts, .n_opt = SWELL_CLI_N(opts)
	};
	unsigned sessions = 0, unplugs = 0;
	int line, port = -1, rc = 0;
	enum pump_end end;
	struct sigaction sa;

	swell_cli_parse(&cli, argc, argv);
	vm_catch_stop();
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_usr; /* no SA_RESTART: a poll they interrupt returns */
	sigaction(SIGUSR1, &sa, NULL);
	sigaction(SIGUSR2, &sa, NULL);
	line = vm_open_line(tty);
	if (line < 0) {
		fprintf(stderr, "swell-vm-usbip-bridge: cannot open the tunnel line %s: %s\n", tty, strerror(errno));
		return 1;
	}
	for (;;) {
		end = session(line, busid, vhci, timeout_s, ready, &port, &err);
		if (end == END_ERROR) {
			if (err)
				fprintf(stderr, "swell-vm-usbip-bridge: %s: %s\n", tty, err);
			else
				fprintf(stderr, "swell-vm-usbip-bridge: I/O error: %s\n", strerror(errno));
			rc = 1;
			break;
		}
		sessions++;
		if (end == END_UNPLUG) {
			unplugs++;
			plug_asked = 0;
			printf("swell-vm-usbip-bridge: cable pulled (SIGUSR1) at %.3f s: vhci port %d detached, "
			       "session ended\n",
			       vm_now_s(), port);
			fflush(stdout);
			printf("swell-vm-usbip-bridge: the session ended (%s)\n",
			       end_session(line) ? "the line hung up" : "the line quiet for 1.5 s");
			fflush(stdout);
			while (!vm_stop && !plug_asked) {
				struct timespec ts = { 0, 20000000 };

				nanosleep(&ts, NULL);
			}
			unplug_asked = 0;
			if (vm_stop || wait_line_back(line) != 0)
				break;
			printf("swell-vm-usbip-bridge: plugged in again (SIGUSR2) at %.3f s\n", vm_now_s());
			fflush(stdout);
			continue;
		}
		if (end != END_LINE)
			break;
		printf("swell-vm-usbip-bridge: the server closed the line: device unplugged from vhci port %d\n", port);
		fflush(stdout);
		if (wait_line_back(line) != 0)
			break;
	}
	printf("swell-vm-usbip-bridge: %s <-> vhci: %u sessions, %u unplugs, %" PRIu64 " bytes to the line, %" PRIu64
	       " to vhci\n",
	       tty, sessions, unplugs, to_line.moved, to_vhci.moved);
	close(line);
	return rc;
}
