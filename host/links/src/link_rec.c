/* Recording and replay links.
 * File format (little-endian): header "SWELLREC" (8 bytes), u32 format version (1), u8 carrier,
 * 3 bytes zero; then one record per received frame: u64 time in ns since the recording started,
 * u32 CAN id, u16 length, u8 flags, u8 zero, then length bytes of data. */
#define _GNU_SOURCE
#include "link_priv.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define REC_MAGIC "SWELLREC"
#define REC_VERSION 1u

struct rec_link {
	struct swell_link base;
	struct swell_link *inner;
	FILE *f;
	uint64_t t0;
};

struct replay_link {
	struct swell_link base;
	FILE *f;
	int realtime;
	uint64_t t0; /* wall-clock time of the replay start */
};

static void put_le(uint8_t *p, uint64_t v, int n)
{
	int i;

	for (i = 0; i < n; i++)
		p[i] = (uint8_t)(v >> (8 * i));
}

static uint64_t get_le(const uint8_t *p, int n)
{
	uint64_t v = 0;
	int i;

	for (i = 0; i < n; i++)
		v |= (uint64_t)p[i] << (8 * i);
	return v;
}

static int replay_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms);

static int rec_send(struct swell_link *l, const struct swell_frame *f)
{
	return swell_link_send(((struct rec_link *)l)->inner, f);
}

static int rec_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct rec_link *r = (struct rec_link *)l;
	uint8_t hdr[16];
	int rc = swell_link_recv(r->inner, f, timeout_ms);

	if (rc)
		return rc;
	/* a replay's frames carry their time since its start already (swell_frame.t_ns): a recording
	 * of a replay keeps them, as the original has them */
	put_le(hdr, r->inner->ops->recv == replay_recv ? f->t_ns : f->t_ns - r->t0, 8);
	put_le(hdr + 8, f->id, 4);
	put_le(hdr + 12, f->len, 2);
	hdr[14] = f->flags;
	hdr[15] = 0;
	if (fwrite(hdr, 1, sizeof(hdr), r->f) != sizeof(hdr) || fwrite(f->data, 1, f->len, r->f) != f->len ||
	    fflush(r->f))
		return -EIO;
	return 0;
}

static void rec_close(struct swell_link *l)
{
	struct rec_link *r = (struct rec_link *)l;

	swell_link_close(r->inner);
	fclose(r->f);
	free(r);
}

static const struct swell_link_ops rec_ops = { rec_send, rec_recv, rec_close, NULL };

int swell_link_open_record(struct swell_link **out, struct swell_link *inner, const char *path)
{
	struct rec_link *r;
	uint8_t hdr[16];

	if (!out || !inner || !path)
		return -EINVAL;
	r = calloc(1, sizeof(*r));
	if (!r)
		return -ENOMEM;
	r->f = fopen(path, "wb");
	if (!r->f) {
		int rc = -errno;

		free(r);
		return rc;
	}
	memcpy(hdr, REC_MAGIC, 8);
	put_le(hdr + 8, REC_VERSION, 4);
	hdr[12] = (uint8_t)inner->carrier;
	hdr[13] = hdr[14] = hdr[15] = 0;
	if (fwrite(hdr, 1, sizeof(hdr), r->f) != sizeof(hdr) || fflush(r->f)) {
		fclose(r->f);
		free(r);
		return -EIO;
	}
	r->base.ops = &rec_ops;
	r->base.carrier = inner->carrier;
	r->inner = inner;
	r->t0 = swell_link_now_ns();
	snprintf(r->base.name, sizeof(r->base.name), "record(%.60s)", inner->name);
	*out = &r->base;
	return 0;
}

static int replay_send(struct swell_link *l, const struct swell_frame *f)
{
	(void)l;
	(void)f;
	return -EROFS;
}

static int replay_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct replay_link *p = (struct replay_link *)l;
	uint8_t hdr[16];
	struct swell_frame tmp;
	size_t n = fread(hdr, 1, sizeof(hdr), p->f);

	if (n == 0 && feof(p->f))
		return -ENODATA;
	if (n != sizeof(hdr))
		return -EIO; /* truncated record */
	memset(&tmp, 0, sizeof(tmp));
	tmp.t_ns = get_le(hdr, 8);
	tmp.id = (uint32_t)get_le(hdr + 8, 4);
	tmp.len = (uint16_t)get_le(hdr + 12, 2);
	tmp.flags = hdr[14];
	if (tmp.len > SWELL_LINK_MTU || fread(tmp.data, 1, tmp.len, p->f) != tmp.len)
		return -EIO;
	if (p->realtime) {
		uint64_t due = p->t0 + tmp.t_ns, now = swell_link_now_ns();

		if (due > now) {
			uint64_t wait = due - now;

			if (timeout_ms >= 0 && wait > (uint64_t)timeout_ms * 1000000u) {
				/* not due within the timeout: keep it for the next call */
				fseek(p->f, -(long)(sizeof(hdr) + tmp.len), SEEK_CUR);
				struct timespec ts = { timeout_ms / 1000, (long)(timeout_ms % 1000) * 1000000 };
				nanosleep(&ts, NULL);
				return -ETIMEDOUT;
			}
			struct timespec ts = { (time_t)(wait / 1000000000u), (long)(wait % 1000000000u) };
			nanosleep(&ts, NULL);
		}
	}
	*f = tmp;
	return 0;
}

static void replay_close(struct swell_link *l)
{
	struct replay_link *p = (struct replay_link *)l;

	fclose(p->f);
	free(p);
}

static const struct swell_link_ops replay_ops = { replay_send, replay_recv, replay_close, NULL };

int swell_link_open_replay(struct swell_link **out, const char *path, int realtime)
{
	struct replay_link *p;
	uint8_t hdr[16];
	int rc;

	if (!out || !path)
		return -EINVAL;
	p = calloc(1, sizeof(*p));
	if (!p)
		return -ENOMEM;
	p->f = fopen(path, "rb");
	if (!p->f) {
		rc = -errno;
		free(p);
		return rc;
	}
	if (fread(hdr, 1, sizeof(hdr), p->f) != sizeof(hdr) || memcmp(hdr, REC_MAGIC, 8) ||
	    get_le(hdr + 8, 4) != REC_VERSION || hdr[12] > SWELL_CARRIER_PKT) {
		fclose(p->f);
		free(p);
		return -EPROTO; /* not a swell recording, or another format version */
	}
	p->base.ops = &replay_ops;
	p->base.carrier = (enum swell_carrier)hdr[12];
	p->realtime = realtime;
	p->t0 = swell_link_now_ns();
	snprintf(p->base.name, sizeof(p->base.name), "replay %s", realtime ? "(recorded speed)" : "(fast)");
	*out = &p->base;
	return 0;
}
