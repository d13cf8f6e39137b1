/* swell-tool: one conversation with a running controller over its host link (UDP, CAN or USB, the
 * spellings of swell-view and swell-flash: swell/link_client.h). It listens to the controller's telemetry
 * (heartbeat, scene, controller info, object pose and force, heights) and keeps the latest of each,
 * and it sends parameter requests and commands and waits for their answers.
 *
 * Every failure has its own exit status (enum tool_rc), so that scripts can tell them apart. */
#ifndef SWELL_TOOL_SESSION_H
#define SWELL_TOOL_SESSION_H

#include <stddef.h>
#include <stdint.h>

#include "swell/link_client.h"
#include "swell/proto.h"

struct swell_param_desc;

enum tool_rc {
	TOOL_OK = 0,
	TOOL_FAIL = 1, /* runtime failure: the link cannot be opened, a file cannot be written */
	TOOL_USAGE = 2, /* bad arguments */
	TOOL_NO_CTL = 3, /* no controller heard on the link */
	TOOL_WRONG_NODE = 4, /* controllers heard, but not the node asked for (or several, none asked for) */
	TOOL_TIMEOUT = 5, /* the controller was there and went silent, or did not answer */
	TOOL_REFUSED = 6, /* the controller refused the request (PARAM_NACK), or the state did not follow */
	TOOL_CHECK_FAILED = 7, /* check: at least one link of the chain failed */
};

#define TOOL_GRID_MAX 256
#define TOOL_SILENT_MS 600 /* at least: heartbeats come at 10 Hz, six missed and the controller is gone */

struct tool_telemetry {
	int have_hb, have_scene, have_info, have_pose, have_force, have_energy;
	struct swell_msg_heartbeat hb;
	struct swell_msg_scene scene;
	struct swell_msg_ctl_info info;
	struct swell_msg_object_pose pose;
	struct swell_msg_object_force force;
	struct swell_msg_energy energy; /* the energy account of the run (docs/energy.md), 10 Hz */
	uint64_t hb_ns, pose_ns, force_ns; /* when each last came (CLOCK_MONOTONIC) */
	uint64_t frames, bytes, msgs; /* received from our node since the session opened */
	uint64_t can_bits; /* CAN: bits on the wire (worst-case stuffing) of those frames */
	int16_t grid[TOOL_GRID_MAX * TOOL_GRID_MAX]; /* latest height samples, 2^-6 mm */
	uint8_t seen[TOOL_GRID_MAX * TOOL_GRID_MAX];
};

struct tool_session {
	struct swell_client_spec spec;
	char name[64];
	struct swell_link *l;
	int node; /* the controller's node once found; -1 before */
	int silent_ms; /* no heartbeat this long: the controller is gone (the timeout, TOOL_SILENT_MS at least) */
	int other; /* another node heard (-1 none) */
	uint8_t seq, pkt_seq;
	uint64_t t0_ns;
	uint64_t keep_ns; /* UDP: when the next keep-alive is due */
	struct swell_proto_stats st;
	struct tool_telemetry t;
	/* Called for every message of our node after it is taken in (NULL: none), e.g. to log each
	 * OBJECT_FORCE of a burst that one tool_pump takes. */
	void (*on_msg)(struct tool_session *s, const struct swell_msg *m, void *user);
	void *user;
};

/* Open the link and wait up to timeout_ms for the controller's heartbeat (node spec->node, or the
 * one controller heard). Silence longer than timeout_ms (TOOL_SILENT_MS at least) later means the
 * controller is gone. TOOL_OK, or NO_CTL / WRONG_NODE / FAIL with a one-line reason in err. */
enum tool_rc tool_open(struct tool_session *s, const struct swell_client_spec *spec, int timeout_ms, char *err,
		       size_t errlen);
void tool_close(struct tool_session *s);

/* Receive and take in telemetry for up to ms (0: only what is there). Returns the number of
 * messages from our node taken in. */
int tool_pump(struct tool_session *s, int ms);

/* Wait until the heartbeat, scene and controller info have all been heard (they come at 10 and 1 Hz),
 * at most timeout_ms. TOOL_OK or TOOL_TIMEOUT. */
enum tool_rc tool_wait_full(struct tool_session *s, int timeout_ms);

/* The controller is silent: no heartbeat for silent_ms. */
int tool_silent(const struct tool_session *s);

/* PARAM_SET (set 1) or PARAM_GET (set 0) of id; waits for the answer for up to timeout_ms, sending
 * the request again every 250 ms (a lost frame). TOOL_OK with *value the value in force; TOOL_REFUSED
 * with *why the controller's reason; TOOL_TIMEOUT when no answer came (err says whether the
 * controller went silent). */
enum tool_rc tool_request(struct tool_session *s, int set, uint16_t id, int32_t value, int timeout_ms, int32_t *answer,
			  enum swell_err *why, char *err, size_t errlen);

/* tool_request's PARAM_GET of d, a failure told on stderr: "swell-tool: [WHAT: ]get NAME refused: why"
 * or "swell-tool: [WHAT: ]get NAME: reason" (what: NULL for none). */
enum tool_rc tool_get(struct tool_session *s, const struct swell_param_desc *d, int timeout_ms, int32_t *v,
		      const char *what);

/* The mean water level over the object's footprint (as far as heights were received), in mm, and the
 * largest |height| outside it (the waves), in mm. 0 when nothing is known. */
double tool_water_under_mm(const struct tool_session *s);
double tool_wave_max_mm(const struct tool_session *s);

/* The object displaces water, as the last pose said (mass, size and damper may not change then). */
int tool_object_wet(const struct tool_session *s);

/* Seconds since the session opened. */
double tool_elapsed_s(const struct tool_session *s);

#endif
