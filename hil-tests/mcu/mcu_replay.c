/* The emulated STM32F405's deterministic replay: mcu_replay.h. */
#include "mcu_replay.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include <unicorn/unicorn.h>

#define MARGIN_NS \
	150000u /* the last frame of a tick completes this long before the tick's update: its RX
			    * interrupt (below the tick in priority) has run by then */
#define BURST_ID 0x7F0u /* rx-burst: a type no message has, node 0: it passes the image's filter */

static uint32_t le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint64_t le64(const uint8_t *p)
{
	return (uint64_t)le32(p) | (uint64_t)le32(p + 4) << 32;
}

static int fail(char *why, size_t len, const char *msg, const char *path)
{
	snprintf(why, len, "%s: %s", path, msg);
	return -1;
}

int mcu_replay_load(struct mcu_replay *r, const char *path, uint64_t tick_ns, char *why, size_t why_len)
{
	uint8_t head[16], fh[16];
	uint64_t t;
	FILE *f;
	size_t cap = 0;
	uint32_t ticks = 0;

	if (!path)
		return 0;
	if (!tick_ns)
		return fail(why, why_len, "tick period 0", path);
	f = fopen(path, "rb");
	if (!f) {
		snprintf(why, why_len, "%s: %s", path, strerror(errno));
		return -1;
	}
	if (fread(head, 1, 16, f) != 16 || memcmp(head, "SWELLREC", 8) != 0 || le32(head + 8) != 1) {
		fclose(f);
		return fail(why, why_len, "not a swell recording (SWELLREC, format 1)", path);
	}
	if (head[12] != 0) {
		fclose(f);
		return fail(why, why_len, "not a recording of classic CAN frames (carrier 0)", path);
	}
	while (fread(fh, 1, 16, f) == 16) {
		struct bxcan_frame fr = { 0 };
		const uint16_t len = (uint16_t)(fh[12] | fh[13] << 8);

		t = le64(fh);
		if (len > 8 || fread(fr.data, 1, len, f) != len) {
			fclose(f);
			return fail(why, why_len, "a frame is longer than 8 bytes or cut", path);
		}
		fr.ide = (fh[14] & 2) != 0;
		fr.id = le32(fh + 8) & (fr.ide ? 0x1FFFFFFFu : 0x7FFu);
		fr.dlc = (uint8_t)len;
		if (t / tick_ns + 1u < ticks || t / tick_ns > 100000000u) {
			fclose(f);
			return fail(why, why_len, "frame times go back or beyond 1e8 ticks", path);
		}
		if (r->n_frames == cap) {
			struct bxcan_frame *n = realloc(r->frame, (cap ? 2 * cap : 1024) * sizeof(*n));

			if (!n) {
				fclose(f);
				return fail(why, why_len, "out of memory", path);
			}
			r->frame = n;
			cap = cap ? 2 * cap : 1024;
		}
		/* tick_first[k]: the first frame of tick k; ticks without frames get none */
		while (ticks <= t / tick_ns) {
			uint32_t *n = realloc(r->tick_first, (ticks + 2u) * sizeof(*n));

			if (!n) {
				fclose(f);
				return fail(why, why_len, "out of memory", path);
			}
			r->tick_first = n;
			r->tick_first[ticks++] = r->n_frames;
		}
		r->frame[r->n_frames++] = fr;
	}
	fclose(f);
	if (!r->n_frames)
		return fail(why, why_len, "no frames", path);
	r->n_ticks = ticks;
	r->tick_first[ticks] = r->n_frames;
	return 0;
}

int mcu_replay_fault(struct mcu_replay *r, const char *spec, char *why, size_t why_len)
{
	static const struct {
		const char *name;
		enum mcu_fault_kind kind;
		int arg; /* 0 none, 1 a count, 2 seconds */
	} kinds[] = { { "busoff", MCU_FAULT_BUS_OFF, 0 },    { "tx-errors", MCU_FAULT_TX_ERRORS, 1 },
		      { "no-ack", MCU_FAULT_NO_ACK, 2 },     { "dominant", MCU_FAULT_DOMINANT, 2 },
		      { "arb-lost", MCU_FAULT_ARB_LOST, 1 }, { "rx-burst", MCU_FAULT_RX_BURST, 1 } };
	char kind[16] = "";
	double at = -1.0, arg = -1.0;
	int n = sscanf(spec, "%lf %15s %lf", &at, kind, &arg);
	struct mcu_fault *f;

	if (r->n_faults == MCU_FAULTS_MAX) {
		snprintf(why, why_len, "--fault '%s': at most %d faults", spec, MCU_FAULTS_MAX);
		return -1;
	}
	f = &r->fault[r->n_faults];
	for (size_t k = 0; k < sizeof(kinds) / sizeof(kinds[0]); k++) {
		if (strcmp(kind, kinds[k].name) != 0)
			continue;
		if (n != (kinds[k].arg ? 3 : 2) || !(at >= 0.0 && at < 86400.0) ||
		    (kinds[k].arg == 1 && !(arg >= 1.0 && arg <= 1e6)) ||
		    (kinds[k].arg == 2 && !(arg > 0.0 && arg < 86400.0)))
			break;
		*f = (struct mcu_fault){ .at = (uint64_t)(at * (double)MCU_TIME_HZ + 0.5), .kind = kinds[k].kind };
		f->until = kinds[k].arg == 2 ? f->at + (uint64_t)(arg * (double)MCU_TIME_HZ + 0.5) : f->at;
		f->n = kinds[k].arg == 1 ? (uint32_t)arg : 0;
		r->n_faults++;
		return 0;
	}
	snprintf(why, why_len,
		 "--fault '%s': AT KIND [ARG]: AT in seconds, KIND busoff | tx-errors N | no-ack S | dominant S | "
		 "arb-lost N | rx-burst N",
		 spec);
	return -1;
}

void mcu_replay_tx(void *user, const struct bxcan_frame *f, uint64_t t_ns)
{
	struct mcu_replay *r = user;
	const unsigned n = f->rtr ? 0u : f->dlc > 8 ? 8u : f->dlc;

	r->tx_frames++;
	if (!r->log)
		return;
	fprintf(r->log, "%llu %03x %u ", (unsigned long long)t_ns, (unsigned)f->id, (unsigned)f->dlc);
	for (unsigned i = 0; i < n; i++)
		fprintf(r->log, "%02x", f->data[i]);
	fputc('\n', r->log);
}

int mcu_replay_start(struct mcu_replay *r, struct mcu *m, struct mcu_can1_dev *c, FILE *log, char *why, size_t why_len)
{
	r->log = log;
	for (unsigned i = 0; i < m->n_periph; i++)
		if (!strcmp(m->periph[i].name, "TIM2"))
			r->tim2 = &m->periph[i];
	if (!r->tim2 || !r->tim2->next_event) {
		snprintf(why, why_len, "the replay needs the TIM2 model");
		return -1;
	}
	r->force_addr = mcu_symbol_addr(m, "force_cN"); /* safe.c: the force last commanded, cN a axis */
	bxcan_set_tx_callback(&c->b, mcu_replay_tx, r);
	if (log)
		fprintf(log,
			"# swell-mcu tx log: T_NS ID DLC DATA for every frame CAN1 sent (EOF time); "
			"T_NS force FX FY FZ (cN) at every TIM2 update, before the tick: the image's force "
			"record%s\n",
			r->force_addr ? "" : " (not found in the image: not logged)");
	return 0;
}

static void faults_due(struct mcu_replay *r, struct mcu *m, struct mcu_can1_dev *c)
{
	const uint64_t ns = mcu_can1_ns(m->now);

	for (unsigned i = 0; i < r->n_faults; i++) {
		struct mcu_fault *f = &r->fault[i];

		if (f->state == 0 && m->now >= f->at) {
			f->state = f->until > f->at ? 1 : 2;
			switch (f->kind) {
			case MCU_FAULT_BUS_OFF:
				bxcan_inject_bus_off(&c->b, ns);
				break;
			case MCU_FAULT_TX_ERRORS:
				bxcan_inject_tx_errors(&c->b, f->n);
				break;
			case MCU_FAULT_NO_ACK:
				bxcan_inject_no_ack(&c->b, true);
				break;
			case MCU_FAULT_DOMINANT:
				bxcan_inject_bus_dominant(&c->b, true, ns);
				break;
			case MCU_FAULT_ARB_LOST:
				bxcan_inject_arbitration_lost(&c->b, f->n);
				break;
			case MCU_FAULT_RX_BURST:
				for (uint32_t k = 0; k < f->n; k++) {
					const struct bxcan_frame b = { .id = BURST_ID, .dlc = 8 };

					mcu_can1_bus_rx(m, c, &b);
				}
				break;
			}
			if (r->log)
				fprintf(r->log, "%llu fault %u on\n", (unsigned long long)ns, i);
		} else if (f->state == 1 && m->now >= f->until) {
			f->state = 2;
			if (f->kind == MCU_FAULT_NO_ACK)
				bxcan_inject_no_ack(&c->b, false);
			else
				bxcan_inject_bus_dominant(&c->b, false, ns);
			if (r->log)
				fprintf(r->log, "%llu fault %u off\n", (unsigned long long)ns, i);
		}
	}
	mcu_can1_bus_rx(m, c, NULL); /* the interrupt lines after an injection */
}

/* A new tick period: log the force record, plan the next recorded tick's frames before the update. */
static void new_tick(struct mcu_replay *r, struct mcu *m, struct mcu_can1_dev *c, uint64_t update)
{
	uint64_t at;

	if (r->log && r->force_addr && r->target) {
		int32_t fc[3] = { 0, 0, 0 };

		if (uc_mem_read(m->uc, r->force_addr, fc, sizeof(fc)) == UC_ERR_OK)
			fprintf(r->log, "%llu force %d %d %d\n", (unsigned long long)mcu_can1_ns(m->now), fc[0], fc[1],
				fc[2]);
	}
	while (r->next < r->end) { /* the last tick's frames that did not fit: now, late */
		if (r->log)
			fprintf(r->log, "%llu late %03x (recorded tick %u)\n", (unsigned long long)mcu_can1_ns(m->now),
				(unsigned)r->frame[r->next].id, r->tick - 1u);
		mcu_can1_bus_rx(m, c, &r->frame[r->next++]);
		r->late++;
	}
	r->target = update;
	r->ticks_seen++;
	if (!r->frame || r->tick >= r->n_ticks)
		return;
	r->first = r->next = r->tick_first[r->tick];
	r->end = r->tick_first[r->tick + 1];
	r->tick++;
	if (r->end - r->next > sizeof(r->due) / sizeof(r->due[0]))
		r->end = r->next + (uint32_t)(sizeof(r->due) / sizeof(r->due[0]));
	/* back to back, the last one completing MARGIN_NS before the update */
	at = update - mcu_can1_units(MARGIN_NS);
	for (uint32_t k = r->end; k-- > r->next;) {
		r->due[k - r->next] = at;
		at -= mcu_can1_units(bxcan_bits_ns(&c->b, bxcan_frame_bits(&r->frame[k], NULL) + 3u));
	}
}

void mcu_replay_step(struct mcu_replay *r, struct mcu *m, struct mcu_can1_dev *c)
{
	const uint64_t update = r->tim2->next_event(m, r->tim2->ctx);

	if (r->n_faults)
		faults_due(r, m, c);
	if (update == MCU_NEVER)
		return;
	if (update != r->target)
		new_tick(r, m, c, update);
	/* One frame at a time: a frame due earlier than the one before it could have ended (a late plan)
	 * waits for that, as on the wire. */
	if (r->next < r->end && m->now >= r->due[r->next - r->first]) {
		const struct bxcan_frame *f = &r->frame[r->next++];
		const uint32_t k = r->next - r->first;

		mcu_can1_bus_rx(m, c, f);
		if (r->next < r->end) {
			const uint64_t after = m->now +
				mcu_can1_units(bxcan_bits_ns(&c->b, bxcan_frame_bits(&r->frame[r->next], NULL) + 3u));

			if (r->due[k] < after)
				r->due[k] = after;
		}
	}
}

void mcu_replay_free(struct mcu_replay *r)
{
	free(r->frame);
	free(r->tick_first);
	r->frame = NULL;
	r->tick_first = NULL;
}
