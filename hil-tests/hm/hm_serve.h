/* The HapticMaster's TCP interface, served from the emulator's device loop (docs/hapticmaster.md).
 *
 * Framing both ways: swell/hm_frame.h, the text ASCII. A fixed table of HM_SERVE_CLIENTS connections
 * with fixed buffers; nothing is allocated after hm_serve_open. hm_serve_poll never blocks: it is called once a device tick and
 * does a bounded amount of work (HM_SERVE_REQS_PER_TICK requests per client, one buffer of reading).
 *
 * Bad input is answered or dropped, and counted by its reason:
 *   header with a length of 0 or over HM_SERVE_TEXT_MAX, or nonzero bytes 4-7 (which is also where a
 *   length that does not match the text lands): answered "--- ERROR: ...", then the connection closes;
 *   text with a byte that is not printable ASCII (binary garbage): answered "--- ERROR: ...", nothing
 *   run, the connection stays;
 *   half a request and then silence for HM_SERVE_STALL_MS: dropped;
 *   a client that does not read its replies (its reply buffer would overflow): dropped;
 *   more requests than a tick's budget: left in the socket for the next tick (a flood slows only
 *   its own client);
 *   a full table: the newcomer is closed at once;
 *   EOF or a reset: closed, its bias forces zeroed at once. */
#ifndef SWELL_HM_SERVE_H
#define SWELL_HM_SERVE_H

#include <netinet/in.h>
#include <stddef.h>
#include <stdint.h>

#include "hm_cmd.h"
#include "swell/hm_frame.h"

#define HM_SERVE_CLIENTS HM_CLIENTS_MAX
#define HM_SERVE_TEXT_MAX 2048 /* longest request text */
#define HM_SERVE_REPLY_MAX 4096 /* longest reply text */
#define HM_SERVE_OUT_MAX 16384 /* replies waiting for a slow reader */
#define HM_SERVE_SNDBUF 65536 /* kernel send buffer of a connection */
#define HM_SERVE_REQS_PER_TICK 4
#define HM_SERVE_STALL_MS 500
#define HM_SERVE_PORT 7654
#define HM_SERVE_HELD 256 /* replies held back at once by an injected delay */

struct hm_conn {
	int fd;
	uint8_t in[SWELL_HM_FRAME_HDR + HM_SERVE_TEXT_MAX];
	size_t in_len;
	uint8_t out[HM_SERVE_OUT_MAX];
	size_t out_len;
	int64_t partial_since_ns; /* a request began arriving then and is not whole yet (0: none) */
	int closing; /* answered a fatal error: close once the answer is out */
	int64_t arrived_rt_ns; /* kernel receive time (CLOCK_REALTIME) of the last bytes read */
	/* fault injection: replies held until their release time (ends in out[], oldest first) */
	size_t held_end[HM_SERVE_HELD];
	int64_t held_until_ns[HM_SERVE_HELD];
	unsigned held_n;
};

#define HM_SERVE_AGE_US 10000 /* request age histogram: 1 us bins, later ones in the last */

struct hm_serve_stats {
	uint32_t accepted, refused_full, requests, replies;
	uint32_t drop_header, drop_stalled, drop_not_reading;
	uint32_t garbage, vanished, deferred_ticks;
	uint32_t injected_resets, injected_garbage, delayed_replies;
	uint64_t bytes_in, bytes_out;
	/* age of a request when the device applies it: kernel arrival to the end of the tick's step */
	uint32_t age_hist[HM_SERVE_AGE_US + 1];
	uint64_t ages;
	int64_t age_max_ns;
};

struct hm_serve {
	int lfd;
	char name[64];
	struct hm_conn c[HM_SERVE_CLIENTS];
	struct hm_serve_stats st;
	char reply[HM_SERVE_REPLY_MAX];
	int64_t tick_first_rt_ns; /* kernel arrival of the oldest request run since the last step (0: none) */
	int64_t reply_delay_ns; /* fault injection: replies go out this much later (0: at once) */
};

/* Checks spec ("[ADDR:]PORT" or "ADDR") into sa; -1 with a one-line reason in err. */
int hm_serve_parse(const char *spec, struct sockaddr_in *sa, char *err, size_t errlen);

/* spec: "[ADDR:]PORT" or "ADDR" (IPv4; ADDR defaults to 127.0.0.1, PORT to 7654). Listens
 * non-blocking. On failure returns -1 with a one-line reason in err. */
int hm_serve_open(struct hm_serve *s, const char *spec, char *err, size_t errlen);

/* One tick's share of the network: accept, read, answer requests through d, write. Never blocks. */
void hm_serve_poll(struct hm_serve *s, struct hm_dev *d, int64_t now_ns);

/* The device has just applied this tick's step: the requests run before it are counted with their
 * age (kernel arrival to now). */
void hm_serve_applied(struct hm_serve *s);

/* Fault injection (the bench's TCP faults): every client's connection reset (RST), or 16 bytes of
 * unframed garbage written to every client; replies delayed by setting reply_delay_ns. */
void hm_serve_inject_reset(struct hm_serve *s, struct hm_dev *d);
void hm_serve_inject_garbage(struct hm_serve *s);

/* Connections open now. */
int hm_serve_clients(const struct hm_serve *s);

void hm_serve_close(struct hm_serve *s, struct hm_dev *d);

#endif
