/* Recording and replay links; the file format is in docs/links.md. */
#define _GNU_SOURCE
#include "link_priv.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define REC_MAGIC "SWELLREC"
#define REC_VERSION 1u

struct file_link { /* a recording of inner, or a replay (inner NULL) */
	struct swell_link base;
	struct swell_link *inner;
	FILE *f;
	int realtime;
	uint64_t t0; /* when the recording or the replay started */
};

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
	return swell_link_send(((struct file_link *)l)->inner, f);
}

static int rec_recv(struct swell_link *l, struct swell_frame *f, int timeout_ms)
{
	struct file_link *r = (struct file_link *)l;
	uint8_t hdr[16];
	int rc = swell_link_recv(r->inner, f, timeout_ms);

	if (rc)
		return rc;
	/* a replay's frames carry their time since its start already (swell_frame.t_ns): a recording
	 * of a replay keeps them, as the original has them */
	swell_put_le(hdr, r->inner->ops->recv == replay_recv ? f->t_ns : f->t_ns - r->t0, 8);
	swell_put_le(hdr + 8, f->id, 4);
	swell_put_le(hdr + 12, f->len, 2);
	hdr[14] = f->flags;
	hdr[15] = 0;
	if (fwrite(hdr, 1, sizeof(hdr), r->f) != sizeof(hdr) || fwrite(f->data, 1, f->len, r->f) != f->len ||
	    fflush(r->f))
		return -EIO;
	return 0;
}

static void file_close(struct swell_link *l)
{
	struct file_link *r = (struct file_link *)l;

	swell_link_close(r->inner);
	fclose(r->f);
	free(r);
}

static const struct swell_link_ops rec_ops = { rec_send, rec_recv, file_close, NULL };

int swell_link_open_record(struct swell_link **out, struct swell_link *inner, const char *path)
{
	struct file_link *r;
	uint8_t hdr[16] = { 0 };
	FILE *fp;
	int rc;

	if (!out || !inner || !path)
		return -EINVAL;
	fp = fopen(path, "wb");
	if (!fp)
		return -errno;
	memcpy(hdr, REC_MAGIC, 8);
	swell_put_le(hdr + 8, REC_VERSION, 4);
	hdr[12] = (uint8_t)inner->carrier;
	r = calloc(1, sizeof(*r));
	rc = !r ? -ENOMEM : fwrite(hdr, 1, sizeof(hdr), fp) != sizeof(hdr) || fflush(fp) ? -EIO : 0;
	if (rc) {
		fclose(fp);
		free(r);
		return rc;
	}
	r->base.ops = &rec_ops;
	r->base.carrier = inner->carrier;
	r->f = fp;
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
	struct file_link *p = (struct file_link *)l;
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
		const uint64_t now = swell_link_now_ns(), wait = p->t0 + tmp.t_ns > now ? p->t0 + tmp.t_ns - now : 0;
		const uint64_t limit = timeout_ms >= 0 ? (uint64_t)timeout_ms * 1000000u : UINT64_MAX;
		const uint64_t ns = wait < limit ? wait : limit; /* until it is due, or the timeout */
		const struct timespec ts = { (time_t)(ns / 1000000000u), (long)(ns % 1000000000u) };

		if (wait > limit) /* not due within the timeout: keep it for the next call */
			fseek(p->f, -(long)(sizeof(hdr) + tmp.len), SEEK_CUR);
		if (ns)
			nanosleep(&ts, NULL);
		if (wait > limit)
			return -ETIMEDOUT;
	}
	*f = tmp;
	return 0;
}

static const struct swell_link_ops replay_ops = { replay_send, replay_recv, file_close, NULL };

int swell_link_open_replay(struct swell_link **out, const char *path, int realtime)
{
	struct file_link *p;
	uint8_t hdr[16];
	FILE *fp;
	int bad;

	if (!out || !path)
		return -EINVAL;
	fp = fopen(path, "rb");
	if (!fp)
		return -errno;
	bad = fread(hdr, 1, sizeof(hdr), fp) != sizeof(hdr) || memcmp(hdr, REC_MAGIC, 8) ||
		get_le(hdr + 8, 4) != REC_VERSION || hdr[12] > SWELL_CARRIER_PKT;
	p = bad ? NULL : calloc(1, sizeof(*p));
	if (!p) {
		fclose(fp);
		return bad ? -EPROTO : -ENOMEM; /* -EPROTO: not a swell recording, or another format version */
	}
	p->base.ops = &replay_ops;
	p->base.carrier = (enum swell_carrier)hdr[12];
	p->f = fp;
	p->realtime = realtime;
	p->t0 = swell_link_now_ns();
	snprintf(p->base.name, sizeof(p->base.name), "replay %s", realtime ? "(recorded speed)" : "(fast)");
	*out = &p->base;
	return 0;
}
