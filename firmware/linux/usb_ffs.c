/* FunctionFS device side of the controller's vendor USB interface. See usb_ffs.h. */
#define _POSIX_C_SOURCE 200809L

#include "usb_ffs.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/usb/ch9.h>
#include <linux/usb/functionfs.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#define HS_BULK_PACKET 512u /* the only bulk wMaxPacketSize USB 2.0 allows at high speed */
#define LANG_EN_US 0x0409u
#define EP_DESC_LEN 7u      /* USB_DT_ENDPOINT_SIZE: no audio extension */
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
	*p++ = 0;               /* bInterfaceNumber: FunctionFS renumbers */
	*p++ = 0;               /* bAlternateSetting */
	*p++ = 2;               /* bNumEndpoints */
	*p++ = it->class_code;
	*p++ = it->subclass;
	*p++ = it->protocol;
	*p++ = 1;               /* iInterface: our first string */
	const uint8_t addr[2] = { it->ep_out, it->ep_in };
	for (int i = 0; i < 2; i++) {
		*p++ = EP_DESC_LEN;
		*p++ = USB_DT_ENDPOINT;
		*p++ = addr[i];
		*p++ = USB_ENDPOINT_XFER_BULK;
		p = put_le16(p, packet);
		*p++ = 0;       /* bInterval: unused for bulk */
	}
	return p;
}

enum swell_err swell_usb_ffs_descriptors(const struct swell_usb_ffs_iface *iface, uint8_t *buf,
					 size_t cap, size_t *len)
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

enum swell_err swell_usb_ffs_strings(const struct swell_usb_ffs_iface *iface, uint8_t *buf,
				     size_t cap, size_t *len)
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

static void close_fd(int *fd)
{
	if (*fd >= 0)
		close(*fd);
	*fd = -1;
}

static void close_data(struct swell_usb_ffs *f)
{
	close_fd(&f->ep_out);
	close_fd(&f->ep_in);
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

enum swell_err swell_usb_ffs_open(struct swell_usb_ffs *f, const char *dir,
				  const struct swell_usb_ffs_iface *iface)
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
	f->ep0 = f->ep_out = f->ep_in = -1;
	f->last_errno = 0;
	f->setup_stalled = 0;
	memcpy(f->dir, dir, strlen(dir) + 1);

	char path[SWELL_USB_FFS_PATH_MAX + 8];
	snprintf(path, sizeof(path), "%s/ep0", f->dir);
	f->ep0 = open(path, O_RDWR | O_CLOEXEC);
	if (f->ep0 < 0) {
		f->last_errno = errno;
		return SWELL_ESTATE;
	}
	err = write_all(f, f->ep0, desc, desc_len);
	if (err == SWELL_OK)
		err = write_all(f, f->ep0, str, str_len);
	if (err != SWELL_OK)
		close_fd(&f->ep0);
	return err;
}

static enum swell_err enable(struct swell_usb_ffs *f)
{
	close_data(f);
	f->ep_out = open_ep(f, 1, O_RDONLY);
	if (f->ep_out >= 0)
		f->ep_in = open_ep(f, 2, O_WRONLY);
	if (f->ep_out < 0 || f->ep_in < 0) {
		f->last_errno = errno;
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

enum swell_err swell_usb_ffs_poll(struct swell_usb_ffs *f, int timeout_ms,
				  enum swell_usb_ffs_event *ev)
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
	return f && f->ep_out >= 0 && f->ep_in >= 0;
}

enum swell_err swell_usb_ffs_read(struct swell_usb_ffs *f, uint8_t *buf, size_t cap, size_t *len)
{
	if (!f || !buf || !len || cap == 0)
		return SWELL_EINVAL;
	if (!swell_usb_ffs_enabled(f))
		return SWELL_ESTATE;
	ssize_t n = read(f->ep_out, buf, cap);
	if (n < 0) {
		f->last_errno = errno;
		return SWELL_ESTATE;
	}
	*len = (size_t)n;
	return SWELL_OK;
}

enum swell_err swell_usb_ffs_write(struct swell_usb_ffs *f, const uint8_t *buf, size_t len)
{
	if (!f || (!buf && len))
		return SWELL_EINVAL;
	if (!swell_usb_ffs_enabled(f))
		return SWELL_ESTATE;
	return write_all(f, f->ep_in, buf, len);
}

void swell_usb_ffs_close(struct swell_usb_ffs *f)
{
	if (!f)
		return;
	close_data(f);
	close_fd(&f->ep0);
}
