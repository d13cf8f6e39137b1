/* Wire protocol codecs, expanded from the one table in swell/proto_table.h. */
#include "swell/proto.h"

#include <string.h>

#include "swell/crc.h"

/* ---- the table as data ---- */
/* A controller build may define SWELL_PROTO_NO_TEXT to keep factors, units and descriptions (about
 * 3 KB) out of flash; names stay. */
#ifdef SWELL_PROTO_NO_TEXT
#define TXT(s) ""
#else
#define TXT(s) s
#endif
#define FIELD_DESC(m, member, ctype, start, bits, min, max, kind, factor, unit, desc) \
	{ #member,                                                                    \
	  TXT(factor),                                                                \
	  TXT(unit),                                                                  \
	  TXT(desc),                                                                  \
	  (int64_t)(min),                                                             \
	  (int64_t)(max),                                                             \
	  (uint16_t)offsetof(struct swell_msg, u.m.member),                           \
	  (uint8_t)sizeof(ctype),                                                     \
	  start,                                                                      \
	  bits,                                                                       \
	  SWELL_FK_##kind },
#define FIELD_COUNT(m, ...) +1
#define FIELD_CHECK(m, member, ctype, start, bits, min, max, kind, factor, unit, desc)         \
	_Static_assert((start) + (bits) <= 64 && (bits) >= 1 && (bits) <= 32, #m "." #member); \
	_Static_assert(sizeof(ctype) * 8 >= (bits), #m "." #member " ctype too narrow");

#define MSG_FIELDS(NAME, name, type, len, from, to, desc)                                                     \
	_Static_assert((len) >= SWELL_MSG_LEN_MIN && (len) <= SWELL_CAN_LEN, #NAME " length");                \
	_Static_assert((type) > 0 && (type) < 0x80, #NAME " type must be 7 bits and not 0");                  \
	SWELL_PROTO_FIELDS_##name(FIELD_CHECK, name) static const struct swell_field_desc fields_##name[] = { \
		SWELL_PROTO_FIELDS_##name(FIELD_DESC, name)                                                   \
	};
SWELL_PROTO_MESSAGES(MSG_FIELDS)

#define MSG_DESC(NAME, name, type, len, from, to, desc) \
	{ #NAME,         #from, #to, TXT(desc),         \
	  fields_##name, type,  len, (uint8_t)(0 SWELL_PROTO_FIELDS_##name(FIELD_COUNT, name)) },
const struct swell_msg_desc swell_msg_descs[] = { SWELL_PROTO_MESSAGES(MSG_DESC) };
const unsigned swell_msg_desc_count = sizeof(swell_msg_descs) / sizeof(swell_msg_descs[0]);

const struct swell_msg_desc *swell_msg_desc_find(unsigned type)
{
	for (unsigned i = 0; i < swell_msg_desc_count; i++)
		if (swell_msg_descs[i].type == type)
			return &swell_msg_descs[i];
	return NULL;
}

/* ---- generic field access ---- */
/* A member of 1, 2 or 4 bytes, read or written through the union member of its size (any byte order). */
union raw {
	uint8_t b;
	uint16_t h;
	uint32_t w;
};

int64_t swell_msg_field_get(const struct swell_msg *m, const struct swell_field_desc *f)
{
	union raw r;
	uint32_t v;

	memcpy(&r, (const uint8_t *)m + f->offset, f->size);
	v = f->size == 1 ? r.b : f->size == 2 ? r.h : r.w;
	if (f->min < 0 && (v >> (8u * f->size - 1u)) & 1u)
		return (int64_t)v - ((int64_t)1 << (8u * f->size)); /* sign-extend */
	return (int64_t)v;
}

enum swell_err swell_msg_field_set(struct swell_msg *m, const struct swell_field_desc *f, int64_t v)
{
	union raw r;

	if (v < f->min || v > f->max)
		return SWELL_ERANGE;
	if (f->size == 1)
		r.b = (uint8_t)v;
	else if (f->size == 2)
		r.h = (uint16_t)v;
	else
		r.w = (uint32_t)v;
	memcpy((uint8_t *)m + f->offset, &r, f->size);
	return SWELL_OK;
}

int swell_msg_equal(const struct swell_msg *a, const struct swell_msg *b)
{
	const struct swell_msg_desc *d = swell_msg_desc_find(a->type);

	if (a->type != b->type || a->node != b->node || !d)
		return 0;
	for (unsigned i = 0; i < d->nfields; i++)
		if (swell_msg_field_get(a, &d->fields[i]) != swell_msg_field_get(b, &d->fields[i]))
			return 0;
	return 1;
}

/* ---- counting ---- */
static enum swell_err count(struct swell_proto_stats *st, enum swell_err err, uint32_t ok)
{
	if (!st)
		return err;
	if (err == SWELL_OK)
		st->ok = (st->ok > UINT32_MAX - ok) ? UINT32_MAX : st->ok + ok;
	else if ((unsigned)err < SWELL_ERR_COUNT && st->rejected[err] != UINT32_MAX)
		st->rejected[err]++;
	return err;
}

uint32_t swell_proto_rejected_total(const struct swell_proto_stats *st)
{
	uint64_t sum = 0;

	for (unsigned i = 0; i < SWELL_ERR_COUNT; i++)
		sum += st->rejected[i];
	return sum > UINT32_MAX ? UINT32_MAX : (uint32_t)sum;
}

/* ---- payload ---- */
static uint64_t field_mask(const struct swell_field_desc *f)
{
	return (f->bits >= 64 ? ~(uint64_t)0 : (((uint64_t)1 << f->bits) - 1)) << f->start;
}

enum swell_err swell_payload_encode(const struct swell_msg *m, uint8_t *payload, size_t cap)
{
	const struct swell_msg_desc *d = swell_msg_desc_find(m->type);
	uint64_t word = 0;
	unsigned i;

	if (!d)
		return SWELL_EUNKNOWN;
	if (cap < d->len)
		return SWELL_ESIZE;
	for (i = 0; i < d->nfields; i++) {
		const struct swell_field_desc *f = &d->fields[i];
		int64_t v = swell_msg_field_get(m, f);

		if (v < f->min || v > f->max)
			return SWELL_ERANGE;
		word |= ((uint64_t)v << f->start) & field_mask(f);
	}
	for (i = 0; i < d->len; i++)
		payload[i] = (uint8_t)(word >> (8 * i));
	return SWELL_OK;
}

/* Decodes one payload of the given type; len must be exactly the message length. */
static enum swell_err payload_decode(unsigned type, const uint8_t *payload, size_t len, struct swell_msg *out)
{
	const struct swell_msg_desc *d = swell_msg_desc_find(type);
	struct swell_msg tmp;
	uint64_t word = 0, covered = 0;
	unsigned i;

	if (!d)
		return SWELL_EUNKNOWN;
	if (len < d->len)
		return SWELL_ETRUNC;
	if (len > d->len)
		return SWELL_ESIZE;
	for (i = 0; i < d->len; i++)
		word |= (uint64_t)payload[i] << (8 * i);
	memset(&tmp, 0, sizeof(tmp));
	tmp.type = (uint8_t)type;
	for (i = 0; i < d->nfields; i++) {
		const struct swell_field_desc *f = &d->fields[i];
		uint64_t raw = (word & field_mask(f)) >> f->start;
		int64_t v = (int64_t)raw;

		covered |= field_mask(f);
		if (f->min < 0 && (raw >> (f->bits - 1)) & 1u)
			v = (int64_t)(raw | ~(((uint64_t)1 << f->bits) - 1)); /* sign-extend */
		if (f->kind == SWELL_FK_VERSION && v != f->min)
			return SWELL_EVERSION;
		if (swell_msg_field_set(&tmp, f, v) != SWELL_OK)
			return SWELL_ERANGE;
	}
	if (word & ~covered)
		return SWELL_ERANGE; /* reserved bits set */
	out->type = tmp.type; /* out->node is the carrier's business */
	out->u = tmp.u;
	return SWELL_OK;
}

/* ---- classic CAN ---- */
enum swell_err swell_can_encode(const struct swell_msg *m, uint32_t *id, uint8_t data[8], uint8_t *len)
{
	const struct swell_msg_desc *d = swell_msg_desc_find(m->type);
	enum swell_err err;

	if (!d)
		return SWELL_EUNKNOWN;
	if (m->node > SWELL_NODE_MAX)
		return SWELL_ERANGE;
	err = swell_payload_encode(m, data, SWELL_CAN_LEN);
	if (err)
		return err;
	*id = SWELL_CAN_ID(m->type, m->node);
	*len = d->len;
	return SWELL_OK;
}

enum swell_err swell_can_decode(uint32_t id, const uint8_t *data, size_t len, struct swell_msg *out,
				struct swell_proto_stats *st)
{
	enum swell_err err = id > 0x7FFu ? SWELL_EUNKNOWN : len > SWELL_CAN_LEN ? SWELL_ESIZE : SWELL_OK;

	if (!err)
		err = payload_decode(id >> 4, data, len, out); /* out untouched unless it succeeds */
	if (!err)
		out->node = (uint8_t)(id & 0xFu);
	return count(st, err, 1);
}

/* ---- CAN FD ---- */
int swell_canfd_len_valid(size_t len)
{
	return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 || len == 48 || len == 64;
}

/* On CAN FD every message takes a slot of its length rounded up to 4 bytes (padding zero), so that
 * 1, 2, 3, 4, 6 or 8 slots of 8 bytes and 1..6, 8, 12 or 16 slots of 4 bytes make valid lengths. */
static size_t fd_slot(const struct swell_msg_desc *d)
{
	return (d->len + 3u) & ~(size_t)3u;
}

enum swell_err swell_canfd_encode(const struct swell_msg *m, size_t n, uint32_t *id, uint8_t data[64], uint8_t *len,
				  size_t *used)
{
	const struct swell_msg_desc *d;
	uint8_t buf[SWELL_CANFD_LEN];
	size_t k, i, slot;

	if (n == 0)
		return SWELL_EINVAL;
	d = swell_msg_desc_find(m[0].type);
	if (!d)
		return SWELL_EUNKNOWN;
	if (m[0].node > SWELL_NODE_MAX)
		return SWELL_ERANGE;
	slot = fd_slot(d);
	k = SWELL_CANFD_LEN / slot;
	if (k > n)
		k = n;
	for (i = 1; i < k; i++)
		if (m[i].type != m[0].type || m[i].node != m[0].node)
			break;
	k = i;
	while (!swell_canfd_len_valid(k * slot))
		k--;
	memset(buf, 0, sizeof(buf));
	for (i = 0; i < k; i++) {
		enum swell_err err = swell_payload_encode(&m[i], buf + i * slot, d->len);

		if (err)
			return err;
	}
	memcpy(data, buf, k * slot);
	*id = SWELL_CAN_ID(m[0].type, m[0].node);
	*len = (uint8_t)(k * slot);
	*used = k;
	return SWELL_OK;
}

static enum swell_err canfd_decode(uint32_t id, const uint8_t *data, size_t len, struct swell_msg *out, size_t cap,
				   size_t *n)
{
	const struct swell_msg_desc *d;
	struct swell_msg tmp[SWELL_CANFD_MSGS_MAX];
	size_t k, i, j, slot;

	if (id > 0x7FFu)
		return SWELL_EUNKNOWN;
	d = swell_msg_desc_find(id >> 4);
	if (!d)
		return SWELL_EUNKNOWN;
	slot = fd_slot(d);
	if (len > SWELL_CANFD_LEN || !swell_canfd_len_valid(len))
		return SWELL_ESIZE;
	if (len < slot || len % slot)
		return SWELL_ETRUNC; /* a partial slot at the end */
	k = len / slot;
	if (k > cap || k > SWELL_CANFD_MSGS_MAX)
		return SWELL_ESIZE;
	/* decode into a local copy so that a rejected frame leaves out[] untouched */
	for (i = 0; i < k; i++) {
		enum swell_err err;

		tmp[i].node = (uint8_t)(id & 0xFu);
		err = payload_decode(d->type, data + i * slot, d->len, &tmp[i]);
		if (err)
			return err;
		for (j = d->len; j < slot; j++)
			if (data[i * slot + j])
				return SWELL_ERANGE; /* padding must be zero */
	}
	memcpy(out, tmp, k * sizeof(tmp[0]));
	*n = k;
	return SWELL_OK;
}

enum swell_err swell_canfd_decode(uint32_t id, const uint8_t *data, size_t len, struct swell_msg *out, size_t cap,
				  size_t *n, struct swell_proto_stats *st)
{
	const enum swell_err err = canfd_decode(id, data, len, out, cap, n);

	return count(st, err, err ? 0u : (uint32_t)*n);
}

/* ---- packets ---- */
enum swell_err swell_pkt_encode(uint8_t node, uint8_t seq, const struct swell_msg *m, size_t n, uint8_t *pkt,
				size_t cap, size_t *len, size_t *used)
{
	uint8_t buf[SWELL_PKT_MAX];
	size_t pos = SWELL_PKT_HEADER, k = 0, limit = cap < SWELL_PKT_MAX ? cap : SWELL_PKT_MAX, i;
	uint32_t crc;

	if (node > SWELL_NODE_MAX)
		return SWELL_ERANGE;
	if (n == 0)
		return SWELL_EINVAL;
	while (k < n && k < 255) {
		const struct swell_msg_desc *d = swell_msg_desc_find(m[k].type);
		enum swell_err err;

		if (!d)
			return SWELL_EUNKNOWN;
		if (pos + 1 + d->len + 4 > limit)
			break;
		buf[pos] = d->type;
		err = swell_payload_encode(&m[k], buf + pos + 1, d->len);
		if (err)
			return err;
		pos += 1u + d->len;
		k++;
	}
	if (k == 0)
		return SWELL_ESIZE;
	memcpy(buf, (const uint8_t[SWELL_PKT_HEADER]){ SWELL_PKT_MAGIC, SWELL_PROTO_VERSION, node, seq, (uint8_t)k },
	       SWELL_PKT_HEADER);
	crc = swell_crc32(0, buf, pos);
	for (i = 0; i < 4; i++)
		buf[pos++] = (uint8_t)(crc >> (8 * i)); /* little-endian */
	memcpy(pkt, buf, pos);
	*len = pos;
	*used = k;
	return SWELL_OK;
}

/* Decodes the records into out[] (room for SWELL_PKT_MSGS_MAX). */
static enum swell_err pkt_records(const uint8_t *pkt, size_t end, struct swell_msg *out, size_t cap, size_t *n)
{
	size_t pos = SWELL_PKT_HEADER, k, count = pkt[4];

	if (count == 0 || count > cap || count > SWELL_PKT_MSGS_MAX)
		return SWELL_ESIZE;
	for (k = 0; k < count; k++) {
		const struct swell_msg_desc *d;
		enum swell_err err;

		if (pos >= end)
			return SWELL_ETRUNC;
		d = swell_msg_desc_find(pkt[pos]);
		if (!d)
			return SWELL_EUNKNOWN;
		if (pos + 1 + d->len > end)
			return SWELL_ETRUNC;
		out[k].node = pkt[2];
		err = payload_decode(d->type, pkt + pos + 1, d->len, &out[k]);
		if (err)
			return err;
		pos += 1u + d->len;
	}
	if (pos != end)
		return SWELL_ESIZE; /* bytes after the last record */
	*n = count;
	return SWELL_OK;
}

static enum swell_err pkt_decode(const uint8_t *pkt, size_t len, struct swell_msg *out, size_t cap, size_t *n,
				 uint8_t *seq)
{
	struct swell_msg tmp[SWELL_PKT_MSGS_MAX];
	uint32_t crc;
	size_t k;
	enum swell_err err;

	if (len > SWELL_PKT_MAX)
		return SWELL_ESIZE;
	if (len < SWELL_PKT_OVERHEAD)
		return SWELL_ETRUNC;
	if (pkt[0] != SWELL_PKT_MAGIC)
		return SWELL_EUNKNOWN;
	crc = (uint32_t)pkt[len - 4] | (uint32_t)pkt[len - 3] << 8 | (uint32_t)pkt[len - 2] << 16 |
		(uint32_t)pkt[len - 1] << 24;
	if (swell_crc32(0, pkt, len - 4) != crc)
		return SWELL_ECRC;
	if (pkt[1] != SWELL_PROTO_VERSION)
		return SWELL_EVERSION;
	if (pkt[2] > SWELL_NODE_MAX)
		return SWELL_ERANGE;
	/* decode into a local copy so that a rejected packet leaves out[] untouched */
	err = pkt_records(pkt, len - 4, tmp, cap, &k);
	if (err)
		return err;
	memcpy(out, tmp, k * sizeof(tmp[0]));
	*n = k;
	*seq = pkt[3];
	return SWELL_OK;
}

enum swell_err swell_pkt_decode(const uint8_t *pkt, size_t len, struct swell_msg *out, size_t cap, size_t *n,
				uint8_t *seq, struct swell_proto_stats *st)
{
	const enum swell_err err = pkt_decode(pkt, len, out, cap, n, seq);

	return count(st, err, err ? 0u : (uint32_t)*n);
}

struct swell_msg swell_param_request(uint8_t node, int set, uint16_t id, int32_t value, uint8_t seq)
{
	struct swell_msg m;

	memset(&m, 0, sizeof(m));
	m.node = node;
	m.type = set ? SWELL_MSG_PARAM_SET : SWELL_MSG_PARAM_GET;
	if (set)
		m.u.param_set = (struct swell_msg_param_set){ .id = id, .value = value, .seq = seq };
	else
		m.u.param_get = (struct swell_msg_param_get){ .id = id, .seq = seq };
	return m;
}

int swell_param_answer(const struct swell_msg *m, uint16_t id, uint8_t seq, int32_t *value, enum swell_err *err)
{
	if (m->type == SWELL_MSG_PARAM_ACK && m->u.param_ack.id == id && m->u.param_ack.seq == seq) {
		*value = m->u.param_ack.value;
		return 1;
	}
	if (m->type == SWELL_MSG_PARAM_NACK && m->u.param_nack.id == id && m->u.param_nack.seq == seq) {
		*err = (enum swell_err)m->u.param_nack.err;
		return 0;
	}
	return -1;
}

/* ---- heights ---- */
struct swell_msg swell_height_quad(const struct swell_quad_at *at, unsigned frame, const int16_t s[4])
{
	struct swell_msg m;

	memset(&m, 0, sizeof(m));
	m.type = SWELL_MSG_HEIGHT_QUAD;
	m.u.height_quad.tile_x = (uint8_t)at->tile_x;
	m.u.height_quad.tile_y = (uint8_t)at->tile_y;
	m.u.height_quad.row = (uint8_t)at->row;
	m.u.height_quad.half = (uint8_t)at->half;
	m.u.height_quad.frame = (uint8_t)(frame & 3u);
	m.u.height_quad.h0 = s[0];
	m.u.height_quad.h1 = s[1];
	m.u.height_quad.h2 = s[2];
	m.u.height_quad.h3 = s[3];
	return m;
}

void swell_height_quad_heights(const struct swell_msg_height_quad *q, int32_t h[4])
{
	h[0] = swell_sample_to_height(q->h0);
	h[1] = swell_sample_to_height(q->h1);
	h[2] = swell_sample_to_height(q->h2);
	h[3] = swell_sample_to_height(q->h3);
}

/* ---- sequence numbers ---- */
uint32_t swell_seq_loss(uint32_t gap, uint32_t *resyncs)
{
	if (gap <= SWELL_SEQ_WINDOW)
		return gap;
	(*resyncs)++;
	return 0;
}

uint32_t swell_seq_track(struct swell_seq *t, uint8_t seq)
{
	uint8_t step = (uint8_t)(seq - t->last), back = (uint8_t)(t->last - seq);
	uint32_t lost = 0;

	t->received++;
	if (t->started && back <= SWELL_SEQ_WINDOW && ++t->back_run < SWELL_SEQ_BACK_RUN) {
		t->repeated++;
		return 0; /* duplicate or a little older: keep the newest as reference */
	}
	if (t->started && (step >= 128 || back <= SWELL_SEQ_WINDOW))
		t->resyncs++; /* far back, or a run of older ones: the sender counts again from elsewhere */
	else if (t->started)
		lost = swell_seq_loss(step - 1u, &t->resyncs);
	t->lost += lost;
	t->back_run = 0;
	t->started = 1;
	t->last = seq;
	return lost;
}
