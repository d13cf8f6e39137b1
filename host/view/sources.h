/* Where swell-view's frames come from. Each source delivers whole carrier frames to the feed (and
 * to the recorder, when one is open).
 *   udp[:PORT]         datagrams on 127.0.0.1:PORT (default SWELL_UDP_PORT_VIEWER), as swell-ctl sends
 *   replay:FILE        a recording made with --record (or by swell-view-gen), at recorded speed
 *   replay-fast:FILE   the same, everything at once
 *   pattern:NAME       a known scene encoded in-process with the real encoders (gen.h), labelled
 *                      "PATTERN" on screen: bump (static), bump2 (its mirror image),
 *                      ripple (animated). Faults can be injected
 *                      into its packet stream (see source_faults) to test the decode path. */
#ifndef SWELL_VIEW_SOURCES_H
#define SWELL_VIEW_SOURCES_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "feed.h"
#include "gen.h"

enum source_kind { SOURCE_UDP, SOURCE_PATTERN, SOURCE_REPLAY };

/* Recording format (provisional, until host/links has one): the 8-byte magic REC_MAGIC, then one
 * record a received frame: receive time us (u64 LE), carrier (u8: 0 packet, 1 CAN, 2 CAN FD),
 * CAN id (u32 LE, 0 for packets), length (u16 LE), the frame's bytes. */
#define REC_MAGIC "SWVREC01"
#define REC_PACKET 0u
#define REC_CAN 1u
#define REC_CANFD 2u

/* Open a recording for writing (writes the magic); NULL with errno set on failure. */
FILE *rec_create(const char *path);
/* Append one frame. */
void rec_write(FILE *f, uint64_t t_us, unsigned carrier, uint32_t can_id, const uint8_t *p, size_t len);

/* Faults injected into the pattern's packets (bit flags). */
#define FAULT_GARBAGE  0x01u /* random datagrams between the real ones */
#define FAULT_TRUNCATE 0x02u /* every 3rd packet cut short */
#define FAULT_CORRUPT  0x04u /* every 5th packet with one bit flipped */
#define FAULT_REORDER  0x08u /* neighbouring packets swapped */
#define FAULT_DROP     0x10u /* every 7th packet lost */
#define FAULT_NOSCENE  0x20u /* never send the scene description (a viewer that joined too late) */
#define FAULT_RESTART  0x40u /* the controller restarts after 0.4 s (heartbeat back to BOOT, new scene) */

struct source {
	enum source_kind kind;
	char desc[96];
	int fd;
	/* pattern */
	struct gen_scene g;
	bool animate;
	unsigned faults;
	uint64_t t0_us, next_us;
	uint32_t frame;
	uint8_t seq, hb_seq;
	uint32_t rng;
	uint8_t held[SWELL_PKT_MAX];
	size_t held_len;
	uint32_t emitted;
	bool restarted;
	/* replay */
	FILE *in;
	bool fast, ended;
	uint64_t rec_t0, rec_first;
	bool have_pending;
	uint64_t pend_t;
	uint8_t pend_carrier;
	uint32_t pend_id;
	uint16_t pend_len;
	uint8_t pend[2048];
	uint32_t rec_bad;      /* records that could not be read (truncated file) */
	/* delivery */
	struct view_feed *feed;
	FILE *record;
	uint64_t now_us;
	uint32_t delivered;
};

/* Parse and open a source spec; false with a one-line reason in err. */
bool source_open(struct source *s, const char *spec, char *err, size_t errlen);
/* Parse a fault list ("garbage,truncate,..."); false with the reason in err. */
bool source_faults(struct source *s, const char *list, char *err, size_t errlen);
/* Deliver everything available at now_us. Returns frames delivered. */
uint32_t source_poll(struct source *s, struct view_feed *f, uint64_t now_us);
void source_close(struct source *s);

#endif
