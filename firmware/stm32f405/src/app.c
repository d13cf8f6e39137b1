#include "app.h"

#include "../logic/scene.h"
#include "boot.h"
#include "can.h"
#include "console.h"
#include "fault.h"
#include "image.h"
#include "irq.h"
#include "iwdg.h"
#include "mem.h"
#include "safe.h"
#include "swell/proto.h"
#include "swell/transport.h"
#include "tick.h"
#include "usb.h"

int32_t app_arena[APP_ARENA_WORDS];
struct swell_ctl app_ctl;
struct fw_mem app_mem;

#define USB_RING 8u /* decoded messages from USB waiting for the tick (SPSC: USB ISR -> tick) */
/* Host messages taken from the core's queue that the carrier has not taken yet (the bulk IN endpoint
 * still holds the previous packet, or every CAN mailbox is full): sent first at the next drain. */
#define HOST_PEND 12u
/* Ticks between an accepted ENTER_BOOTLOADER and the reset: the zero force and the last heartbeat
 * leave through the normal drains first. */
#define BOOT_DRAIN_TICKS 3u

static struct {
	int can_on, usb_on, device_on_can;
	struct swell_msg usb_rx[USB_RING];
	volatile uint32_t usb_head, usb_tail;
	uint32_t usb_dropped, bad_frames_reported, overruns_seen, bus_offs_seen;
	/* device commands on CAN that the driver refused, in a row (every mailbox held by frames that do
	 * not leave: no ACK, lost arbitration, a stuck bus) */
	uint32_t unsent_run;
	int starving, aborted; /* aborted: the spell's abort frees a mailbox, which proves nothing */
	struct swell_proto_stats stats;
	uint8_t usb_seq;
	struct fw_pool_at place;
	/* a start-up parameter's request (swell/ctl_pool.h), taken at a tick without a background part
	 * running, and its answer, sent by the host link's drain */
	struct swell_msg pool_req, pool_ans;
	volatile uint8_t pool_req_on, pool_ans_on;
	/* the host drain's pending messages, oldest first; touched only by the context that drains the
	 * host queue (host_drained_in_tick) */
	struct swell_msg host_pend[HOST_PEND];
	uint32_t host_pend_n;
} app;

static enum swell_ctl_link link_of(const struct swell_msg *m)
{
	const struct swell_msg_desc *d = swell_msg_desc_find(m->type);

	return d && d->from[0] == 'D' ? SWELL_LINK_DEVICE : SWELL_LINK_HOST;
}

static void on_usb_out(const uint8_t *pkt, uint32_t len)
{
	struct swell_msg m[SWELL_PKT_MSGS_MAX];
	size_t n = 0, i;
	uint8_t seq;

	if (swell_pkt_decode(pkt, len, m, SWELL_PKT_MSGS_MAX, &n, &seq, &app.stats) != SWELL_OK)
		return; /* counted in stats, reported to the core at the next tick */
	for (i = 0; i < n; i++) {
		if (app.usb_head - app.usb_tail >= USB_RING) {
			app.usb_dropped++;
			continue;
		}
		app.usb_rx[app.usb_head % USB_RING] = m[i];
		__asm__ volatile("dmb" ::: "memory");
		app.usb_head++;
	}
}

/* SWELL_OK when the driver took the frame into a mailbox; refused when every mailbox holds something
 * more urgent (or a frame of the same id that has not left). */
static enum swell_err send_can(const struct swell_msg *m)
{
	struct fw_frame f = { 0 };
	enum swell_err err = swell_can_encode(m, &f.id, f.data, &f.len);

	return err == SWELL_OK ? can_send(&f) : err;
}

/* How many messages of the front of m went out (or could never go: dropped), as many as fit in each
 * 64-byte packet; stops at the first packet the endpoint refuses (not configured, suspended, or the
 * previous packet still in flight). */
static size_t send_usb(const struct swell_msg *m, size_t n)
{
	uint8_t pkt[SWELL_PKT_MAX];
	size_t len, used, sent = 0;

	while (sent < n && usb_host_active()) {
		if (swell_pkt_encode(app_ctl.cfg.node, app.usb_seq, m + sent, n - sent, pkt, sizeof(pkt), &len,
				     &used) != SWELL_OK ||
		    !used) {
			sent++; /* a message no packet carries: it would hold the link up */
			continue;
		}
		if (usb_send(pkt, (uint32_t)len) != SWELL_OK)
			break;
		app.usb_seq++;
		sent += used;
	}
	return sent;
}

/* The device link's messages on CAN: what the carrier refuses is dropped (the next tick sends fresh
 * ones). */
static void send_device_can(const struct swell_msg *m, size_t n)
{
	for (size_t j = 0; j < n; j++)
		if (send_can(&m[j]) != SWELL_OK && m[j].type == SWELL_MSG_FORCE_CMD)
			app.unsent_run++; /* the device link's command did not reach the carrier */
		else if (m[j].type == SWELL_MSG_FORCE_CMD && !app.aborted)
			app.unsent_run = 0; /* taken: the one before it left its mailbox */
		else if (m[j].type == SWELL_MSG_FORCE_CMD)
			app.aborted = 0;
}

/* The first n pending host messages went out (or were dropped): the rest move up. */
static void host_taken(size_t n)
{
	for (size_t j = n; j < app.host_pend_n; j++)
		app.host_pend[j - n] = app.host_pend[j];
	app.host_pend_n -= (uint32_t)n;
}

/* The device link's messages on USB (the k first of out, which has room for 8). Both links share the
 * one bulk IN endpoint, and a packet goes out at most every tick: the host's pending messages ride in
 * the device's packet, after the device's own, as many as fit (alone, the device's packet would
 * leave the endpoint busy at every host drain, and the host link would get nothing). What the
 * endpoint refuses: the device's messages are dropped, the host's stay pending. */
static void send_device_usb(struct swell_msg *out, size_t k)
{
	size_t h = 0, sent;

	for (; k + h < 8 && h < app.host_pend_n; h++)
		out[k + h] = app.host_pend[h];
	sent = send_usb(out, k + h);
	host_taken(sent > k ? sent - k : 0);
}

/* The host link's carrier: USB while a USB host has the device configured and not suspended
 * (usb_host_active), CAN otherwise (when CAN runs). Decided at every host drain, so answers follow
 * the cable. */
static int host_on_can(void)
{
	return app.can_on && !(app.usb_on && usb_host_active());
}

/* The device link's queue onto its carrier. Bounded: a queue holds at most SWELL_CTL_QUEUE messages,
 * taken 8 at a time (SRAM and stack are tight). */
static void drain_device(void)
{
	struct swell_msg out[8];
	uint32_t n;
	size_t k;

	for (n = 0; n < SWELL_CTL_QUEUE / 8; n++) {
		k = swell_ctl_tx(&app_ctl, SWELL_LINK_DEVICE, out, 8);
		if (!k)
			break;
		for (size_t j = 0; j < k; j++) {
			const struct swell_msg_force_cmd *fc = &out[j].u.force_cmd;

			if (out[j].type == SWELL_MSG_FORCE_CMD)
				safe_force_record(fc->enable ? fc->fx_cN : 0, fc->enable ? fc->fy_cN : 0,
						  fc->enable ? fc->fz_cN : 0);
		}
		if (app.device_on_can)
			send_device_can(out, k);
		else
			send_device_usb(out, k);
	}
}

/* Telemetry a newer sample replaces: what the host drain gives up when its pending buffer is full. */
static int host_is_telemetry(const struct swell_msg *m)
{
	return m->type == SWELL_MSG_HEIGHT_QUAD || m->type == SWELL_MSG_OBJECT_POSE ||
		m->type == SWELL_MSG_OBJECT_FORCE;
}

/* The pending messages the carrier takes, oldest first, until it refuses one. */
static void host_flush(int on_can)
{
	size_t sent = 0;

	if (!on_can)
		sent = send_usb(app.host_pend, app.host_pend_n);
	else
		for (; sent < app.host_pend_n; sent++) {
			struct fw_frame f = { 0 };

			/* a message no frame carries is dropped: it would hold the link up */
			if (swell_can_encode(&app.host_pend[sent], &f.id, f.data, &f.len) == SWELL_OK &&
			    can_send(&f) != SWELL_OK)
				break;
		}
	host_taken(sent);
}

/* Room for one more pending message: a full buffer gives up its oldest telemetry. 0 when it holds
 * only answers, heartbeats and the like (they wait in the core's queue then). */
static int host_room(void)
{
	uint32_t i;

	if (app.host_pend_n < HOST_PEND)
		return 1;
	for (i = 0; i < HOST_PEND && !host_is_telemetry(&app.host_pend[i]); i++)
		;
	if (i == HOST_PEND)
		return 0;
	for (; i + 1 < HOST_PEND; i++)
		app.host_pend[i] = app.host_pend[i + 1];
	app.host_pend_n--;
	return 1;
}

/* The start-up parameter's answer and the core's host queue into the pending buffer, while it has room
 * (bounded: at most SWELL_CTL_QUEUE messages taken). */
static void host_fill(void)
{
	if (app.pool_ans_on && host_room()) {
		app.host_pend[app.host_pend_n++] = app.pool_ans;
		__asm__ volatile("dmb" ::: "memory");
		app.pool_ans_on = 0;
	}
	for (uint32_t n = 0; n < SWELL_CTL_QUEUE && host_room(); n++) {
		if (!swell_ctl_tx(&app_ctl, SWELL_LINK_HOST, &app.host_pend[app.host_pend_n], 1))
			break;
		app.host_pend_n++;
	}
}

/* The host link's queue onto its carrier. Nothing taken from the core is lost because the carrier is
 * busy: what it refuses stays pending (bounded, HOST_PEND) and goes first at the next drain; when the
 * carrier is slower than the core queues, the oldest pending telemetry gives way to newer messages.
 * Bounded: at most SWELL_CTL_QUEUE messages taken, each one move of the pending buffer. */
static void drain_host(void)
{
	int on_can = host_on_can();
	uint32_t n;

	if (!on_can && !usb_host_active()) {
		/* USB only, and no host on it (the cable out, suspended, not configured): what the host link
		 * holds has nobody to go to, and would reach the next host stale; dropped (bounded: one
		 * queue's worth) */
		for (n = 0; n < SWELL_CTL_QUEUE && swell_ctl_tx(&app_ctl, SWELL_LINK_HOST, app.host_pend, 1); n++)
			;
		app.host_pend_n = 0;
		app.pool_ans_on = 0;
		return;
	}
	host_flush(on_can);
	host_fill();
	host_flush(on_can);
}

/* Which context drains the host queue, fixed at start-up. Device on USB (no CAN): the host is on USB
 * too, and both queues go out from the tick interrupt, so that the USB driver is never entered from
 * two priorities. Device on CAN: the host queue goes out in thread mode right after the background
 * part (fresh telemetry), on USB or CAN as host_on_can says; can_send masks interrupts around the
 * mailboxes, so the tick's device drain and thread mode's host drain may both use it. */
static int host_drained_in_tick(void)
{
	return !app.device_on_can;
}

/* The tick (TIM2, priority 0): inputs, the force part of the core's tick, the force out. The solver
 * slice and telemetry (the background part) run in thread mode right after, from app_run's loop; if
 * one is still running when the next tick comes, the core counts an overrun and the force path goes
 * first. Bounded: at most a CAN RX ring and a USB ring of messages, one force part, one drain. */
/* A message for the core, or a start-up parameter's request for the port (one at a time: a second
 * one before the first is answered is dropped, and the host's request times out). */
static void rx(const struct swell_msg *m)
{
	if (link_of(m) != SWELL_LINK_HOST || !fw_pool_is_startup(m))
		swell_ctl_rx(&app_ctl, link_of(m), m);
	else if (!app.pool_req_on) {
		app.pool_req = *m;
		app.pool_req_on = 1;
	}
}

static void app_tick(void)
{
	struct swell_msg m;
	struct fw_frame f;
	struct tick_stats st;
	uint32_t bad, n;

	while (app.can_on && can_recv(&f) == SWELL_OK)
		if (swell_can_decode(f.id, f.data, f.len, &m, &app.stats) == SWELL_OK)
			rx(&m);
	for (n = 0; n < USB_RING && app.usb_tail != app.usb_head; n++) {
		m = app.usb_rx[app.usb_tail % USB_RING];
		__asm__ volatile("dmb" ::: "memory");
		app.usb_tail++;
		rx(&m);
	}
	/* a new pool restarts the core: never under a background part still running */
	if (app.pool_req_on && !app.pool_ans_on && !swell_ctl_background_due(&app_ctl)) {
		(void)fw_pool_param(&app_ctl, &app_mem, &app.pool_req, &app.pool_ans, &app.place);
		app.pool_req_on = 0;
		__asm__ volatile("dmb" ::: "memory");
		app.pool_ans_on = 1;
	}
	bad = swell_proto_rejected_total(&app.stats);
	if (bad != app.bad_frames_reported) {
		swell_ctl_bad_frames(&app_ctl, bad - app.bad_frames_reported);
		app.bad_frames_reported = bad;
	}
	tick_read(&st);
	if (st.overruns != app.overruns_seen) {
		app.overruns_seen = st.overruns;
		swell_ctl_overrun(&app_ctl);
	}

	if (app.device_on_can && can_bus_offs() != app.bus_offs_seen) {
		/* the status interrupt has zeroed the force; the core faults as on the Linux port */
		app.bus_offs_seen = can_bus_offs();
		swell_ctl_link_down(&app_ctl, SWELL_LINK_DEVICE);
	}
	/* The device link on USB without a host to read it (usb_host_active: the cable out, which shows as
	 * the bus's suspend 6 ms after the last frame; a bus reset; SET_CONFIGURATION 0): the device link is
	 * down at every such tick, as on a CAN bus-off: the core faults, its force and the record go to
	 * zero at this tick, and nothing of it waits in the endpoint (the driver took the unread packet
	 * back). Once a host configures the device again, the device's samples bring the loop back as after
	 * any loss (autorun: recover_ticks of the device heard; or the host's clear). */
	if (!app.device_on_can && !usb_host_active())
		swell_ctl_link_down(&app_ctl, SWELL_LINK_DEVICE);
	/* A starved device (docs/links.md, as swell-ctl): no command of the device link reached the bus for
	 * the silence limit while the device is there (it still talks: nobody acknowledges, higher ids hold
	 * the bus, the bus is stuck). The loop faults as for a silent device; at the start of each spell the
	 * safe state aborts the commands stuck in the mailboxes, whose force is stale by the time the bus
	 * takes them, and queues a zero command in their place. */
	if (app.device_on_can && app.unsent_run >= swell_ctl_silent_limit(&app_ctl) &&
	    (app_ctl.state == SWELL_CTL_ARMED || app_ctl.state == SWELL_CTL_RUNNING || app.starving)) {
		if (!app.starving) {
			app.starving = 1;
			app.aborted = 1;
			safe_force_zero();
		}
		swell_ctl_link_down(&app_ctl, SWELL_LINK_DEVICE);
	} else if (app.unsent_run == 0) {
		app.starving = 0;
	}
	swell_ctl_tick_force(&app_ctl);
	if (host_drained_in_tick() && usb_host_active())
		host_fill(); /* USB only: what fits rides in the device's packet */
	drain_device();
	if (host_drained_in_tick())
		drain_host();
}

/* Thread mode, lowest priority: the background part of the tick the interrupt just ran. */
static void app_background(void)
{
	if (!swell_ctl_background_due(&app_ctl))
		return;
	swell_ctl_tick_background(&app_ctl);
	if (!host_drained_in_tick())
		drain_host();
}

void app_fw_version(uint8_t v[3])
{
	uint32_t version = image_version(); /* checked at boot */

	v[0] = (uint8_t)(version >> 16 > 255u ? 255u : version >> 16);
	v[1] = (uint8_t)(version >> 8);
	v[2] = (uint8_t)version;
}

/* The safe-state hook of the device carrier: a zero FORCE_CMD queued directly (fault path; no core
 * involved). */
static void app_send_zero_force(void)
{
	const struct swell_msg m = { .type = SWELL_MSG_FORCE_CMD, .node = app_ctl.cfg.node };

	if (app.device_on_can)
		(void)send_can(&m); /* after the mailboxes' abort: taken unless the bus has them all */
}

/* Sleep until an interrupt when the loop has nothing to do: no tick since the loop last looked (the
 * watchdog kick, can_poll's time and the bootloader countdown move only with the tick count) and no
 * background part due. Race-free: checked with interrupts masked (irq.h), and WFI wakes on an
 * interrupt that is pending even while PRIMASK masks it (ARMv7-M ARM B1.5.19); it is taken once the
 * mask is restored, so the loop runs again right after the interrupt that woke it. */
static void idle_until_interrupt(uint32_t seen_count)
{
	struct tick_stats st;
	uint32_t primask = irq_save();

	tick_read(&st);
	if (st.count == seen_count && !swell_ctl_background_due(&app_ctl))
		__asm__ volatile("dsb\n\twfi" ::: "memory");
	irq_restore(primask);
}

void app_run(const struct clock_info *ci, int can_ok, int usb_ok, const struct app_prio *prio, uint32_t watchdog_ms)
{
	struct swell_ctl_config cfg;
	struct tick_stats st;
	/* Accept every message type for our node: id = type << 4 | node. */
	struct can_filter_spec flt = { .id = 0, .mask = 0x00F, .kind = CAN_FILTER_MASK, .fifo = 0 };
	uint32_t tick_hz = can_ok ? 1000u : 2500u, last_count = 0, now_ms, boot_at = 0;
	int boot_armed = 0;
	enum swell_err err;

	swell_ctl_default_config(&cfg);
	app_fw_version(cfg.fw_version);
	cfg.tick_hz = tick_hz;
	cfg.safety.tick_hz = tick_hz;
	flt.id = cfg.node;
	err = fw_pool_start(&app_ctl, &cfg, &app_mem, &app.place);
	if (err == SWELL_OK)
		mem_report(&app_ctl, &app_mem, &app.place);
	if (err == SWELL_OK && can_ok) {
		err = can_start(ci->pclk1_hz, SWELL_CAN_BITRATE, &flt, 1, 0, prio->can_rx, prio->can_sce);
		app.can_on = app.device_on_can = err == SWELL_OK;
		if (err == SWELL_OK) /* after the driver's transmit abort: the zero command goes out last */
			err = safe_register(app_send_zero_force);
	}
	if (err == SWELL_OK && usb_ok && ci->src != CLOCK_HSE_PLL)
		con_puts("usb: not started: 48 MHz needs the crystal (HSE), running on HSI\n");
	else if (err == SWELL_OK && usb_ok) {
		err = usb_start(prio->usb, on_usb_out);
		app.usb_on = err == SWELL_OK;
	}
	if (err == SWELL_OK) {
		/* The banner before the tick starts: the console waits on its USART (5 ms for this line at
		 * 115200 baud). Written once the tick ran, it held the main loop over the first ticks, whose
		 * background parts then never ran: 4 overruns at every boot, the solver a step behind. */
		con_puts("controller: ");
		con_put_u64(tick_hz);
		con_puts(" Hz tick, device on ");
		con_puts(app.device_on_can ? "CAN 1 Mbit/s" : "USB");
		con_puts(!app.usb_on          ? ", host on CAN\n"
				 : app.can_on ? ", host on USB while configured, else CAN\n"
					      : ", host on USB\n");
		err = tick_start(ci->tim_apb1_hz, tick_hz, prio->tick, app_tick);
	}
	if (err != SWELL_OK) {
		con_puts("controller: start refused: ");
		con_puts(swell_err_str(err));
		con_putc('\n');
		fault_stop("controller start refused");
	}
	iwdg_start(watchdog_ms);
	for (;;) {
		tick_read(&st);
		now_ms = (uint32_t)((uint64_t)st.count * 1000u / tick_hz);
		if (st.count != last_count) { /* a stopped tick lets the watchdog bite */
			last_count = st.count;
			iwdg_kick();
		}
		if (app.can_on)
			can_poll(now_ms);
		app_background();
		if (swell_ctl_bootloader_requested(
			    &app_ctl)) { /* accepted by the core: force zeroed, heartbeat queued */
			if (!boot_armed) {
				boot_armed = 1;
				boot_at = st.count + BOOT_DRAIN_TICKS;
			} else if ((int32_t)(st.count - boot_at) >= 0)
				boot_request_reset();
		}
		idle_until_interrupt(st.count);
	}
}
