/* The decoder side of swell-view: carrier frames in (packets from UDP/USB, CAN and CAN FD frames),
 * the view model filled out. Every frame goes through the common/ decoders; a rejected frame is
 * counted (by reason) and changes nothing.
 *
 * Height quads are written into the model as they arrive (each is a complete, checked row piece),
 * ordered by stream position (the packet sequence unwrapped; arrival order on CAN): a reordered
 * packet never overwrites newer heights. The quads' 2-bit frame numbers cannot order quads that the
 * controller sends many solver steps apart, so they are not used for ordering. */
#ifndef SWELL_VIEW_FEED_H
#define SWELL_VIEW_FEED_H

#include <stdbool.h>
#include <stdint.h>
#include <stddef.h>

#include "chart.h"
#include "swell/proto.h"
#include "vm.h"

#define FEED_NODE_ANY 0xffu
#define FEED_HEARTBEAT_US 100000u /* the controller's heartbeat period (10 Hz) */

struct view_feed {
	struct view_model *vm;
	struct charts *charts; /* strip-chart samples of poses, forces and latency, or NULL */
	struct swell_proto_stats st;
	uint8_t node; /* accept this node, or FEED_NODE_ANY */
	uint32_t other_node; /* frames from other nodes, ignored */
	/* object size: from CTL_INFO once one has arrived (obj_from_wire), until then the fallback the
	 * caller set (swell-view's --object) */
	uint32_t obj_a_um, obj_b_um, obj_h_um;
	bool obj_from_wire;
	uint8_t submersion_halfpct;
	uint8_t force_limits;
	/* controller state and restart detection */
	bool have_state;
	uint8_t state;
	/* A replay sets rec_clock and, before each frame, rec_us: the receive time the recording gives
	 * it. The latency is then taken from the recording's own times, never from when the display
	 * happened to read the frame. */
	bool rec_clock;
	uint64_t rec_us;
	/* heartbeat counter unwrapped: the controller's clock for the latency estimate */
	bool have_hb;
	uint8_t hb_seq;
	uint64_t hb_count;
	/* object pose order (and, on CAN, loss: it has no packet sequence) */
	bool have_pose_seq;
	uint8_t pose_seq, pose_stale;
	/* stream position */
	bool have_seq;
	uint8_t last_seq;
	uint32_t pos;
};

void feed_init(struct view_feed *f, struct view_model *vm, uint8_t node);

/* One USB packet or UDP datagram. */
void feed_packet(struct view_feed *f, const uint8_t *pkt, size_t len, uint64_t now_us);
/* One CAN frame (classic when len <= 8 and !fd). id: 11-bit identifier. */
void feed_can(struct view_feed *f, uint32_t id, const uint8_t *data, size_t len, bool fd, uint64_t now_us);

#endif
