/* Where swell-view's frames come from. Each source hands whole carrier frames to the feed.
 * Link sources use the host links (host/links, swell/link.h; spellings: swell/link_spec.h):
 *   udp[:PORT]         datagrams on 127.0.0.1:PORT (default SWELL_UDP_PORT_VIEWER, where swell-ctl sends)
 *   can:IFACE          SocketCAN, classic frames; canfd:IFACE for CAN FD
 *   usb[:VID:PID]      libusb bulk (default the swell VID/PID); waits for the device and follows
 *                      unplug and replug
 *   replay:FILE        a recording (--record, or swell-view-gen), at recorded speed
 *   replay-fast:FILE   the same, as fast as it can be read
 * and one in-process source for tests and demos:
 *   pattern:NAME[:N]   a known scene encoded with the real encoders (gen.h), labelled "PATTERN" on
 *                      screen: bump (static), bump2 (its mirror image), ripple (animated), bob (the
 *                      object bobbing, its force following), wake (bob with rings running out from
 *                      the object: waves to see), still (bob on still water: the wake's reference);
 *                      N x N cells instead of 64 x 64. Faults
 *                      can be injected into its packet stream (source_faults) to test the decode path. */
#ifndef SWELL_VIEW_SOURCES_H
#define SWELL_VIEW_SOURCES_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "feed.h"
#include "gen.h"
#include "swell/link.h"
#include "swell/link_spec.h"

enum source_kind {
	SOURCE_LINK,
	SOURCE_PATTERN
};

/* Live links are read by a thread of their own into this ring, so frames keep being taken off the
 * socket (or bus, or USB endpoint) while a frame renders; the display thread drains it. */
#define RX_RING 32768u
struct rx_item {
	int rc; /* 0: a frame; -ENODEV: device gone; other negative errno: link error */
	uint64_t t_us; /* receive time, CLOCK_MONOTONIC */
	struct swell_frame f;
};

/* Faults injected into the pattern's packets (bit flags). */
#define FAULT_GARBAGE 0x01u /* random datagrams between the real ones */
#define FAULT_TRUNCATE 0x02u /* every 3rd packet cut short */
#define FAULT_CORRUPT 0x04u /* every 5th packet with one bit flipped */
#define FAULT_REORDER 0x08u /* neighbouring packets swapped */
#define FAULT_DROP 0x10u /* every 7th packet lost */
#define FAULT_NOSCENE 0x20u /* never send the scene description (a viewer that joined too late) */
#define FAULT_RESTART 0x40u /* the controller restarts after 0.4 s (heartbeat back to BOOT, new scene) */

struct source {
	enum source_kind kind;
	char desc[96];
	/* link */
	struct swell_link_spec ls;
	struct swell_link *link;
	char spec[256];
	uint64_t retry_us; /* USB not there at start: next attempt to open it */
	bool ended; /* replay reached the end of the recording */
	uint32_t rec_damaged; /* replay stopped at a damaged record */
	const char *record; /* record what is received to this file (link sources) */
	/* reader thread (live links) */
	bool threaded;
	pthread_t thread;
	atomic_bool stop;
	atomic_bool have_link; /* link set (by the thread when a USB device appears late) */
	atomic_uint head, tail; /* ring indices: the thread writes at head, the display reads at tail */
	atomic_uint overflow; /* frames lost because the display fell RX_RING frames behind */
	struct rx_item *ring;
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
	/* delivery */
	struct view_feed *feed;
	uint64_t now_us;
	uint32_t delivered;
};

/* Parse and open a source spec; false with a one-line reason in err. record: a file to record the
 * received frames to (link sources only), or NULL. */
bool source_open(struct source *s, const char *spec, const char *record, int usb_iface, char *err, size_t errlen);
/* Parse a fault list ("garbage,truncate,..."); false with the reason in err. */
bool source_faults(struct source *s, const char *list, char *err, size_t errlen);
/* Deliver everything available at now_us (live links: everything their thread has received, with
 * its receive times). Returns frames delivered. */
uint32_t source_poll(struct source *s, struct view_feed *f, uint64_t now_us);
void source_close(struct source *s);

#endif
