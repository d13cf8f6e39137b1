/* USB/IP server for the OTG FS model (usbip.h). */
#define _POSIX_C_SOURCE 200809L
#include "usbip.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#define BULK_MPS 64u
#define NORESP_MAX 1000u /* unanswered tries before a transfer fails with -EPROTO */
#define TRIES_PER_STEP 32u /* transactions one transfer may make in one step */

enum {
	PH_OP = 0,
	PH_ENUM,
	PH_URB
};

/* ---- codec ---- */

static void put32(uint8_t *p, uint32_t v)
{
	p[0] = (uint8_t)(v >> 24);
	p[1] = (uint8_t)(v >> 16);
	p[2] = (uint8_t)(v >> 8);
	p[3] = (uint8_t)v;
}

static void put16(uint8_t *p, uint16_t v)
{
	p[0] = (uint8_t)(v >> 8);
	p[1] = (uint8_t)v;
}

static uint32_t get32(const uint8_t *p)
{
	return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

static uint16_t get16(const uint8_t *p)
{
	return (uint16_t)(p[0] << 8 | p[1]);
}

void usbip_hdr_encode(const struct usbip_hdr *h, uint8_t out[USBIP_HDR_LEN])
{
	memset(out, 0, USBIP_HDR_LEN);
	put32(out, h->command);
	put32(out + 4, h->seqnum);
	put32(out + 8, h->devid);
	put32(out + 12, h->direction);
	put32(out + 16, h->ep);
	switch (h->command) {
	case USBIP_CMD_SUBMIT:
		put32(out + 20, h->u.submit.flags);
		put32(out + 24, h->u.submit.length);
		put32(out + 28, h->u.submit.start_frame);
		put32(out + 32, h->u.submit.number_of_packets);
		put32(out + 36, h->u.submit.interval);
		memcpy(out + 40, h->u.submit.setup, 8);
		break;
	case USBIP_RET_SUBMIT:
		put32(out + 20, (uint32_t)h->u.ret_submit.status);
		put32(out + 24, h->u.ret_submit.actual_length);
		put32(out + 28, h->u.ret_submit.start_frame);
		put32(out + 32, h->u.ret_submit.number_of_packets);
		put32(out + 36, h->u.ret_submit.error_count);
		break;
	case USBIP_CMD_UNLINK:
		put32(out + 20, h->u.unlink.seqnum);
		break;
	case USBIP_RET_UNLINK:
		put32(out + 20, (uint32_t)h->u.ret_unlink.status);
		break;
	default:
		break;
	}
}

int usbip_hdr_decode(const uint8_t in[USBIP_HDR_LEN], struct usbip_hdr *h)
{
	struct usbip_hdr d;

	memset(&d, 0, sizeof(d));
	d.command = get32(in);
	d.seqnum = get32(in + 4);
	d.devid = get32(in + 8);
	d.direction = get32(in + 12);
	d.ep = get32(in + 16);
	switch (d.command) {
	case USBIP_CMD_SUBMIT:
		d.u.submit.flags = get32(in + 20);
		d.u.submit.length = get32(in + 24);
		d.u.submit.start_frame = get32(in + 28);
		d.u.submit.number_of_packets = get32(in + 32);
		d.u.submit.interval = get32(in + 36);
		memcpy(d.u.submit.setup, in + 40, 8);
		break;
	case USBIP_RET_SUBMIT:
		d.u.ret_submit.status = (int32_t)get32(in + 20);
		d.u.ret_submit.actual_length = get32(in + 24);
		d.u.ret_submit.start_frame = get32(in + 28);
		d.u.ret_submit.number_of_packets = get32(in + 32);
		d.u.ret_submit.error_count = get32(in + 36);
		break;
	case USBIP_CMD_UNLINK:
		d.u.unlink.seqnum = get32(in + 20);
		break;
	case USBIP_RET_UNLINK:
		d.u.ret_unlink.status = (int32_t)get32(in + 20);
		break;
	default:
		return -1;
	}
	*h = d;
	return 0;
}

void usbip_dev_encode(const struct usbip_dev *d, uint8_t out[USBIP_DEV_LEN])
{
	memset(out, 0, USBIP_DEV_LEN);
	memcpy(out, d->path, strnlen(d->path, sizeof(d->path) - 1));
	memcpy(out + 0x100, d->busid, strnlen(d->busid, sizeof(d->busid) - 1));
	put32(out + 0x120, d->busnum);
	put32(out + 0x124, d->devnum);
	put32(out + 0x128, d->speed);
	put16(out + 0x12C, d->id_vendor);
	put16(out + 0x12E, d->id_product);
	put16(out + 0x130, d->bcd_device);
	out[0x132] = d->dev_class;
	out[0x133] = d->dev_subclass;
	out[0x134] = d->dev_protocol;
	out[0x135] = d->config_value;
	out[0x136] = d->num_configs;
	out[0x137] = d->num_interfaces;
}

int usbip_dev_decode(const uint8_t in[USBIP_DEV_LEN], struct usbip_dev *d)
{
	if (!memchr(in, 0, 256) || !memchr(in + 0x100, 0, USBIP_BUSID_LEN))
		return -1; /* strings must end inside their fields */
	memset(d, 0, sizeof(*d));
	memcpy(d->path, in, 256);
	memcpy(d->busid, in + 0x100, USBIP_BUSID_LEN);
	d->busnum = get32(in + 0x120);
	d->devnum = get32(in + 0x124);
	d->speed = get32(in + 0x128);
	d->id_vendor = get16(in + 0x12C);
	d->id_product = get16(in + 0x12E);
	d->bcd_device = get16(in + 0x130);
	d->dev_class = in[0x132];
	d->dev_subclass = in[0x133];
	d->dev_protocol = in[0x134];
	d->config_value = in[0x135];
	d->num_configs = in[0x136];
	d->num_interfaces = in[0x137];
	return 0;
}

void usbip_op_encode(uint16_t code, uint32_t status, uint8_t out[USBIP_OP_HDR_LEN])
{
	put16(out, USBIP_VERSION);
	put16(out + 2, code);
	put32(out + 4, status);
}

void usbip_op_decode(const uint8_t in[USBIP_OP_HDR_LEN], uint16_t *version, uint16_t *code, uint32_t *status)
{
	*version = get16(in);
	*code = get16(in + 2);
	*status = get32(in + 4);
}

/* ---- server ---- */

void usbip_server_init(struct usbip_server *s, int fd, struct otgfs *dev, uint8_t address)
{
	int fl;

	memset(s, 0, sizeof(*s));
	s->fd = fd;
	s->dev = dev;
	s->address = address >= 1 && address <= 127 ? address : 1;
	s->ep0_mps = 64;
	fl = fcntl(fd, F_GETFL);
	if (fl >= 0)
		(void)fcntl(fd, F_SETFL, fl | O_NONBLOCK);
}

int usbip_server_wants_write(const struct usbip_server *s)
{
	return s->tx_len > 0;
}

static enum usbip_step fail(struct usbip_server *s, const char *why)
{
	if (!s->error)
		s->error = why;
	return USBIP_CLOSED;
}

static int tx_room(const struct usbip_server *s, uint32_t n)
{
	return sizeof(s->tx) - s->tx_len >= n;
}

static void tx_put(struct usbip_server *s, const void *d, uint32_t n)
{
	memcpy(s->tx + s->tx_len, d, n);
	s->tx_len += n;
}

static void dev_record(const struct usbip_server *s, struct usbip_dev *d)
{
	memset(d, 0, sizeof(*d));
	memcpy(d->path, "/swell-mcu/otgfs", sizeof("/swell-mcu/otgfs"));
	memcpy(d->busid, USBIP_BUSID, sizeof(USBIP_BUSID));
	d->busnum = USBIP_BUSNUM;
	d->devnum = s->address;
	d->speed = 2; /* USB_SPEED_FULL */
	d->id_vendor = (uint16_t)(s->dev_desc[8] | s->dev_desc[9] << 8);
	d->id_product = (uint16_t)(s->dev_desc[10] | s->dev_desc[11] << 8);
	d->bcd_device = (uint16_t)(s->dev_desc[12] | s->dev_desc[13] << 8);
	d->dev_class = s->dev_desc[4];
	d->dev_subclass = s->dev_desc[5];
	d->dev_protocol = s->dev_desc[6];
	d->config_value = 0; /* not configured: the importing host chooses */
	d->num_configs = s->dev_desc[17];
	d->num_interfaces = s->cfg_head[4];
}

static void reply_op(struct usbip_server *s)
{
	uint8_t b[USBIP_OP_HDR_LEN + 4 + USBIP_DEV_LEN + 4];
	struct usbip_dev d;
	uint32_t n = USBIP_OP_HDR_LEN;

	dev_record(s, &d);
	if (s->op_pending == USBIP_OP_REQ_IMPORT) {
		usbip_op_encode(USBIP_OP_REP_IMPORT, 0, b);
		usbip_dev_encode(&d, b + n);
		n += USBIP_DEV_LEN;
		s->phase = PH_URB;
	} else {
		/* the device and its one interface (class, subclass, protocol, padding) */
		usbip_op_encode(USBIP_OP_REP_DEVLIST, 0, b);
		put32(b + n, 1);
		n += 4;
		usbip_dev_encode(&d, b + n);
		n += USBIP_DEV_LEN;
		memset(b + n, 0, 4);
		b[n] = 0xFF;
		n += 4;
		s->phase = PH_OP;
	}
	tx_put(s, b, n);
	s->op_pending = 0;
}

static struct usbip_urb *urb_new(struct usbip_server *s)
{
	for (unsigned i = 0; i < USBIP_URBS_MAX; i++)
		if (!s->urbs[i].in_use) {
			struct usbip_urb *u = &s->urbs[i];

			memset(&u->h, 0, sizeof(u->h));
			u->in_use = 1;
			u->internal = 0;
			u->stage = 0;
			u->actual = 0;
			u->zlp_sent = 0;
			u->noresp = 0;
			u->order = s->next_order++;
			return u;
		}
	return NULL;
}

static void internal_control(struct usbip_server *s, const uint8_t setup[8])
{
	struct usbip_urb *u = urb_new(s);

	if (!u)
		return; /* cannot happen: the enumeration runs before any URB */
	u->internal = 1;
	u->h.command = USBIP_CMD_SUBMIT;
	u->h.direction = (setup[0] & 0x80u) ? USBIP_DIR_IN : USBIP_DIR_OUT;
	u->h.u.submit.length = (uint32_t)(setup[6] | setup[7] << 8);
	memcpy(u->h.u.submit.setup, setup, 8);
}

/* The enumeration before OP_REP_IMPORT: each step waits for the previous one. */
static void enum_next(struct usbip_server *s, uint64_t now)
{
	static const uint8_t get_dev[8] = { 0x80, 6, 0, 1, 0, 0, 18, 0 };

	if (s->enum_step == 0 && otgfs_host_attached(s->dev)) {
		s->bus_addr = 0;
		if (otgfs_host_reset(s->dev, now) == 0)
			s->enum_step = 1;
	} else if (s->enum_step == 1 && otgfs_host_running(s->dev)) {
		internal_control(s, get_dev);
		s->enum_step = 2;
	}
}

static void enum_done(struct usbip_server *s, const struct usbip_urb *u, int32_t status)
{
	static const uint8_t get_cfg[8] = { 0x80, 6, 0, 2, 0, 0, 9, 0 };
	uint8_t set_addr[8] = { 0x00, 5, 0, 0, 0, 0, 0, 0 };

	if (status) {
		s->enum_step = 0; /* start again with a bus reset */
		return;
	}
	if (s->enum_step == 2 && u->actual >= 18) {
		memcpy(s->dev_desc, u->buf, 18);
		s->ep0_mps = s->dev_desc[7] ? s->dev_desc[7] : 8;
		set_addr[2] = s->address;
		internal_control(s, set_addr);
		s->enum_step = 3;
	} else if (s->enum_step == 3) {
		s->bus_addr = s->address;
		internal_control(s, get_cfg);
		s->enum_step = 4;
	} else if (s->enum_step == 4 && u->actual >= 9) {
		memcpy(s->cfg_head, u->buf, 9);
		s->enum_step = 5;
		s->enumerated = 1;
		reply_op(s);
	} else {
		s->enum_step = 0;
	}
}

static void complete(struct usbip_server *s, struct usbip_urb *u, int32_t status)
{
	uint8_t b[USBIP_HDR_LEN];
	struct usbip_hdr r;

	u->in_use = 0;
	if (u->internal) {
		enum_done(s, u, status);
		return;
	}
	memset(&r, 0, sizeof(r));
	r.command = USBIP_RET_SUBMIT;
	r.seqnum = u->h.seqnum;
	r.u.ret_submit.status = status;
	r.u.ret_submit.actual_length = u->actual;
	/* As Linux's usbip-host: the URB's own count (0 for a non-isochronous URB from Linux). */
	r.u.ret_submit.number_of_packets = u->h.u.submit.number_of_packets;
	usbip_hdr_encode(&r, b);
	tx_put(s, b, USBIP_HDR_LEN);
	if (u->h.direction == USBIP_DIR_IN && u->actual) {
		tx_put(s, u->buf, u->actual);
		s->stats.bytes_in += u->actual;
	} else if (u->h.direction == USBIP_DIR_OUT) {
		s->stats.bytes_out += u->actual;
	}
	s->stats.ret_submits++;
	if (status)
		s->stats.errors++;
	s->stats.stalls += status == USBIP_EPIPE;
	s->stats.no_answers += status == USBIP_EPROTO;
	s->stats.babbles += status == USBIP_EOVERFLOW;
}

/* One transaction's outcome: 1 the transfer is done (status in *st), 0 go on, -1 NAK (wait). */
static int outcome(struct usbip_urb *u, enum otgfs_resp r, int32_t *st)
{
	switch (r) {
	case OTGFS_ACK:
		u->noresp = 0;
		return 0;
	case OTGFS_NAK:
		return -1;
	case OTGFS_STALL:
		*st = USBIP_EPIPE;
		return 1;
	default:
		if (++u->noresp >= NORESP_MAX) {
			*st = USBIP_EPROTO;
			return 1;
		}
		return -1;
	}
}

/* One IN transaction of endpoint ep (max packet size mps) into the URB's buffer: outcome()'s value,
 * 1 with USBIP_EOVERFLOW for more data than the URB has room for; 0 when the data was taken, *end then
 * says whether the transfer is complete (a short packet, or the URB full). */
static int in_packet(struct usbip_server *s, struct usbip_urb *u, uint64_t now, uint8_t ep, uint32_t mps, int32_t *st,
		     int *end)
{
	const uint32_t len = u->h.u.submit.length;
	uint32_t n = 0;
	uint8_t pkt[64];
	const int o = outcome(u, otgfs_host_in(s->dev, now, s->bus_addr, ep, pkt, sizeof(pkt), &n), st);

	if (o)
		return o;
	if (n > len - u->actual) {
		*st = USBIP_EOVERFLOW;
		return 1;
	}
	memcpy(u->buf + u->actual, pkt, n);
	u->actual += n;
	*end = n < mps || u->actual >= len;
	return 0;
}

static int control_step(struct usbip_server *s, struct usbip_urb *u, uint64_t now, int32_t *st)
{
	uint32_t len = u->h.u.submit.length, n = 0;
	int in = (u->h.u.submit.setup[0] & 0x80u) != 0, o;
	uint8_t pkt[64];
	enum otgfs_resp r;

	if (u->stage == 0) {
		r = otgfs_host_setup(s->dev, now, s->bus_addr, u->h.u.submit.setup);
		o = outcome(u, r, st);
		if (o == 0)
			u->stage = len ? 1 : 2;
		return o;
	}
	if (u->stage == 1) {
		uint32_t left = len - u->actual, chunk = left < s->ep0_mps ? left : s->ep0_mps;

		if (in) {
			int end = 0;

			o = in_packet(s, u, now, 0, s->ep0_mps, st, &end);
			if (o == 0 && end)
				u->stage = 2;
			return o;
		}
		r = otgfs_host_out(s->dev, now, s->bus_addr, 0, u->buf + u->actual, chunk);
		o = outcome(u, r, st);
		if (o)
			return o;
		u->actual += chunk;
		if (u->actual >= len)
			u->stage = 2;
		return 0;
	}
	/* status stage: the other direction, zero length */
	if (in)
		r = otgfs_host_out(s->dev, now, s->bus_addr, 0, NULL, 0);
	else
		r = otgfs_host_in(s->dev, now, s->bus_addr, 0, pkt, sizeof(pkt), &n);
	o = outcome(u, r, st);
	if (o)
		return o;
	*st = 0;
	return 1;
}

static int bulk_step(struct usbip_server *s, struct usbip_urb *u, uint64_t now, int32_t *st)
{
	uint32_t len = u->h.u.submit.length, n = 0, left = len - u->actual;
	const uint8_t ep = (uint8_t)u->h.ep;
	enum otgfs_resp r;
	int o;

	if (u->h.direction == USBIP_DIR_IN) {
		int end = 0;

		o = in_packet(s, u, now, ep, BULK_MPS, st, &end);
		if (o == 0 && end) {
			*st = 0;
			return 1;
		}
		return o;
	}
	if (!left) {
		int zlp = !u->zlp_sent &&
			(len == 0 || ((u->h.u.submit.flags & USBIP_URB_ZERO_PACKET) && len % BULK_MPS == 0));

		if (!zlp) {
			*st = 0;
			return 1;
		}
		r = otgfs_host_out(s->dev, now, s->bus_addr, ep, NULL, 0);
		o = outcome(u, r, st);
		if (o == 0)
			u->zlp_sent = 1;
		return o;
	}
	n = left < BULK_MPS ? left : BULK_MPS;
	r = otgfs_host_out(s->dev, now, s->bus_addr, ep, u->buf + u->actual, n);
	o = outcome(u, r, st);
	if (o == 0)
		u->actual += n;
	return o;
}

static uint32_t pipe_of(const struct usbip_urb *u)
{
	return u->h.ep == 0 ? 0 : (u->h.ep & 0xFu) | (u->h.direction ? 0x10u : 0);
}

/* Is u the oldest pending URB of its pipe? */
static int head_of_pipe(const struct usbip_server *s, const struct usbip_urb *u)
{
	for (unsigned i = 0; i < USBIP_URBS_MAX; i++) {
		const struct usbip_urb *v = &s->urbs[i];

		if (v != u && v->in_use && pipe_of(v) == pipe_of(u) && v->order < u->order)
			return 0;
	}
	return 1;
}

/* Move the transfers on; 1 when some are still pending. */
static int run_transfers(struct usbip_server *s, uint64_t now)
{
	int pending = 0;

	for (unsigned i = 0; i < USBIP_URBS_MAX; i++) {
		struct usbip_urb *u = &s->urbs[i];

		if (!u->in_use || !head_of_pipe(s, u))
			continue;
		if (!tx_room(s, USBIP_HDR_LEN + USBIP_XFER_MAX)) {
			pending = 1;
			continue;
		}
		for (unsigned k = 0; k < TRIES_PER_STEP && u->in_use; k++) {
			int32_t st = 0;
			int o = u->h.ep == 0 ? control_step(s, u, now, &st) : bulk_step(s, u, now, &st);

			if (o == 1)
				complete(s, u, st);
			else if (o < 0)
				break;
		}
	}
	for (unsigned i = 0; i < USBIP_URBS_MAX; i++)
		pending |= s->urbs[i].in_use;
	return pending;
}

static void unlink_urb(struct usbip_server *s, const struct usbip_hdr *h)
{
	uint8_t b[USBIP_HDR_LEN];
	struct usbip_hdr r;

	memset(&r, 0, sizeof(r));
	r.command = USBIP_RET_UNLINK;
	r.seqnum = h->seqnum;
	for (unsigned i = 0; i < USBIP_URBS_MAX; i++) {
		struct usbip_urb *u = &s->urbs[i];

		if (u->in_use && !u->internal && u->h.seqnum == h->u.unlink.seqnum) {
			u->in_use = 0;
			r.u.ret_unlink.status = USBIP_ECONNRESET;
		}
	}
	usbip_hdr_encode(&r, b);
	tx_put(s, b, USBIP_HDR_LEN);
	s->stats.unlinks++;
}

/* Parse what rx holds; returns 0, or fail()'s USBIP_CLOSED. */
static enum usbip_step parse(struct usbip_server *s)
{
	for (;;) {
		uint32_t used = 0;

		if (s->phase == PH_ENUM)
			return USBIP_IDLE;
		if (!tx_room(s, 2 * (USBIP_HDR_LEN + USBIP_DEV_LEN)))
			return USBIP_IDLE; /* replies first */
		if (s->phase == PH_OP) {
			uint16_t version, code;
			uint32_t status;

			if (s->rx_len < USBIP_OP_HDR_LEN)
				return USBIP_IDLE;
			usbip_op_decode(s->rx, &version, &code, &status);
			if (version != USBIP_VERSION)
				return fail(s, "USB/IP: an operation of another protocol version");
			if (code == USBIP_OP_REQ_IMPORT) {
				if (s->rx_len < USBIP_OP_HDR_LEN + USBIP_BUSID_LEN)
					return USBIP_IDLE;
				used = USBIP_OP_HDR_LEN + USBIP_BUSID_LEN;
				if (strncmp((const char *)s->rx + USBIP_OP_HDR_LEN, USBIP_BUSID, USBIP_BUSID_LEN) !=
				    0) {
					uint8_t b[USBIP_OP_HDR_LEN];

					usbip_op_encode(USBIP_OP_REP_IMPORT, 1, b);
					tx_put(s, b, sizeof(b));
				} else {
					s->op_pending = USBIP_OP_REQ_IMPORT;
				}
			} else if (code == USBIP_OP_REQ_DEVLIST) {
				used = USBIP_OP_HDR_LEN;
				s->op_pending = USBIP_OP_REQ_DEVLIST;
			} else {
				return fail(s, "USB/IP: an unknown operation");
			}
			if (s->op_pending) {
				if (s->enumerated)
					reply_op(s);
				else
					s->phase = PH_ENUM;
			}
		} else {
			struct usbip_hdr h;

			if (s->rx_len < USBIP_HDR_LEN)
				return USBIP_IDLE;
			if (usbip_hdr_decode(s->rx, &h) != 0)
				return fail(s, "USB/IP: an unknown command");
			used = USBIP_HDR_LEN;
			if (h.command == USBIP_CMD_SUBMIT) {
				struct usbip_urb *u;
				uint32_t len = h.u.submit.length, np = h.u.submit.number_of_packets;

				if (len > USBIP_XFER_MAX)
					return fail(s, "USB/IP: a transfer over 4096 bytes");
				if (np != 0 && np != 0xFFFFFFFFu)
					return fail(s, "USB/IP: an isochronous transfer");
				if (h.ep >= OTGFS_EPS)
					return fail(s, "USB/IP: an endpoint the device does not have");
				if (h.direction == USBIP_DIR_OUT) {
					if (s->rx_len < USBIP_HDR_LEN + len)
						return USBIP_IDLE;
					used += len;
				}
				u = urb_new(s);
				if (!u)
					return fail(s, "USB/IP: more URBs pending than the server holds");
				u->h = h;
				if (h.direction == USBIP_DIR_OUT)
					memcpy(u->buf, s->rx + USBIP_HDR_LEN, len);
				s->stats.submits++;
			} else if (h.command == USBIP_CMD_UNLINK) {
				unlink_urb(s, &h);
			} else {
				return fail(s, "USB/IP: a reply where a command belongs");
			}
		}
		memmove(s->rx, s->rx + used, s->rx_len - used);
		s->rx_len -= used;
	}
}

static int flush_tx(struct usbip_server *s)
{
	while (s->tx_len) {
		/* send: a peer that closed is an error here, not a SIGPIPE; write for a non-socket */
		ssize_t n = send(s->fd, s->tx, s->tx_len, MSG_NOSIGNAL);

		if (n < 0 && errno == ENOTSOCK)
			n = write(s->fd, s->tx, s->tx_len);

		if (n < 0) {
			if (errno == EINTR)
				continue;
			if (errno == EAGAIN || errno == EWOULDBLOCK)
				return 0;
			return -1;
		}
		memmove(s->tx, s->tx + n, s->tx_len - (uint32_t)n);
		s->tx_len -= (uint32_t)n;
	}
	return 0;
}

static enum usbip_step step(struct usbip_server *s, uint64_t now)
{
	enum usbip_step st;
	int pending;

	if (s->error)
		return USBIP_CLOSED;
	while (s->rx_len < sizeof(s->rx)) {
		ssize_t n = read(s->fd, s->rx + s->rx_len, sizeof(s->rx) - s->rx_len);

		if (n > 0) {
			s->rx_len += (uint32_t)n;
			continue;
		}
		if (n == 0)
			return fail(s, "USB/IP: the peer closed the connection");
		if (errno == EINTR)
			continue;
		if (errno == EAGAIN || errno == EWOULDBLOCK)
			break;
		return fail(s, "USB/IP: read error");
	}
	st = parse(s);
	if (st == USBIP_CLOSED)
		return st;
	if (s->phase == PH_URB && !otgfs_host_attached(s->dev)) {
		/* USB/IP has no message for an unplug: the importer sees it as the connection's end */
		(void)flush_tx(s);
		return fail(s, "USB/IP: the device left the bus");
	}
	if (s->phase == PH_ENUM)
		enum_next(s, now);
	pending = run_transfers(s, now);
	st = parse(s); /* an enumeration that ended lets queued requests through */
	if (st == USBIP_CLOSED)
		return st;
	if (flush_tx(s) != 0)
		return fail(s, "USB/IP: write error");
	return pending || s->phase == PH_ENUM || s->tx_len ? USBIP_BUSY : USBIP_IDLE;
}

/* The session's end is the cable's: the device sees the bus go idle (its suspend). */
enum usbip_step usbip_server_step(struct usbip_server *s, uint64_t now)
{
	const enum usbip_step st = step(s, now);

	if (st == USBIP_CLOSED)
		otgfs_host_unplug(s->dev, now);
	return st;
}

int usbip_server_waiting(const struct usbip_server *s)
{
	if (s->phase == PH_ENUM)
		return 1;
	for (unsigned i = 0; i < USBIP_URBS_MAX; i++)
		if (s->urbs[i].in_use)
			return 1;
	return 0;
}
