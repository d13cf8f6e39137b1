/* A HapticMaster client on its TCP command interface, for the controller's device link (swell-ctl
 * --device hm:HOST[:PORT]) and for swell-hmbridge; its requests, start-up, retries and units:
 * docs/hapticmaster.md. Inside it speaks swell's device protocol: each tick's FORCE_CMD becomes one
 * pipelined request, each answer DEVICE_VEL + DEVICE_POS (status: bit 0 powered, bit 1 force
 * rendered, bit 2 not rendering, bit 3 an error answer). Nothing blocks a tick (non-blocking socket);
 * an answer read more than max_age_ticks ticks after its tick is late: counted and dropped, so the
 * controller sees a silent device tick. Integers only, the device's decimal text parsed without
 * floating point. For the effect mode (hm_fx.h) hm_client_set_extra appends commands to the next
 * tick's request and hm_client_request sends one of its own at once; cleanup, when set, is sent
 * before every start-up, its answers not checked. The start-up is three requests, each after the
 * previous one's answers are good: the e-stop and state; swell's effects removed, init, both
 * calibrations read; the force state and a zero bias force. A pushed e-stop or a calibration the
 * device does not report stops it before any force (refusal says why; it starts again after
 * HMC_RETRY_MS). The exit removes swell's effects too (hm_client_zero_wait). */
#ifndef SWELL_HM_CLIENT_H
#define SWELL_HM_CLIENT_H

#include <netinet/in.h>
#include <stddef.h>
#include <stdio.h>
#include <stdint.h>

#include "swell/link_spec.h"
#include "swell/proto.h"

struct swell_link;

#define HMC_PORT 7654
#define HMC_TEXT_MAX 1024 /* longest request or answer text */
#define HMC_RING 32 /* requests in flight at most */
#define HMC_RETRY_MS 200 /* reconnect and start-up retry period */
#define HMC_RTT_US 20000 /* round-trip histogram range */
/* The effect mode's effects (hm_fx.h), removed with the stream mode's bias force before every
 * start-up and on exit, whichever mode left them. */
#define HMC_FX_REMOVE "remove swell_pull;remove swell_push;remove swell_damp;remove swell_weight"

enum hmc_phase {
	HMC_DOWN,
	HMC_CONNECTING,
	HMC_STARTING,
	HMC_RUNNING,
	HMC_HOLDOFF
};

struct hmc_stats {
	uint32_t requests, answers, samples; /* tick requests sent, answers read, samples produced */
	uint32_t late, lost, skipped; /* too old / never answered / not sent (too many in flight) */
	uint32_t error_answers, garbage; /* "--- ERROR:" in a tick answer / an answer not understood */
	uint32_t connects, resets, startups, startup_failures, not_force;
	uint32_t max_inflight;
	uint64_t rtt_ns_sum, rtt_ns_max; /* request written -> answer read */
	uint32_t rtt_hist[HMC_RTT_US + 1]; /* 1 us bins, later ones in the last */
};

struct hm_client {
	int fd;
	enum hmc_phase phase;
	struct sockaddr_in addr;
	char name[80];
	int64_t retry_at_ns;
	uint32_t max_age_ticks;
	/* bytes */
	uint8_t in[2 * (8 + HMC_TEXT_MAX)];
	size_t in_len;
	uint8_t out[4 * (8 + HMC_TEXT_MAX)];
	size_t out_len;
	/* requests in flight, oldest first: kind (0 tick, 1 start-up, 2 extra-only), tick and time sent */
	uint8_t ring_kind[HMC_RING];
	uint32_t ring_tick[HMC_RING];
	int64_t ring_ns[HMC_RING];
	unsigned ring_head, ring_n;
	uint32_t tick; /* hm_client_force calls */
	uint8_t seq;
	uint8_t status; /* of the last sample */
	int sent_zero; /* the last tick request sent carried zero force */
	char extra[HMC_TEXT_MAX / 2]; /* commands for the next request (effect mode) */
	const char *cleanup; /* a request before every start-up (NULL: none) */
	uint32_t inertia_g; /* set at every start-up after the calibrations (set inertia), 0: not set */
	char refusal[120]; /* why the last start-up stopped before any force ("" once running) */
	uint32_t refusal_seq; /* +1 whenever refusal changes to another reason */
	int fault_next; /* a checked request had an error answer: the next sample says fault */
	struct hmc_stats st;
};

/* spec "HOST[:PORT]" (IPv4 address or host name, resolved here, at start-up). Starts connecting;
 * never blocks. -1 with a one-line reason in err. */
int hm_client_open(struct hm_client *c, const char *spec, uint32_t max_age_ticks, char *err, size_t errlen);

/* One tick: the force to render (enable 0: zero), written at once. */
void hm_client_force(struct hm_client *c, const int16_t f_cN[3], int enable);

/* Everything that arrived: connection progress, answers. Each fresh tick answer gives DEVICE_VEL and
 * DEVICE_POS (node as given) in out; returns the number of messages (cap >= 2 for one sample). */
size_t hm_client_poll(struct hm_client *c, struct swell_msg *out, size_t cap, uint8_t node);

/* Commands appended to the next tick's request (effect mode), replacing any not sent yet ("": none);
 * -1 if they do not fit. */
int hm_client_set_extra(struct hm_client *c, const char *cmds);

/* A request of its own, written at once (never waits). checked: an error answer to any of its
 * commands is counted and the next sample reports a fault (status bits 2 and 3, not rendering);
 * otherwise its answers are not looked at. -1 when not connected or there is no room (nothing sent). */
int hm_client_request(struct hm_client *c, const char *text, int checked);

/* The exit path: zero bias force on the device now and every effect of swell's removed (one request,
 * the zero first), waiting up to wait_ms for it to go out and its answer to come. 0 when the device
 * answered. Blocks: never on the tick path. */
int hm_client_zero_wait(struct hm_client *c, int wait_ms);

/* Parses the decimal text at *s ("-0.0123", "1.5e-05", "2") into an integer in units of 10^-scale
 * (scale 5: metres to 0.01 mm), rounded half away from zero and saturated to +-limit; *s moves past
 * it. -1 (nothing moved) when no number is there. No floating point. */
int hm_client_parse_fixed(const char **s, int scale, int32_t limit, int32_t *out);

/* The way back: v in units of 10^-decimals (0..5) as decimal text ("-0.00125", "2.000"); the length
 * written, cap when it did not fit. */
size_t hm_client_fmt_fixed(char *b, size_t cap, int64_t v, int decimals);

/* The device node's link to the controller (swell-hmbridge, swell-hm): spec with the controller's
 * port and USB interface, its UDP address host and our own UDP port; on classic CAN it takes only
 * the controller's messages to the device and its heartbeat. NULL when it cannot be opened, said on
 * stderr after prog and the link's text (what). */
struct swell_link *hm_node_open(const struct swell_link_spec *spec, unsigned port, unsigned iface, const char *host,
				unsigned bind_port, const char *prog, const char *what);

/* The device node's messages on it: as many frames of the link's carrier as they take, under node
 * and seq. Returns how many failed. */
uint32_t hm_node_send(struct swell_link *l, uint8_t node, uint8_t seq, const struct swell_msg *m, size_t n);

/* Percentile p (0..1) of the n values counted in hist[0..last] (1 us bins, later ones in the last),
 * in us: for the programs' reports (the round trip here, swell-hm's figures). */
double hm_hist_pct(const uint32_t *hist, int last, uint64_t n, double p);

/* The counters and round-trip times, a few lines of "  hm ..." for a program's report. */
void hm_client_report(const struct hm_client *c, FILE *f);

int hm_client_fd(const struct hm_client *c);
const char *hm_client_phase_name(enum hmc_phase p);
void hm_client_close(struct hm_client *c);

#endif
