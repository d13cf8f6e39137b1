/* swell-vm-dfuse: an emulated STM32F405 ROM DFU bootloader for the HIL VM. A GadgetFS USB device
 * (0483:df11, DFU class 0xFE/1/2, DfuSe 1.1a functional descriptor) that stores what it receives
 * in a 1 MiB flash file, reads it back on UPLOAD and logs every request. The DfuSe logic is
 * dfuse_target.c; this file is the USB side. GadgetFS, not FunctionFS: the Debian 12 kernel's
 * FunctionFS refuses a DFU functional descriptor; GadgetFS carries any descriptor but stalls
 * control OUT transfers longer than 256 bytes, hence wTransferSize 256, not the ROM's 2048
 * (docs/hil-vm.md). */
#define _GNU_SOURCE /* sched_setscheduler, pwrite */

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/usb/ch9.h>
#include <linux/usb/gadgetfs.h>
#include <poll.h>
#include <sched.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "dfuse_target.h"
#include "swell/cli.h"
#include "vm-util.h"

#define PROG "swell-vm-dfuse"
#define EP0_MAX 64u
#define GADGETFS_EP0_MAX 256u /* RBUF_SIZE of drivers/usb/gadget/legacy/inode.c: longer OUT data stalls */

static struct swell_dfuse target; /* 1 MiB of flash: static, not on the stack */
static FILE *log_out;
static double t0;

static void usage(FILE *to)
{
	fprintf(to,
		"usage: " PROG " --flash FILE [--log FILE] [--gadgetfs DIR] [--transfer-size N] [--poll-ms N]\n"
		"                      [--leave-ms N] [--serial TEXT] [--bad-cell ADDRESS] [--no-rt]\n"
		"Be an STM32F405 in its ROM DFU bootloader on the VM's USB bus, for dfu-util: VID:PID 0483:df11,\n"
		"DfuSe 1.1a, alternate setting 0 \"@Internal Flash  /0x08000000/04*016Kg,01*064Kg,07*128Kg\"\n"
		"(1 MiB; the option bytes, OTP and feature settings are listed but refused). Handles DNLOAD\n"
		"(set address 0x21, erase 0x41, mass erase, data blocks at (wBlockNum-2)*wTransferSize +\n"
		"pointer), UPLOAD, GETSTATUS, CLRSTATUS, GETSTATE, ABORT and the leave\n"
		"request; refuses writes outside the flash (errADDRESS) or to bytes not erased\n"
		"(errCHECK_ERASED) with dfuERROR, changing nothing. Exits after leaving DFU.\n"
		"  --flash FILE     the flash, %u bytes, written through as it changes; created erased (0xFF)\n"
		"                   when missing\n"
		"  --log FILE       one line per USB request and event (default: standard output); DFU class\n"
		"                   requests start with 'dfu ', the rest with 'usb '\n"
		"  --gadgetfs DIR   mounted GadgetFS (default /dev/gadget); its one file is the UDC's ep0\n"
		"  --transfer-size N  wTransferSize in bytes, 1..%u (default and most GadgetFS takes: %u;\n"
		"                   the F405 ROM has 2048)\n"
		"  --poll-ms N      bwPollTimeout of the busy answers, ms (default 1)\n"
		"  --leave-ms N     after reporting dfuMANIFEST, wait N ms, then disconnect (default 50)\n"
		"  --serial TEXT    serial number string (default 5357454C4C31)\n"
		"  --bad-cell ADDRESS  fault injection: the byte written at ADDRESS is stored with bit 0\n"
		"                   inverted (a bad flash cell), so a read-back verify must fail\n"
		"  --no-rt          stay a normal process (default: SCHED_FIFO, so that each request is\n"
		"                   read before the host can send the next one; see docs/hil-vm.md)\n"
		"Exit status: 0 left DFU or stopped by SIGTERM/SIGINT, 1 USB or file error, 2 bad arguments.\n",
		SWELL_DFUSE_FLASH_SIZE, GADGETFS_EP0_MAX, GADGETFS_EP0_MAX);
}

static void logline(const char *kind, const char *fmt, ...)
{
	va_list ap;

	fprintf(log_out, "%s %10.6f ", kind, vm_now_s() - t0);
	va_start(ap, fmt);
	vfprintf(log_out, fmt, ap);
	va_end(ap);
	fputc('\n', log_out);
	fflush(log_out);
}

/* Strings: 0 languages, 1-3 device, 4-7 the alternate settings (as the F405 ROM names them). */
static const char *const alt_names[SWELL_DFUSE_ALTS] = {
	"@Internal Flash  /0x08000000/04*016Kg,01*064Kg,07*128Kg",
	"@Option Bytes  /0x1FFFC000/01*016 e",
	"@OTP Memory /0x1FFF7800/01*512 e,01*016 e",
	"@Device Feature/0xFFFF0000/01*004 e",
};

static size_t string_desc(unsigned index, const char *serial, uint8_t *out, size_t cap)
{
	const char *const device[4] = { NULL, "STMicroelectronics", "STM32  BOOTLOADER", serial };

	if (index == 0) {
		const uint8_t lang[4] = { 4, USB_DT_STRING, 0x09, 0x04 };
		memcpy(out, lang, sizeof(lang));
		return sizeof(lang);
	}
	if (index >= 4u + SWELL_DFUSE_ALTS)
		return 0;
	const char *s = index < 4u ? device[index] : alt_names[index - 4u];
	size_t n = strlen(s);
	if (2u + 2u * n > cap || 2u + 2u * n > 255u)
		n = (cap < 255u ? cap - 2u : 253u) / 2u;
	out[0] = (uint8_t)(2u + 2u * n);
	out[1] = USB_DT_STRING;
	for (size_t i = 0; i < n; i++) {
		out[2 + 2 * i] = (uint8_t)s[i];
		out[3 + 2 * i] = 0;
	}
	return 2u + 2u * n;
}

/* GadgetFS set-up blob: tag 0, the full-speed configuration, the device descriptor. */
static size_t descriptors(uint8_t *b, unsigned xfer)
{
	static const uint8_t config[9] = { 9, USB_DT_CONFIG, 0, 0, 1, 1, 0, 0xC0, 50 };
	/* DFU functional: will detach, upload, download; detach timeout 255 ms; wTransferSize; DfuSe 1.1a */
	const uint8_t dfu_func[9] = { 9,    0x21, 0x0B, 0xFF, 0x00, (uint8_t)(xfer & 0xFFu), (uint8_t)(xfer >> 8),
				      0x1A, 0x01 };
	static const uint8_t device[18] = { 18,   USB_DT_DEVICE, 0x00, 0x02, 0,    0, 0, EP0_MAX, 0x83,
					    0x04, 0x11,          0xDF, 0x00, 0x22, 1, 2, 3,       1 };
	size_t n = 4;

	memset(b, 0, 4); /* tag */
	memcpy(b + n, config, sizeof(config));
	n += sizeof(config);
	for (unsigned alt = 0; alt < SWELL_DFUSE_ALTS; alt++) {
		const uint8_t iface[9] = { 9,    USB_DT_INTERFACE,   0, (uint8_t)alt, 0, 0xFE, 0x01,
					   0x02, (uint8_t)(4u + alt) };
		memcpy(b + n, iface, sizeof(iface));
		n += sizeof(iface);
	}
	memcpy(b + n, dfu_func, sizeof(dfu_func)); /* after the last alternate setting, as the ROM has it */
	n += sizeof(dfu_func);
	size_t total = n - 4;
	b[4 + 2] = (uint8_t)(total & 0xFF);
	b[4 + 3] = (uint8_t)(total >> 8);
	memcpy(b + n, device, sizeof(device));
	return n + sizeof(device);
}

static int find_ep0(const char *dir, char *path, size_t cap)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	int rc = -1;

	if (!d)
		return -1;
	while ((e = readdir(d)) != NULL) {
		/* Skip . and .. and the endpoint files GadgetFS adds once bound (ep1in-bulk, ...). */
		if (e->d_name[0] == '.' || (!strncmp(e->d_name, "ep", 2) && e->d_name[2] >= '0' && e->d_name[2] <= '9'))
			continue;
		if ((size_t)snprintf(path, cap, "%s/%s", dir, e->d_name) < cap)
			rc = 0;
		break;
	}
	closedir(d);
	return rc;
}

/* The flash file: exactly SWELL_DFUSE_FLASH_SIZE bytes, loaded into the target; made erased if missing. */
static int open_flash(const char *path)
{
	int fd = open(path, O_RDWR | O_CLOEXEC);

	if (fd < 0 && errno == ENOENT) {
		fd = open(path, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
		if (fd < 0 || pwrite(fd, target.flash, sizeof(target.flash), 0) != (ssize_t)sizeof(target.flash)) {
			fprintf(stderr, PROG ": cannot create the flash file %s: %s\n", path, strerror(errno));
			return -1;
		}
		return fd;
	}
	if (fd < 0) {
		fprintf(stderr, PROG ": cannot open the flash file %s: %s\n", path, strerror(errno));
		return -1;
	}
	struct stat st;
	if (fstat(fd, &st) != 0 || st.st_size != (off_t)sizeof(target.flash) ||
	    pread(fd, target.flash, sizeof(target.flash), 0) != (ssize_t)sizeof(target.flash)) {
		fprintf(stderr, PROG ": the flash file %s must hold exactly %u bytes\n", path, SWELL_DFUSE_FLASH_SIZE);
		close(fd);
		return -1;
	}
	return fd;
}

struct dev {
	long bad_cell; /* flash offset of the faulty byte, -1: none */
	int ep0;
	int flash_fd;
	const char *serial;
	unsigned dfu_requests;
};

/* ep0 replies through GadgetFS: IN data is a write; a zero-length read acks an OUT request or
 * stalls an IN one; a zero-length write stalls an OUT request without data. */
static void reply_stall(const struct dev *d, int is_in)
{
	uint8_t dummy = 0;

	if ((is_in ? read(d->ep0, &dummy, 0) : write(d->ep0, &dummy, 0)) < 0 && errno != EL2HLT)
		logline("usb", "stall (%s) failed: %s", is_in ? "IN" : "OUT", strerror(errno));
}

static void reply_ack(const struct dev *d)
{
	uint8_t dummy = 0;

	if (read(d->ep0, &dummy, 0) < 0)
		logline("usb", "status stage failed: %s", strerror(errno));
}

static void reply_data(const struct dev *d, const uint8_t *buf, size_t n)
{
	if (write(d->ep0, buf, n) != (ssize_t)n)
		logline("usb", "IN data stage of %zu bytes failed: %s", n, strerror(errno));
}

static int persist(struct dev *d)
{
	uint32_t lo, hi;

	swell_dfuse_take_dirty(&target, &lo, &hi);
	if (lo < hi && pwrite(d->flash_fd, target.flash + lo, hi - lo, lo) != (ssize_t)(hi - lo)) {
		fprintf(stderr, PROG ": writing the flash file failed: %s\n", strerror(errno));
		return -1;
	}
	return 0;
}

static const char *dfu_request_name(unsigned r)
{
	static const char *const names[] = {
		"DETACH", "DNLOAD", "UPLOAD", "GETSTATUS", "CLRSTATUS", "GETSTATE", "ABORT"
	};
	return r < sizeof(names) / sizeof(names[0]) ? names[r] : "UNKNOWN";
}

static int handle_dfu(struct dev *d, const struct usb_ctrlrequest *c)
{
	static uint8_t out[SWELL_DFUSE_XFER_MAX], in[SWELL_DFUSE_XFER_MAX];
	const struct swell_dfuse_setup s = { c->bRequestType, c->bRequest, __le16_to_cpu(c->wValue),
					     __le16_to_cpu(c->wIndex), __le16_to_cpu(c->wLength) };
	const int is_in = (c->bRequestType & USB_DIR_IN) != 0;
	size_t out_len = 0, in_len = 0;

	d->dfu_requests++;
	if (!is_in && s.length > 0) {
		/* GadgetFS has already queued the data stage; collect it (it cannot be stalled). */
		ssize_t r = read(d->ep0, out, s.length <= sizeof(out) ? s.length : sizeof(out));
		if (r < 0) {
			logline("dfu", "%s block=%u len=%u: data stage lost: %s", dfu_request_name(s.request),
				(unsigned)s.value, (unsigned)s.length, strerror(errno));
			return 0;
		}
		out_len = (size_t)r;
	}
	const uint32_t written = target.bytes_written;
	enum swell_dfuse_reply rep = swell_dfuse_request(&target, &s, out, out_len, in, sizeof(in), &in_len);
	/* The dirty range is this request's alone (persist() takes it after every request). */
	if (d->bad_cell >= 0 && target.bytes_written != written && (uint32_t)d->bad_cell >= target.dirty_lo &&
	    (uint32_t)d->bad_cell < target.dirty_hi) {
		target.flash[d->bad_cell] ^= 0x01u;
		logline("dfu", "fault: bad cell 0x%08lx stores bit 0 inverted",
			(unsigned long)(SWELL_DFUSE_FLASH_BASE + (unsigned long)d->bad_cell));
	}
	switch (rep) {
	case SWELL_DFUSE_DATA:
		reply_data(d, in, in_len);
		break;
	case SWELL_DFUSE_ACK:
		if (s.length == 0)
			reply_ack(d);
		break;
	case SWELL_DFUSE_STALL:
		if (is_in || s.length == 0)
			reply_stall(d, is_in);
		break;
	}
	char what[24];
	if (rep == SWELL_DFUSE_DATA)
		snprintf(what, sizeof(what), "data %zu", in_len);
	else
		snprintf(what, sizeof(what), "%s", rep == SWELL_DFUSE_ACK ? "ack" : "stall");
	logline("dfu", "%s block=%u len=%u -> %s, %s %s%s%s", dfu_request_name(s.request), (unsigned)s.value,
		(unsigned)s.length, what, swell_dfu_state_name(target.state), swell_dfu_status_name(target.status),
		target.note[0] ? ": " : "", target.note);
	return persist(d);
}

static int handle_setup(struct dev *d, const struct usb_ctrlrequest *c)
{
	static uint8_t buf[256];
	const unsigned value = __le16_to_cpu(c->wValue), len = __le16_to_cpu(c->wLength);
	const int is_in = (c->bRequestType & USB_DIR_IN) != 0;

	if ((c->bRequestType & USB_TYPE_MASK) == USB_TYPE_CLASS &&
	    (c->bRequestType & USB_RECIP_MASK) == USB_RECIP_INTERFACE)
		return handle_dfu(d, c);
	if ((c->bRequestType & USB_TYPE_MASK) == USB_TYPE_STANDARD) {
		switch (c->bRequest) {
		case USB_REQ_GET_DESCRIPTOR:
			if ((value >> 8) == USB_DT_STRING) {
				size_t n = string_desc(value & 0xFFu, d->serial, buf, sizeof(buf));
				if (n > 0) {
					reply_data(d, buf, n < len ? n : len);
					logline("usb", "GET_DESCRIPTOR string %u -> %zu bytes", value & 0xFFu, n);
					return 0;
				}
			}
			break;
		case USB_REQ_SET_CONFIGURATION:
			reply_ack(d);
			logline("usb", "SET_CONFIGURATION %u", value);
			return 0;
		case USB_REQ_SET_INTERFACE:
			if (swell_dfuse_set_alt(&target, value) == 0) {
				reply_ack(d);
				logline("usb", "SET_INTERFACE alt %u", value);
				return 0;
			}
			break;
		case USB_REQ_GET_INTERFACE:
			if (is_in && len >= 1) {
				buf[0] = target.alt;
				reply_data(d, buf, 1);
				logline("usb", "GET_INTERFACE -> alt %u", (unsigned)target.alt);
				return 0;
			}
			break;
		default:
			break;
		}
	}
	const int drop = !is_in && len > 0;
	if (drop) /* an OUT data stage GadgetFS has queued cannot be stalled: collect it, drop it */
		(void)!read(d->ep0, buf, len < sizeof(buf) ? len : sizeof(buf));
	else
		reply_stall(d, is_in);
	logline("usb", "request type 0x%02x req 0x%02x value 0x%04x len %u -> %s", c->bRequestType, c->bRequest, value,
		len, drop ? "data dropped (not stallable)" : "stall");
	return 0;
}

int main(int argc, char **argv)
{
	const char *flash_path = NULL, *log_path = NULL, *gfs = "/dev/gadget";
	long poll_ms = 1, leave_ms = 50, xfer = GADGETFS_EP0_MAX;
	int rt = 1;
	struct dev d = { .bad_cell = -1, .ep0 = -1, .flash_fd = -1, .serial = "5357454C4C31", .dfu_requests = 0 };

	long bad_addr = -1;
	const struct swell_cli_opt opts[] = {
		SWELL_CLI_SET("--no-rt", rt, 0),
		SWELL_CLI_STR("--flash", flash_path),
		SWELL_CLI_STR("--log", log_path),
		SWELL_CLI_STR("--gadgetfs", gfs),
		SWELL_CLI_STR("--serial", d.serial),
		SWELL_CLI_WHOLE("--transfer-size", xfer, 1, GADGETFS_EP0_MAX, "bytes"),
		SWELL_CLI_HEX("--bad-cell", bad_addr, SWELL_DFUSE_FLASH_BASE,
			      SWELL_DFUSE_FLASH_BASE + SWELL_DFUSE_FLASH_SIZE - 1),
		SWELL_CLI_WHOLE("--poll-ms", poll_ms, 0, 10000, "ms"),
		SWELL_CLI_WHOLE("--leave-ms", leave_ms, 0, 10000, "ms"),
	};
	struct swell_cli cli = { .prog = PROG, .opt = opts, .n_opt = SWELL_CLI_N(opts) };
	const int scanned = swell_cli_scan(&cli, argc, argv);

	if (scanned > 0) {
		usage(stdout);
		return 0;
	}
	if (scanned < 0)
		swell_cli_die(PROG, "%s", cli.why);
	if (strlen(d.serial) == 0 || strlen(d.serial) > 60)
		swell_cli_die(PROG, "--serial needs 1..60 characters");
	if (bad_addr >= 0)
		d.bad_cell = bad_addr - (long)SWELL_DFUSE_FLASH_BASE;
	if (!flash_path) {
		fprintf(stderr, PROG ": --flash FILE is required (see --help)\n");
		return 2;
	}
	log_out = stdout;
	if (log_path && !(log_out = fopen(log_path, "a"))) {
		fprintf(stderr, PROG ": cannot open the log %s: %s\n", log_path, strerror(errno));
		return 1;
	}
	t0 = vm_now_s();
	if (swell_dfuse_init(&target, (uint32_t)poll_ms, (unsigned)xfer) != SWELL_OK)
		return 2;
	d.flash_fd = open_flash(flash_path);
	if (d.flash_fd < 0)
		return 1;

	vm_catch_stop();

	/* GadgetFS queues an OUT data stage as soon as the SETUP arrives and the host's next request
	 * would overwrite it: answer before the host (a normal process) runs again, like hardware. */
	struct sched_param sp = { .sched_priority = 10 };
	if (rt && sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
		fprintf(stderr, PROG ": warning: no SCHED_FIFO (%s); requests may race the host\n", strerror(errno));

	char ep0_path[512];
	if (find_ep0(gfs, ep0_path, sizeof(ep0_path)) != 0) {
		fprintf(stderr, PROG ": no UDC file in %s (is GadgetFS mounted there, is dummy_hcd loaded?)\n", gfs);
		return 1;
	}
	d.ep0 = open(ep0_path, O_RDWR | O_CLOEXEC);
	if (d.ep0 < 0) {
		fprintf(stderr, PROG ": cannot open %s: %s\n", ep0_path, strerror(errno));
		return 1;
	}
	uint8_t blob[128];
	size_t n = descriptors(blob, (unsigned)xfer);
	if (write(d.ep0, blob, n) != (ssize_t)n) {
		fprintf(stderr, PROG ": %s refused the descriptors: %s (is the UDC taken by a configfs gadget?)\n",
			ep0_path, strerror(errno));
		return 1;
	}
	logline("usb", "descriptors written to %s: 0483:df11, DfuSe 1.1a, %u-byte transfers, flash %s", ep0_path,
		(unsigned)xfer, flash_path);

	int rc = 0;
	double leave_at = 0;
	while (!vm_stop) {
		if (target.leave && leave_at == 0)
			leave_at = vm_now_s() + (double)leave_ms / 1000.0;
		if (leave_at != 0 && vm_now_s() >= leave_at)
			break;
		struct pollfd pfd = { .fd = d.ep0, .events = POLLIN, .revents = 0 };
		int pr = poll(&pfd, 1, leave_at != 0 ? 5 : 100);
		if (pr < 0 && errno != EINTR) {
			fprintf(stderr, PROG ": poll: %s\n", strerror(errno));
			rc = 1;
			break;
		}
		if (pr <= 0)
			continue;
		if (!(pfd.revents & POLLIN)) {
			/* POLLOUT alone: a request of ours is still open (its SETUP was overtaken, see
			 * handle_dfu), and GadgetFS shows no events until it is closed. Close it (an IN is
			 * stalled, an OUT acked) instead of spinning at real-time priority. POLLHUP: the
			 * host aborted a request; the next read clears it. */
			if (pfd.revents & POLLOUT) {
				uint8_t dummy = 0;
				if (read(d.ep0, &dummy, 0) < 0 && errno != EL2HLT)
					logline("usb", "closing an unanswered request failed: %s", strerror(errno));
				else
					logline("usb", "unanswered request closed (IN stalled, OUT acked)");
			} else if (pfd.revents & (POLLHUP | POLLERR)) {
				uint8_t dummy[sizeof(struct usb_gadgetfs_event)];
				(void)!read(d.ep0, dummy, sizeof(dummy));
			}
			continue;
		}
		struct usb_gadgetfs_event ev[4];
		ssize_t r = read(d.ep0, ev, sizeof(ev));
		if (r < 0) {
			if (errno == EAGAIN || errno == EINTR || errno == EIDRM)
				continue;
			fprintf(stderr, PROG ": reading ep0 events: %s\n", strerror(errno));
			rc = 1;
			break;
		}
		for (size_t k = 0; k < (size_t)r / sizeof(ev[0]); k++) {
			if (ev[k].type == GADGETFS_SETUP && handle_setup(&d, &ev[k].u.setup) != 0)
				rc = 1;
			else if (ev[k].type == GADGETFS_CONNECT)
				logline("usb", "connect, speed %d", (int)ev[k].u.speed);
			else if (ev[k].type == GADGETFS_DISCONNECT || ev[k].type == GADGETFS_SUSPEND)
				logline("usb", "%s", ev[k].type == GADGETFS_SUSPEND ? "suspend" : "disconnect");
		}
		if (rc)
			break;
	}
	close(d.ep0); /* unbinds GadgetFS: the device leaves the bus */
	if (target.leave)
		logline("usb", "left DFU: disconnected, the image starts at 0x%08x", (unsigned)target.leave_address);
	logline("usb", "summary: %u DFU requests, %u bytes written, %u sectors erased, %u bytes read, %u refused",
		d.dfu_requests, (unsigned)target.bytes_written, (unsigned)target.sectors_erased,
		(unsigned)target.bytes_read, (unsigned)target.refused);
	if (fsync(d.flash_fd) != 0 || close(d.flash_fd) != 0)
		rc = 1;
	if (log_out != stdout)
		fclose(log_out);
	return rc;
}
