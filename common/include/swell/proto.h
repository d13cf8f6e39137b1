/* swell wire protocol: encoders and decoders for every carrier, expanded from swell/proto_table.h.
 * Carriers, byte by byte, in docs/protocol.md: classic CAN (one message a frame, 11-bit id = type << 4
 * | node), CAN FD (messages of one type and node in 4-byte-aligned slots) and packets (USB bulk and
 * UDP, the same bytes, with a CRC-32).
 *
 * Every decoder is strict: truncated, oversized, unknown, wrong-version, wrong-CRC, out-of-range and
 * reserved-bit frames are rejected with a swell_err reason, counted in struct swell_proto_stats when
 * one is given, and leave the output untouched. Controller-safe: no allocation, no float. */
#ifndef SWELL_PROTO_H
#define SWELL_PROTO_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"
#include "swell/proto_table.h"

#if defined(__ARM_FEATURE_SAT)
#include <arm_acle.h>
#endif

enum swell_msg_type {
#define SWELL_X(NAME, name, type, len, from, to, desc) SWELL_MSG_##NAME = type,
	SWELL_PROTO_MESSAGES(SWELL_X)
#undef SWELL_X
};

/* One struct per message; members are raw integers in the unit their name says. */
#define SWELL_PROTO_MEMBER(m, member, ctype, start, bits, min, max, kind, factor, unit, desc) ctype member;
#define SWELL_X(NAME, name, type, len, from, to, desc)              \
	struct swell_msg_##name {                                   \
		SWELL_PROTO_FIELDS_##name(SWELL_PROTO_MEMBER, name) \
	};
SWELL_PROTO_MESSAGES(SWELL_X)
#undef SWELL_X

struct swell_msg {
	uint8_t type; /* enum swell_msg_type */
	uint8_t node; /* 0 .. SWELL_NODE_MAX */
	union {
#define SWELL_X(NAME, name, type, len, from, to, desc) struct swell_msg_##name name;
		SWELL_PROTO_MESSAGES(SWELL_X)
#undef SWELL_X
	} u;
};

#define SWELL_NODE_MAX 15u
#define SWELL_CAN_ID(type, node) (((uint32_t)(type) << 4) | (uint32_t)(node))
#define SWELL_CAN_LEN 8u
#define SWELL_CANFD_LEN 64u
#define SWELL_PKT_MAX 64u /* USB full-speed bulk packet; UDP datagrams use the same bound */
#define SWELL_PKT_HEADER 5u
#define SWELL_PKT_MAGIC 0x57u
#define SWELL_PKT_OVERHEAD (SWELL_PKT_HEADER + 4u)
#define SWELL_MSG_LEN_MIN 3u /* shortest payload (checked in proto.c) */
#define SWELL_CANFD_MSGS_MAX (SWELL_CANFD_LEN / 4u) /* slots are rounded up to 4 bytes */
#define SWELL_PKT_MSGS_MAX ((SWELL_PKT_MAX - SWELL_PKT_OVERHEAD) / (1u + SWELL_MSG_LEN_MIN))

/* Bits on the wire of a classic CAN frame, 11-bit id, n data bytes, worst-case bit stuffing: 47 + 8n fixed
 * bits, and at most one stuff bit per 4 bits of the 34 + 8n bits from SOF to the end of the CRC. */
static inline unsigned swell_can_bits(unsigned n)
{
	return 47u + 8u * n + (34u + 8u * n - 1u) / 4u;
}

/* ---- the table as data (for generic code, the generator, tests) ---- */
enum swell_field_kind {
	SWELL_FK_PLAIN,
	SWELL_FK_SEQ,
	SWELL_FK_VERSION
};

struct swell_field_desc {
	const char *name;
	const char *factor; /* decimal text, physical = raw * factor */
	const char *unit;
	const char *desc;
	int64_t min, max; /* valid raw range; signed iff min < 0 */
	uint16_t offset; /* offsetof in the message struct */
	uint8_t size; /* sizeof the member: 1, 2 or 4 */
	uint8_t start, bits;
	uint8_t kind; /* enum swell_field_kind */
};

struct swell_msg_desc {
	const char *name; /* e.g. "FORCE_CMD" */
	const char *from, *to, *desc;
	const struct swell_field_desc *fields;
	uint8_t type, len, nfields;
};

extern const struct swell_msg_desc swell_msg_descs[];
extern const unsigned swell_msg_desc_count;

/* Descriptor of a message type, NULL if the type is unknown. */
const struct swell_msg_desc *swell_msg_desc_find(unsigned type);

/* Raw value of a field of m (m->type must match the descriptor the field came from). */
int64_t swell_msg_field_get(const struct swell_msg *m, const struct swell_field_desc *f);
/* Store raw v into a field; SWELL_ERANGE (nothing stored) if v is outside [min, max]. */
enum swell_err swell_msg_field_set(struct swell_msg *m, const struct swell_field_desc *f, int64_t v);
/* 1 if a and b have the same type, node and field values (padding ignored). */
int swell_msg_equal(const struct swell_msg *a, const struct swell_msg *b);

/* ---- counted rejections ---- */
struct swell_proto_stats {
	uint32_t ok; /* messages accepted */
	uint32_t rejected[SWELL_ERR_COUNT]; /* frames rejected, by reason (saturating) */
};
uint32_t swell_proto_rejected_total(const struct swell_proto_stats *st);

/* ---- payload: the bytes of one message (same on every carrier) ---- */
/* Writes desc->len bytes to payload (cap >= len). SWELL_ERANGE if a field is out of range,
 * SWELL_EUNKNOWN for an unknown type, SWELL_ESIZE if cap is too small. */
enum swell_err swell_payload_encode(const struct swell_msg *m, uint8_t *payload, size_t cap);

/* ---- classic CAN ---- */
enum swell_err swell_can_encode(const struct swell_msg *m, uint32_t *id, uint8_t data[8], uint8_t *len);
/* id: 11-bit identifier without flag bits (anything above 0x7FF is refused as unknown). */
enum swell_err swell_can_decode(uint32_t id, const uint8_t *data, size_t len, struct swell_msg *out,
				struct swell_proto_stats *st);

/* ---- CAN FD ---- */
/* Encodes the longest prefix of m[0..n) (same type and node as m[0]) whose slots make a valid
 * CAN FD length; *used says how many messages went in (>= 1 on success). */
enum swell_err swell_canfd_encode(const struct swell_msg *m, size_t n, uint32_t *id, uint8_t data[64], uint8_t *len,
				  size_t *used);
enum swell_err swell_canfd_decode(uint32_t id, const uint8_t *data, size_t len, struct swell_msg *out, size_t cap,
				  size_t *n, struct swell_proto_stats *st);
/* 1 if len is a length a CAN FD frame can have (0-8, 12, 16, 20, 24, 32, 48, 64). */
int swell_canfd_len_valid(size_t len);

/* ---- packets: USB bulk and UDP ---- */
/* Packs as many of m[0..n) as fit in min(cap, SWELL_PKT_MAX) bytes, all under header node `node`
 * (the messages' own node fields are ignored). *used >= 1 on success. */
enum swell_err swell_pkt_encode(uint8_t node, uint8_t seq, const struct swell_msg *m, size_t n, uint8_t *pkt,
				size_t cap, size_t *len, size_t *used);
/* On success *n messages (node from the header) and the packet sequence number in *seq. */
enum swell_err swell_pkt_decode(const uint8_t *pkt, size_t len, struct swell_msg *out, size_t cap, size_t *n,
				uint8_t *seq, struct swell_proto_stats *st);

/* ---- heights on the wire (see SWELL_PROTO_H_SHIFT) ---- */
/* Solver height (int32, LSB 2^-16 mm) to a wire sample (int12, LSB 2^-6 mm): rounded to nearest
 * (ties toward +infinity), saturated to [-2048, 2047]. Inline: the controller converts every cell
 * it scans. */
static inline int16_t swell_height_to_sample(int32_t h)
{
	const int shift = 16 - SWELL_PROTO_H_SHIFT;
	const int32_t s = ((h >> (shift - 1)) + 1) >> 1; /* floor((h + 2^(shift-1)) / 2^shift), no overflow */

#if defined(__ARM_FEATURE_SAT)
	return (int16_t)__ssat(s, 12); /* [-2048, 2047] in one instruction */
#else
	return (int16_t)(s < -2048 ? -2048 : s > 2047 ? 2047 : s);
#endif
}

/* Two solver heights with |h| < 2^28 (the solver saturates its field to 27 bits) as two wire samples
 * packed as sample 0 | sample 1 << 16: the rounding of swell_height_to_sample, in one shift of
 * h + 2^(shift-1) (no overflow for such h). The controller's telemetry scans the grid in pairs. */
static inline uint32_t swell_height_pair_to_samples(int32_t h0, int32_t h1)
{
	const int shift = 16 - SWELL_PROTO_H_SHIFT;
	const int32_t half = (int32_t)1 << (shift - 1);
	int32_t s0 = (h0 + half) >> shift, s1 = (h1 + half) >> shift;

#if defined(__ARM_FEATURE_SAT)
	s0 = __ssat(s0, 12);
	s1 = __ssat(s1, 12);
#else
	s0 = s0 < -2048 ? -2048 : s0 > 2047 ? 2047 : s0;
	s1 = s1 < -2048 ? -2048 : s1 > 2047 ? 2047 : s1;
#endif
	return (uint32_t)(uint16_t)s0 | (uint32_t)s1 << 16;
}

/* Wire sample to solver units: exact (sample * 2^10). */
static inline int32_t swell_sample_to_height(int16_t sample)
{
	return (int32_t)sample * ((int32_t)1 << (16 - SWELL_PROTO_H_SHIFT));
}

/* A grid is sent in tiles of SWELL_PROTO_TILE x SWELL_PROTO_TILE cells, row-major, each in 16 quads
 * (4 cells of one tile row): quad q of a grid tiles_x tiles wide is tile q / 16, row (q / 2) % 8,
 * half q % 2. Cells of a partial tile outside the grid are sent as 0. */
#define SWELL_QUADS_PER_TILE (2u * SWELL_PROTO_TILE)
#define SWELL_TILES(cells) (((unsigned)(cells) + SWELL_PROTO_TILE - 1u) / SWELL_PROTO_TILE)

struct swell_quad_at {
	unsigned tile_x, tile_y, row, half;
	unsigned x0, y; /* grid cell of the first sample */
};

static inline struct swell_quad_at swell_quad_locate(uint32_t q, unsigned tiles_x)
{
	const unsigned tile = q / SWELL_QUADS_PER_TILE;
	struct swell_quad_at at;

	at.tile_x = tile % tiles_x;
	at.tile_y = tile / tiles_x;
	at.row = (q >> 1) % SWELL_PROTO_TILE;
	at.half = q & 1u;
	at.x0 = at.tile_x * SWELL_PROTO_TILE + 4u * at.half;
	at.y = at.tile_y * SWELL_PROTO_TILE + at.row;
	return at;
}

/* The PARAM_SET of value (set 1) or the PARAM_GET (set 0; value unused) of parameter id to node, request
 * number seq. */
struct swell_msg swell_param_request(uint8_t node, int set, uint16_t id, int32_t value, uint8_t seq);
/* Whether m answers the parameter request (id, seq): 1 for PARAM_ACK (*value the value in force), 0 for
 * PARAM_NACK (*err the reason), -1 for any other message. */
int swell_param_answer(const struct swell_msg *m, uint16_t id, uint8_t seq, int32_t *value, enum swell_err *err);

/* The HEIGHT_QUAD (node 0) of the quad at `at` carrying samples s[0..3]; frame 0..3. */
struct swell_msg swell_height_quad(const struct swell_quad_at *at, unsigned frame, const int16_t s[4]);
/* The four samples of a HEIGHT_QUAD in solver units. */
void swell_height_quad_heights(const struct swell_msg_height_quad *q, int32_t h[4]);

/* ---- sequence numbers on streams ---- */
/* A gap of at most this many missing sequence numbers is counted as lost; a longer jump (another
 * sender, a count that started again) is one resynchronisation, not hundreds lost. For 8-bit
 * sequences it is a quarter of the half range, so a jump back further than it is one too. */
#define SWELL_SEQ_WINDOW 32u
/* This many numbers in a row a little behind the newest are no longer late ones: the sender
 * started its count again (a resynchronisation). */
#define SWELL_SEQ_BACK_RUN 8u
/* The loss a forward gap of `gap` missing numbers stands for: gap itself within the window;
 * beyond it 0, and *resyncs counts one more resynchronisation. Every loss counter uses it. */
uint32_t swell_seq_loss(uint32_t gap, uint32_t *resyncs);

struct swell_seq {
	uint8_t last;
	uint8_t started;
	uint8_t back_run; /* numbers in a row behind the newest */
	uint32_t received, lost, repeated; /* repeated: duplicates and reordered (seq went back) */
	uint32_t resyncs; /* jumps beyond SWELL_SEQ_WINDOW either way, runs of older ones: one
			   * each, the number taken as the new reference */
};
/* Accounts for one received sequence number; returns how many were lost before it (0 for a
 * repeat, a late one and a resynchronisation). */
uint32_t swell_seq_track(struct swell_seq *t, uint8_t seq);

#endif
