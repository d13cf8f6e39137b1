/* FunctionFS: the device side of the controller's vendor USB interface (swell/usb_ffs.h), and the
 * link on it (swell_link_open_ffs in swell/link.h). */
#define _DEFAULT_SOURCE /* syscall() for Linux AIO */

#include "swell/usb_ffs.h"

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

static uint8_t *put_le16(uint8_t *p, uint16_t v)
{
	p[0] = (uint8_t)(v & 0xFFu);
	p[1] = (uint8_t)(v >> 8);
	return p + 2;
}

static uint8_t *put_le32(uint8_t *p, uint32_t v)
{
	for (int i = 0; i < 4; i++)
		p[i] = (uint8_t)(v >> (8 * i));
	return p + 4;
}

static size_t name_len(const char *s)
{
	size_t n = 0;

	while (n <= SWELL_USB_FFS_NAME_MAX && s[n] != '\0')
		n++;
	return n;
}

static enum swell_err check_iface(const struct swell_usb_ffs_iface *it)
{
	if (!it || !it->name)
		return SWELL_EINVAL;
	if ((it->ep_out & 0x80u) || (it->ep_out & 0x0Fu) == 0 || it->ep_out > 0x0Fu)
		return SWELL_ERANGE;
	if (!(it->ep_in & 0x80u) || (it->ep_in & 0x0Fu) == 0 || (it->ep_in & 0x70u))
		return SWELL_ERANGE;
	if (it->fs_packet != 8 && it->fs_packet != 16 && it->fs_packet != 32 && it->fs_packet != 64)
		return SWELL_ERANGE;
	size_t n = name_len(it->name);
	if (n == 0 || n > SWELL_USB_FFS_NAME_MAX)
		return SWELL_ERANGE;
	for (size_t i = 0; i < n; i++)
		if (it->name[i] < 0x20 || it->name[i] > 0x7E)
			return SWELL_ERANGE;
	return SWELL_OK;
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
		p = put_le16(p, packet);
		*p++ = 0; /* bInterval: unused for bulk */
	}
	return p;
}

enum swell_err swell_usb_ffs_descriptors(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap, size_t *len)
{
	const size_t total = 5u * 4u + 2u * SET_LEN;
	enum swell_err err = check_iface(iface);

	if (err != SWELL_OK)
		return err;
	if (!buf || !len)
		return SWELL_EINVAL;
	if (cap < total)
		return SWELL_ESIZE;
	uint8_t *p = buf;
	p = put_le32(p, FUNCTIONFS_DESCRIPTORS_MAGIC_V2);
	p = put_le32(p, (uint32_t)total);
	p = put_le32(p, FUNCTIONFS_HAS_FS_DESC | FUNCTIONFS_HAS_HS_DESC);
	p = put_le32(p, 3); /* fs_count */
	p = put_le32(p, 3); /* hs_count */
	p = put_set(p, iface, iface->fs_packet);
	p = put_set(p, iface, HS_BULK_PACKET);
	*len = (size_t)(p - buf);
	return SWELL_OK;
}

enum swell_err swell_usb_ffs_strings(const struct swell_usb_ffs_iface *iface, uint8_t *buf, size_t cap, size_t *len)
{
	enum swell_err err = check_iface(iface);

	if (err != SWELL_OK)
		return err;
	if (!buf || !len)
		return SWELL_EINVAL;
	size_t n = name_len(iface->name);
	size_t total = 4u * 4u + 2u + n + 1u;
	if (cap < total)
		return SWELL_ESIZE;
	uint8_t *p = buf;
	p = put_le32(p, FUNCTIONFS_STRINGS_MAGIC);
	p = put_le32(p, (uint32_t)total);
	p = put_le32(p, 1); /* str_count */
	p = put_le32(p, 1); /* lang_count */
	p = put_le16(p, LANG_EN_US);
	memcpy(p, iface->name, n);
	p[n] = '\0';
	*len = total;
	return SWELL_OK;
}

/* Linux AIO through its system calls (glibc has no wrappers; libaio is not needed). */
static int aio_setup(unsigned nr, aio_context_t *ctx)
{
	return (int)syscall(SYS_io_setup, nr, ctx);
}

static int aio_destroy(aio_context_t ctx)
{
	return (int)syscall(SYS_io_destroy, ctx);
}

static int aio_submit(aio_context_t ctx, struct iocb *cb)
{
	struct iocb *list[1] = { cb };
	return (int)syscall(SYS_io_submit, ctx, 1L, list);
}

static int aio_reap(aio_context_t ctx, struct io_event *ev, long max)
{
	struct timespec zero = { 0, 0 };
	return (int)syscall(SYS_io_getevents, ctx, 0L, max, ev, &zero);
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
static void close_data(struct swell_usb_ffs *f)
{
	if (f->ctx) {
		aio_destroy(f->ctx);
		f->ctx = 0;
	}
	close_fd(&f->ep_out);
	close_fd(&f->ep_in);
	f->rx_state = 0;
	memset(f->tx_queued, 0, sizeof(f->tx_queued));
	f->link_lost = 0;
}

static int open_ep(const struct swell_usb_ffs *f, int n, int flags)
{
	char path[SWELL_USB_FFS_PATH_MAX + 8];

	snprintf(path, sizeof(path), "%s/ep%d", f->dir, n);
	return open(path, flags | O_CLOEXEC);
}

static enum swell_err write_all(struct swell_usb_ffs *f, int fd, const uint8_t *b, size_t n)
{
	ssize_t w = write(fd, b, n);

	if (w < 0) {
		f->last_errno = errno;
		return SWELL_ESTATE;
	}
	if ((size_t)w != n) {
		f->last_errno = EIO;
		return SWELL_ETRUNC;
	}
	return SWELL_OK;
}

static void prep(struct swell_usb_ffs *f, struct iocb *cb, unsigned tag, int fd, uint16_t op, uint8_t *buf, size_t len)
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

static enum swell_err queue_rx(struct swell_usb_ffs *f)
{
	/* One packet per transfer: a read longer than wMaxPacketSize would only end at a short packet. */
	prep(f, &f->rx_cb, RX_TAG, f->ep_out, IOCB_CMD_PREAD, f->rx_buf, f->rx_packet);
	if (aio_submit(f->ctx, &f->rx_cb) != 1) {
		f->last_errno = errno;
		return SWELL_ESTATE;
	}
	f->rx_state = 1;
	return SWELL_OK;
}

/* Collect finished transfers without waiting. */
static void reap(struct swell_usb_ffs *f)
{
	struct io_event ev[1 + SWELL_USB_FFS_TX_SLOTS];
	uint64_t count;

	if (read(f->efd, &count, sizeof(count)) < 0) {
		/* EAGAIN: nothing signalled since the last look; the events are read anyway */
	}
	int n = aio_reap(f->ctx, ev, (long)(sizeof(ev) / sizeof(ev[0])));
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
			f->last_errno = (int)-ev[i].res;
			f->link_lost = 1;
		}
	}
}

enum swell_err swell_usb_ffs_open(struct swell_usb_ffs *f, const char *dir, const struct swell_usb_ffs_iface *iface)
{
	uint8_t desc[SWELL_USB_FFS_DESC_MAX];
	uint8_t str[SWELL_USB_FFS_STR_MAX];
	size_t desc_len, str_len;
	enum swell_err err;

	if (!f || !dir)
		return SWELL_EINVAL;
	if (strlen(dir) >= sizeof(f->dir))
		return SWELL_ESIZE;
	err = swell_usb_ffs_descriptors(iface, desc, sizeof(desc), &desc_len);
	if (err == SWELL_OK)
		err = swell_usb_ffs_strings(iface, str, sizeof(str), &str_len);
	if (err != SWELL_OK)
		return err;
	memset(f, 0, sizeof(*f));
	f->ep0 = f->ep_out = f->ep_in = f->efd = -1;
	memcpy(f->dir, dir, strlen(dir) + 1);

	char path[SWELL_USB_FFS_PATH_MAX + 8];
	snprintf(path, sizeof(path), "%s/ep0", f->dir);
	f->ep0 = open(path, O_RDWR | O_CLOEXEC);
	if (f->ep0 < 0) {
		f->last_errno = errno;
		return SWELL_ESTATE;
	}
	f->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	if (f->efd < 0) {
		f->last_errno = errno;
		err = SWELL_ESTATE;
	} else {
		err = write_all(f, f->ep0, desc, desc_len);
	}
	if (err == SWELL_OK)
		err = write_all(f, f->ep0, str, str_len);
	if (err != SWELL_OK) {
		close_fd(&f->efd);
		close_fd(&f->ep0);
	}
	return err;
}

static enum swell_err enable(struct swell_usb_ffs *f)
{
	close_data(f);
	f->ep_out = open_ep(f, 1, O_RDONLY);
	if (f->ep_out >= 0)
		f->ep_in = open_ep(f, 2, O_WRONLY);
	if (f->ep_out < 0 || f->ep_in < 0 || aio_setup(1 + SWELL_USB_FFS_TX_SLOTS, &f->ctx) < 0) {
		f->last_errno = errno;
		f->ctx = 0;
		close_data(f);
		return SWELL_ESTATE;
	}
	/* The descriptor of the speed the host connected at. */
	struct usb_endpoint_descriptor d;
	memset(&d, 0, sizeof(d));
	f->rx_packet = 64;
	if (ioctl(f->ep_out, FUNCTIONFS_ENDPOINT_DESC, &d) == 0 && d.wMaxPacketSize >= 8 &&
	    d.wMaxPacketSize <= SWELL_USB_FFS_XFER_MAX)
		f->rx_packet = d.wMaxPacketSize;
	if (queue_rx(f) != SWELL_OK) {
		close_data(f);
		return SWELL_ESTATE;
	}
	return SWELL_OK;
}

static void stall(struct swell_usb_ffs *f, const struct usb_ctrlrequest *req)
{
	uint8_t dummy = 0;

	/* FunctionFS stalls a control request when ep0 is used in the wrong direction. */
	if (req->bRequestType & USB_DIR_IN) {
		if (read(f->ep0, &dummy, 0) < 0)
			f->last_errno = errno;
	} else {
		if (write(f->ep0, &dummy, 0) < 0)
			f->last_errno = errno;
	}
	f->setup_stalled++;
}

enum swell_err swell_usb_ffs_poll(struct swell_usb_ffs *f, int timeout_ms, enum swell_usb_ffs_event *ev)
{
	struct usb_functionfs_event e;
	struct pollfd pfd;

	if (!f || !ev || f->ep0 < 0)
		return SWELL_EINVAL;
	*ev = SWELL_USB_FFS_NONE;
	pfd.fd = f->ep0;
	pfd.events = POLLIN;
	pfd.revents = 0;
	int r = poll(&pfd, 1, timeout_ms);
	if (r < 0) {
		if (errno == EINTR)
			return SWELL_OK;
		f->last_errno = errno;
		return SWELL_ESTATE;
	}
	if (r == 0)
		return SWELL_OK;
	ssize_t n = read(f->ep0, &e, sizeof(e));
	if (n < 0) {
		f->last_errno = errno;
		return (errno == EAGAIN || errno == EINTR) ? SWELL_OK : SWELL_ESTATE;
	}
	if ((size_t)n < sizeof(e))
		return SWELL_ETRUNC;
	switch (e.type) {
	case FUNCTIONFS_BIND:
		*ev = SWELL_USB_FFS_BIND;
		break;
	case FUNCTIONFS_UNBIND:
		close_data(f);
		*ev = SWELL_USB_FFS_UNBIND;
		break;
	case FUNCTIONFS_ENABLE:
		*ev = SWELL_USB_FFS_ENABLE;
		return enable(f);
	case FUNCTIONFS_DISABLE:
		close_data(f);
		*ev = SWELL_USB_FFS_DISABLE;
		break;
	case FUNCTIONFS_SETUP:
		stall(f, &e.u.setup);
		*ev = SWELL_USB_FFS_SETUP;
		break;
	case FUNCTIONFS_SUSPEND:
		*ev = SWELL_USB_FFS_SUSPEND;
		break;
	case FUNCTIONFS_RESUME:
		*ev = SWELL_USB_FFS_RESUME;
		break;
	default:
		return SWELL_EUNKNOWN;
	}
	return SWELL_OK;
}

int swell_usb_ffs_enabled(const struct swell_usb_ffs *f)
{
	return f && f->ep_out >= 0 && f->ep_in >= 0 && f->ctx != 0;
}

int swell_usb_ffs_data_fd(const struct swell_usb_ffs *f)
{
	return f ? f->efd : -1;
}

enum swell_err swell_usb_ffs_read(struct swell_usb_ffs *f, uint8_t *buf, size_t cap, size_t *len)
{
	if (!f || !buf || !len || cap == 0)
		return SWELL_EINVAL;
	if (!swell_usb_ffs_enabled(f))
		return SWELL_ESTATE;
	reap(f);
	if (f->rx_state == 2 && f->rx_res >= 0) {
		size_t n = (size_t)f->rx_res < cap ? (size_t)f->rx_res : cap;
		memcpy(buf, f->rx_buf, n);
		*len = n;
		return queue_rx(f);
	}
	if (f->link_lost)
		return SWELL_ESTATE;
	*len = 0;
	return SWELL_OK;
}

enum swell_err swell_usb_ffs_write(struct swell_usb_ffs *f, const uint8_t *buf, size_t len)
{
	if (!f || (!buf && len))
		return SWELL_EINVAL;
	if (len > SWELL_USB_FFS_XFER_MAX)
		return SWELL_ESIZE;
	if (!swell_usb_ffs_enabled(f))
		return SWELL_ESTATE;
	reap(f);
	if (f->link_lost)
		return SWELL_ESTATE;
	for (int k = 0; k < SWELL_USB_FFS_TX_SLOTS; k++) {
		if (f->tx_queued[k])
			continue;
		if (len)
			memcpy(f->tx_buf[k], buf, len);
		prep(f, &f->tx_cb[k], TX_TAG(k), f->ep_in, IOCB_CMD_PWRITE, f->tx_buf[k], len);
		if (aio_submit(f->ctx, &f->tx_cb[k]) != 1) {
			f->last_errno = errno;
			return SWELL_ESTATE;
		}
		f->tx_queued[k] = 1;
		return SWELL_OK;
	}
	f->tx_busy_drops++;
	return SWELL_ESIZE;
}

void swell_usb_ffs_close(struct swell_usb_ffs *f)
{
	if (!f)
		return;
	close_data(f);
	close_fd(&f->efd);
	close_fd(&f->ep0);
}

/* ---- the link: packets through the two bulk endpoints ---- */

struct ffs_link {
	struct swell_link base;
	struct swell_usb_ffs usb;
	int up; /* endpoints enabled at the last look at ep0, and no read has failed since */
};

/* Never waits for the host: a packet goes into a free IN slot or is refused. -ENODEV while the host
 * has not enabled the interface (or a read found it gone), -EBUSY when every IN slot is in flight or
 * the host is going away (the DISABLE event follows). */
static int ffs_send(struct swell_link *l, const struct swell_frame *f)
{
	struct ffs_link *u = (struct ffs_link *)l;

	if (!u->up)
		return -ENODEV;
	return swell_usb_ffs_write(&u->usb, f->data, f->len) == SWELL_OK ? 0 : -EBUSY;
}

/* One packet: ep0's events first (ENABLE opens the data endpoints, DISABLE and UNBIND close them),
 * then a finished OUT transfer; until the deadline, sleep on both. */
static int ffs_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct ffs_link *u = (struct ffs_link *)l;
	const uint64_t deadline = swell_link_deadline(timeout_ms);

	for (;;) {
		enum swell_usb_ffs_event ev = SWELL_USB_FFS_NONE;
		size_t len = 0;
		int ms;

		swell_usb_ffs_poll(&u->usb, 0, &ev);
		u->up = swell_usb_ffs_enabled(&u->usb);
		if (u->up && swell_usb_ffs_read(&u->usb, f->data, SWELL_LINK_MTU, &len) == SWELL_ESTATE)
			u->up = 0;
		if (u->up && len > 0) {
			f->t_ns = swell_link_now_ns();
			f->id = 0;
			f->flags = 0;
			f->len = (uint16_t)len;
			return 0;
		}
		ms = swell_link_ms_left(deadline, timeout_ms);
		if (ms == 0)
			return u->up ? -ETIMEDOUT : -ENODEV;
		struct pollfd p[2] = { { .fd = u->usb.ep0, .events = POLLIN }, { .fd = u->usb.efd, .events = POLLIN } };
		if (poll(p, 2, ms) < 0 && errno != EINTR)
			return -errno;
	}
}

static int ffs_poll_fd(const struct swell_link *l)
{
	const struct ffs_link *u = (const struct ffs_link *)l;

	return u->up ? u->usb.efd : u->usb.ep0; /* the data endpoints cannot be polled: their AIO eventfd can */
}

static void ffs_close(struct swell_link *l)
{
	struct ffs_link *u = (struct ffs_link *)l;

	swell_usb_ffs_close(&u->usb);
	free(u);
}

static const struct swell_link_ops ffs_ops = { ffs_send, ffs_recv, ffs_close, ffs_poll_fd };

static int errno_of(enum swell_err e, int last_errno)
{
	if (last_errno)
		return -last_errno;
	return e == SWELL_ESIZE ? -ENAMETOOLONG : -EINVAL;
}

int swell_link_open_ffs(struct swell_link **out, const char *dir, const struct swell_usb_ffs_iface *iface)
{
	struct ffs_link *u;
	enum swell_err e;

	if (!out || !dir)
		return -EINVAL;
	u = calloc(1, sizeof(*u));
	if (!u)
		return -ENOMEM;
	e = swell_usb_ffs_open(&u->usb, dir, iface);
	if (e != SWELL_OK) {
		const int rc = errno_of(e, u->usb.last_errno);

		free(u);
		return rc;
	}
	u->base.ops = &ffs_ops;
	u->base.carrier = SWELL_CARRIER_PKT;
	snprintf(u->base.name, sizeof(u->base.name), "usb:%s", dir);
	*out = &u->base;
	return 0;
}

const struct swell_usb_ffs *swell_link_ffs(const struct swell_link *l)
{
	return (l && l->ops == &ffs_ops) ? &((const struct ffs_link *)l)->usb : NULL;
}
