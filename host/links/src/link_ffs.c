/* FunctionFS: the device side of the controller's vendor USB interface, a link (swell/link.h). */
#define _DEFAULT_SOURCE /* syscall() for Linux AIO */

#include <linux/aio_abi.h>

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <linux/usb/ch9.h>
#include <linux/usb/functionfs.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include "link_priv.h"

#define HS_BULK_PACKET 512u /* the only bulk wMaxPacketSize USB 2.0 allows at high speed */
#define LANG_EN_US 0x0409u
#define EP_DESC_LEN 7u /* USB_DT_ENDPOINT_SIZE: no audio extension */
#define SET_LEN (USB_DT_INTERFACE_SIZE + 2u * EP_DESC_LEN)

/* The interface, then the output buffer and length of the two blocks below. */
static enum swell_err check_args(const struct swell_usb_ffs_iface *it, const uint8_t *buf, const size_t *len)
{
	if (!it || !it->name)
		return SWELL_EINVAL;
	if ((it->ep_out & 0x80u) || (it->ep_out & 0x0Fu) == 0 || it->ep_out > 0x0Fu)
		return SWELL_ERANGE;
	if (!(it->ep_in & 0x80u) || (it->ep_in & 0x0Fu) == 0 || (it->ep_in & 0x70u))
		return SWELL_ERANGE;
	if (it->fs_packet != 8 && it->fs_packet != 16 && it->fs_packet != 32 && it->fs_packet != 64)
		return SWELL_ERANGE;
	size_t n = strnlen(it->name, SWELL_USB_FFS_NAME_MAX + 1);
	if (n == 0 || n > SWELL_USB_FFS_NAME_MAX)
		return SWELL_ERANGE;
	for (size_t i = 0; i < n; i++)
		if (it->name[i] < 0x20 || it->name[i] > 0x7E)
			return SWELL_ERANGE;
	return buf && len ? SWELL_OK : SWELL_EINVAL;
}

static uint8_t *put_set(uint8_t *p, const struct swell_usb_ffs_iface *it, uint16_t packet)
{
	*p++ = USB_DT_INTERFACE_SIZE;
	*p++ = USB_DT_INTERFACE;
	*p++ = 0; /* bInterfaceNumber: FunctionFS renumbers */
	*p++ = 0; /* bAlternateSetting */
	*p++ = 2; /* bNumEndpoints */
	*p++ = it->class_code;
	*p++ = it->subclass;
	*p++ = it->protocol;
	*p++ = 1; /* iInterface: our first string */
	const uint8_t addr[2] = { it->ep_out, it->ep_in };
	for (int i = 0; i < 2; i++) {
		*p++ = EP_DESC_LEN;
		*p++ = USB_DT_ENDPOINT;
		*p++ = addr[i];
		*p++ = USB_ENDPOINT_XFER_BULK;
		p = swell_put_le(p, packet, 2);
		*p++ = 0; /* bInterval: unused for bulk */
	}
	return p;
}

enum swell_err swell_usb_ffs_descriptors(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap, size_t *len)
{
	const size_t total = 5u * 4u + 2u * SET_LEN;
	enum swell_err err = check_args(iface, buf, len);

	if (err != SWELL_OK)
		return err;
	if (cap < total)
		return SWELL_ESIZE;
	uint8_t *p = buf;
	p = swell_put_le(p, FUNCTIONFS_DESCRIPTORS_MAGIC_V2, 4);
	p = swell_put_le(p, (uint32_t)total, 4);
	p = swell_put_le(p, FUNCTIONFS_HAS_FS_DESC | FUNCTIONFS_HAS_HS_DESC, 4);
	p = swell_put_le(p, 3, 4); /* fs_count */
	p = swell_put_le(p, 3, 4); /* hs_count */
	p = put_set(p, iface, iface->fs_packet);
	p = put_set(p, iface, HS_BULK_PACKET);
	*len = (size_t)(p - buf);
	return SWELL_OK;
}

enum swell_err swell_usb_ffs_strings(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap, size_t *len)
{
	enum swell_err err = check_args(iface, buf, len);

	if (err != SWELL_OK)
		return err;
	size_t n = strnlen(iface->name, SWELL_USB_FFS_NAME_MAX + 1);
	size_t total = 4u * 4u + 2u + n + 1u;
	if (cap < total)
		return SWELL_ESIZE;
	uint8_t *p = buf;
	p = swell_put_le(p, FUNCTIONFS_STRINGS_MAGIC, 4);
	p = swell_put_le(p, (uint32_t)total, 4);
	p = swell_put_le(p, 1, 4); /* str_count */
	p = swell_put_le(p, 1, 4); /* lang_count */
	p = swell_put_le(p, LANG_EN_US, 2);
	memcpy(p, iface->name, n);
	p[n] = '\0';
	*len = total;
	return SWELL_OK;
}

/* ---- the link: ep0, the two bulk endpoints and their transfers ---- */

struct ffs_link {
	struct swell_link base;
	int ep0, ep_out, ep_in; /* file descriptors, -1 when closed */
	int efd; /* eventfd: readable when a transfer finished */
	int up; /* endpoints enabled at the last look at ep0, and no read has failed since */
	struct swell_usb_ffs_stats st;
	aio_context_t ctx;
	struct iocb rx_cb;
	struct iocb tx_cb[SWELL_USB_FFS_TX_SLOTS];
	int64_t rx_res; /* result of the finished OUT transfer */
	uint16_t rx_packet; /* OUT wMaxPacketSize at the connected speed: one packet a read */
	uint8_t rx_state; /* 0 idle, 1 queued, 2 finished */
	uint8_t tx_queued[SWELL_USB_FFS_TX_SLOTS];
	uint8_t link_lost; /* a transfer ended with an error: endpoints are going away */
	uint8_t rx_buf[SWELL_USB_FFS_XFER_MAX];
	uint8_t tx_buf[SWELL_USB_FFS_TX_SLOTS][SWELL_USB_FFS_XFER_MAX];
	char dir[SWELL_USB_FFS_PATH_MAX];
};

/* Linux AIO through its system calls (glibc has no wrappers; libaio is not needed). */
static int aio_submit(aio_context_t ctx, struct iocb *cb)
{
	struct iocb *list[1] = { cb };
	return (int)syscall(SYS_io_submit, ctx, 1L, list);
}

#define RX_TAG 0u
#define TX_TAG(k) (1u + (unsigned)(k))

static void close_fd(int *fd)
{
	if (*fd >= 0)
		close(*fd);
	*fd = -1;
}

/* Close the data endpoints. Destroying the AIO context waits for (and cancels) every transfer in
 * flight, so no buffer of ours is written after this returns. */
static void close_data(struct ffs_link *f)
{
	if (f->ctx) {
		syscall(SYS_io_destroy, f->ctx);
		f->ctx = 0;
	}
	close_fd(&f->ep_out);
	close_fd(&f->ep_in);
	f->rx_state = 0;
	memset(f->tx_queued, 0, sizeof(f->tx_queued));
	f->link_lost = 0;
}

static int enabled(const struct ffs_link *f)
{
	return f->ep_out >= 0 && f->ep_in >= 0 && f->ctx != 0;
}

static int open_ep(const struct ffs_link *f, int n, int flags)
{
	char path[SWELL_USB_FFS_PATH_MAX + 8];

	snprintf(path, sizeof(path), "%s/ep%d", f->dir, n);
	return open(path, flags | O_CLOEXEC);
}

/* 0 when all n bytes went to ep0, else a negative errno. */
static int write_all(int fd, const uint8_t *b, size_t n)
{
	const ssize_t w = write(fd, b, n);

	if (w < 0)
		return -errno;
	return (size_t)w == n ? 0 : -EIO;
}

static void prep(struct ffs_link *f, struct iocb *cb, unsigned tag, int fd, uint16_t op, uint8_t *buf, size_t len)
{
	memset(cb, 0, sizeof(*cb));
	cb->aio_data = tag;
	cb->aio_lio_opcode = op;
	cb->aio_fildes = (uint32_t)fd;
	cb->aio_buf = (uint64_t)(uintptr_t)buf;
	cb->aio_nbytes = len;
	cb->aio_flags = IOCB_FLAG_RESFD;
	cb->aio_resfd = (uint32_t)f->efd;
}

/* One packet per transfer: a read longer than wMaxPacketSize would only end at a short packet. */
static int queue_rx(struct ffs_link *f)
{
	prep(f, &f->rx_cb, RX_TAG, f->ep_out, IOCB_CMD_PREAD, f->rx_buf, f->rx_packet);
	if (aio_submit(f->ctx, &f->rx_cb) != 1) {
		f->st.last_errno = errno;
		return -1;
	}
	f->rx_state = 1;
	return 0;
}

/* Collect finished transfers without waiting. */
static void reap(struct ffs_link *f)
{
	struct io_event ev[1 + SWELL_USB_FFS_TX_SLOTS];
	struct timespec zero = { 0, 0 };
	uint64_t count;

	if (read(f->efd, &count, sizeof(count)) < 0) {
		/* EAGAIN: nothing signalled since the last look; the events are read anyway */
	}
	int n = (int)syscall(SYS_io_getevents, f->ctx, 0L, (long)(sizeof(ev) / sizeof(ev[0])), ev, &zero);
	for (int i = 0; i < n; i++) {
		if (ev[i].data == RX_TAG) {
			f->rx_res = ev[i].res;
			f->rx_state = 2;
		} else if (ev[i].data >= TX_TAG(0) && ev[i].data < TX_TAG(SWELL_USB_FFS_TX_SLOTS)) {
			f->tx_queued[ev[i].data - TX_TAG(0)] = 0;
		} else {
			continue;
		}
		if (ev[i].res < 0) {
			f->st.last_errno = (int)-ev[i].res;
			f->link_lost = 1;
		}
	}
}

/* ENABLE: the data endpoints open, at the packet size of the speed the host connected at. */
static void enable(struct ffs_link *f)
{
	struct usb_endpoint_descriptor d;

	close_data(f);
	f->ep_out = open_ep(f, 1, O_RDONLY);
	if (f->ep_out >= 0)
		f->ep_in = open_ep(f, 2, O_WRONLY);
	if (f->ep_out < 0 || f->ep_in < 0 || syscall(SYS_io_setup, 1 + SWELL_USB_FFS_TX_SLOTS, &f->ctx) < 0) {
		f->st.last_errno = errno;
		f->ctx = 0;
		close_data(f);
		return;
	}
	memset(&d, 0, sizeof(d));
	f->rx_packet = 64;
	if (ioctl(f->ep_out, FUNCTIONFS_ENDPOINT_DESC, &d) == 0 && d.wMaxPacketSize >= 8 &&
	    d.wMaxPacketSize <= SWELL_USB_FFS_XFER_MAX)
		f->rx_packet = d.wMaxPacketSize;
	if (queue_rx(f) != 0)
		close_data(f);
}

/* FunctionFS stalls a control request when ep0 is used in the wrong direction. */
static void stall(struct ffs_link *f, const struct usb_ctrlrequest *req)
{
	uint8_t dummy = 0;

	if (((req->bRequestType & USB_DIR_IN) ? read(f->ep0, &dummy, 0) : write(f->ep0, &dummy, 0)) < 0)
		f->st.last_errno = errno;
	f->st.setup_stalled++;
}

/* One ep0 event, if one is waiting, acted on. */
static void ep0_event(struct ffs_link *f)
{
	struct usb_functionfs_event e;
	struct pollfd pfd = { .fd = f->ep0, .events = POLLIN };

	if (poll(&pfd, 1, 0) <= 0 || read(f->ep0, &e, sizeof(e)) != (ssize_t)sizeof(e))
		return;
	if (e.type == FUNCTIONFS_ENABLE)
		enable(f);
	else if (e.type == FUNCTIONFS_DISABLE || e.type == FUNCTIONFS_UNBIND)
		close_data(f);
	else if (e.type == FUNCTIONFS_SETUP)
		stall(f, &e.u.setup);
}

/* The next finished OUT transfer, up to cap bytes (a longer one is cut): its length, 0 when none has
 * arrived, -1 when the host went away (the DISABLE event follows on ep0). */
static long take_rx(struct ffs_link *f, uint8_t *buf, size_t cap)
{
	reap(f);
	if (f->rx_state == 2 && f->rx_res >= 0) {
		const size_t n = (size_t)f->rx_res < cap ? (size_t)f->rx_res : cap;

		memcpy(buf, f->rx_buf, n);
		return queue_rx(f) == 0 ? (long)n : -1;
	}
	return f->link_lost ? -1 : 0;
}

/* A packet into a free IN slot, or refused at once (-EBUSY also while the host is going away: the
 * DISABLE event follows). */
static int ffs_send(struct swell_link *l, const struct swell_frame *fr)
{
	struct ffs_link *f = (struct ffs_link *)l;

	if (!f->up)
		return -ENODEV;
	if (!enabled(f))
		return -EBUSY;
	reap(f);
	for (int k = 0; k < SWELL_USB_FFS_TX_SLOTS && !f->link_lost; k++) {
		if (f->tx_queued[k])
			continue;
		memcpy(f->tx_buf[k], fr->data, fr->len);
		prep(f, &f->tx_cb[k], TX_TAG(k), f->ep_in, IOCB_CMD_PWRITE, f->tx_buf[k], fr->len);
		if (aio_submit(f->ctx, &f->tx_cb[k]) != 1) {
			f->st.last_errno = errno;
			return -EBUSY;
		}
		f->tx_queued[k] = 1;
		return 0;
	}
	f->st.tx_busy_drops += !f->link_lost;
	return -EBUSY;
}

/* One packet: ep0's events first, then a finished OUT transfer; until the deadline, sleep on both. */
static int ffs_recv(struct swell_link *l, struct swell_frame *fr, int timeout_ms)
{
	struct ffs_link *f = (struct ffs_link *)l;
	const uint64_t deadline = swell_link_deadline(timeout_ms);

	for (;;) {
		long n = 0;
		int ms;

		ep0_event(f);
		f->up = enabled(f);
		if (f->up && (n = take_rx(f, fr->data, SWELL_LINK_MTU)) < 0)
			f->up = 0;
		if (f->up && n > 0) {
			fr->t_ns = swell_link_now_ns();
			fr->id = 0;
			fr->flags = 0;
			fr->len = (uint16_t)n;
			return 0;
		}
		ms = swell_link_ms_left(deadline, timeout_ms);
		if (ms == 0)
			return f->up ? -ETIMEDOUT : -ENODEV;
		struct pollfd p[2] = { { .fd = f->ep0, .events = POLLIN }, { .fd = f->efd, .events = POLLIN } };
		if (poll(p, 2, ms) < 0 && errno != EINTR)
			return -errno;
	}
}

/* The data endpoints cannot be polled: their AIO eventfd can. */
static int ffs_poll_fd(const struct swell_link *l)
{
	const struct ffs_link *f = (const struct ffs_link *)l;

	return f->up ? f->efd : f->ep0;
}

static void ffs_close(struct swell_link *l)
{
	struct ffs_link *f = (struct ffs_link *)l;

	close_data(f);
	close_fd(&f->efd);
	close_fd(&f->ep0);
	free(f);
}

static const struct swell_link_ops ffs_ops = { ffs_send, ffs_recv, ffs_close, ffs_poll_fd };

/* ep0 and the eventfd opened, the descriptors and strings written: the function can be bound to a UDC. */
static int open_ep0(struct ffs_link *f, const struct swell_usb_ffs_iface *iface)
{
	uint8_t desc[SWELL_USB_FFS_DESC_MAX], str[SWELL_USB_FFS_STR_MAX];
	size_t desc_len = 0, str_len = 0;
	char path[SWELL_USB_FFS_PATH_MAX + 8];
	enum swell_err e = swell_usb_ffs_descriptors(iface, desc, sizeof(desc), &desc_len);
	int rc;

	if (e == SWELL_OK)
		e = swell_usb_ffs_strings(iface, str, sizeof(str), &str_len);
	if (e != SWELL_OK)
		return -EINVAL;
	snprintf(path, sizeof(path), "%s/ep0", f->dir);
	f->ep0 = open(path, O_RDWR | O_CLOEXEC);
	if (f->ep0 < 0)
		return -errno;
	f->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	rc = f->efd < 0 ? -errno : write_all(f->ep0, desc, desc_len);
	return rc ? rc : write_all(f->ep0, str, str_len);
}

int swell_link_open_ffs(struct swell_link **out, const char *dir, const struct swell_usb_ffs_iface *iface)
{
	struct ffs_link *f;
	int rc;

	if (!out || !dir)
		return -EINVAL;
	if (strlen(dir) >= SWELL_USB_FFS_PATH_MAX)
		return -ENAMETOOLONG;
	f = calloc(1, sizeof(*f));
	if (!f)
		return -ENOMEM;
	f->ep0 = f->ep_out = f->ep_in = f->efd = -1;
	memcpy(f->dir, dir, strlen(dir) + 1);
	rc = open_ep0(f, iface);
	if (rc) {
		ffs_close(&f->base);
		return rc;
	}
	f->base.ops = &ffs_ops;
	f->base.carrier = SWELL_CARRIER_PKT;
	snprintf(f->base.name, sizeof(f->base.name), "usb:%s", dir);
	*out = &f->base;
	return 0;
}

const struct swell_usb_ffs_stats *swell_link_ffs_stats(const struct swell_link *l)
{
	return (l && l->ops == &ffs_ops) ? &((const struct ffs_link *)l)->st : NULL;
}
