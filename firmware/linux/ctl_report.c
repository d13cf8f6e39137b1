/* swell-ctl's report at exit; see ctl_main.h. */
#include <arpa/inet.h>
#include <math.h>
#include <stdio.h>

#include "ctl_main.h"

static double jitter_pct(const struct jitter *j, double p)
{
	uint64_t want = (uint64_t)ceil(p * (double)j->n), seen = 0;
	int k;

	for (k = 0; k <= HIST_US; k++) {
		seen += j->hist[k];
		if (seen >= want && want > 0)
			return k;
	}
	return 0;
}

/* A CAN or USB link's own counters (none for UDP and hm:). */
static void report_link(const char *what, const struct ctl_link *l)
{
	const struct swell_can_health *h = &l->can;
	const struct swell_usb_ffs_stats *u = l->kind == CTL_LINK_USB ? swell_link_ffs_stats(l->usb) : NULL;

	if (l->kind == CTL_LINK_CAN)
		printf("  %s CAN  %s: %s, %u error frames: %u bus-off, %u restarts, %u error-passive, %u warnings, "
		       "%u back to active; %u no-ACK, %u protocol, %u overflows, %u TX timeouts; counters tx %u rx %u; "
		       "%u frames dropped while bus-off, interface down %u times\n",
		       what, l->name, swell_can_state_name(h->state), h->error_frames, h->bus_offs, h->restarts,
		       h->passives, h->warnings, h->actives, h->no_ack, h->prot, h->overflows, h->tx_timeouts,
		       h->tx_err, h->rx_err, h->dropped_off, h->downs);
	if (u)
		printf("  %s USB  %s: %u parameter answers held for a busy IN queue, %u dropped; %u IN writes "
		       "refused (all %d slots in flight)\n",
		       what, l->name, l->answers_held, l->answers_dropped, u->tx_busy_drops, SWELL_USB_FFS_TX_SLOTS);
}

/* "ADDR:PORT" of a, "(fixed)" after a configured one, or "none yet". */
const char *addr_str(const struct sockaddr_in *a, int have, int fixed, char *buf, size_t len)
{
	char ip[INET_ADDRSTRLEN] = "?";

	if (!have)
		return "none yet";
	inet_ntop(AF_INET, &a->sin_addr, ip, sizeof(ip));
	snprintf(buf, len, "%s:%u%s", ip, ntohs(a->sin_port), fixed ? " (fixed)" : "");
	return buf;
}

void report(const struct opts *o, const struct port *p, const struct jitter *jit, uint64_t ticks, double ran_s,
	    int32_t peak_h)
{
	char abuf[48];

	printf("swell-ctl report\n");
	printf("  firmware        %u.%u.%u\n", o->cfg.fw_version[0], o->cfg.fw_version[1], o->cfg.fw_version[2]);
	printf("  ran             %.3f s, %llu ticks at %u Hz, %u solver steps at %u Hz\n", ran_s,
	       (unsigned long long)ticks, o->cfg.tick_hz, p->c.n.solver_steps, o->cfg.solver_hz);
	printf("  state           %s (last error: %s), faults %u\n", swell_ctl_state_name(p->c.state),
	       swell_err_str(p->c.last_err), p->c.n.faults);
	if (p->c.n.faults)
		printf("  FAULTED         %u times in this run (zero force while faulted; last error: %s; device "
		       "silence limit %u ticks = %.1f ms)\n",
		       p->c.n.faults, swell_err_str(p->c.last_err), swell_ctl_silent_limit(&p->c),
		       swell_ctl_silent_limit(&p->c) * 1e3 / o->cfg.tick_hz);
	/* a fault after the device's last sample is the device going away (the end of a bench run
	 * whose device exits first), not the loop's */
	if (p->c.n.faults && p->fault_sample_ns)
		printf("  last fault      began %.1f ms after the device's sample before it; the device %s\n",
		       (p->fault_ns - p->fault_sample_ns) / 1e6,
		       p->sample_ns > p->fault_sample_ns ? "sent samples again after it" : "sent nothing after it");
	if (!o->device_clock)
		printf("  tick jitter     p50 %.0f us, p99 %.0f us, max %.0f us (lateness of the wake-up)\n",
		       jitter_pct(jit, 0.5), jitter_pct(jit, 0.99), jit->max_ns / 1e3);
	printf("  overruns        %u\n", p->c.n.overruns);
	printf("  work            worst tick %u cell-operations (a whole step: %u)\n", p->c.n.work_max,
	       6u * o->cfg.nx * o->cfg.ny);
	printf("  device link     %s: %u frames in, %u out, %u bad, %u send errors, %u samples lost, %u resyncs, %u "
	       "of other nodes\n",
	       p->dev.name, p->dev.frames_rx, p->dev.frames_tx, swell_proto_rejected_total(&p->dev.st),
	       p->dev.tx_errors, p->c.n.dev_lost, p->c.dev_seq.resyncs, p->dev.foreign);
	if (p->dev.kind == CTL_LINK_UDP)
		printf("  device peer     %s; %u datagrams of other senders dropped; device taken %u times, "
		       "let go %u times (declared lost)\n",
		       addr_str(&p->dev.peers.peer, p->dev.peers.have_peer, p->dev.peers.peer_fixed, abuf,
				sizeof(abuf)),
		       p->dev.peers.others, p->dev.peers.peers_taken, p->releases);
	printf("  device starved  %u times (nothing reached the device in %u sends in a row)\n", p->starved,
	       o->cfg.silent_ticks);
	if (p->have_host)
		printf("  host link       %s: %u frames in, %u out, %u bad, %u not sent (no reader or busy); "
		       "%u height quads (%u refreshes), %u dropped from the queue\n",
		       p->host.name, p->host.frames_rx, p->host.frames_tx, swell_proto_rejected_total(&p->host.st),
		       p->host.tx_errors, p->c.n.quads_sent, p->c.n.quads_refreshed, p->c.q[SWELL_LINK_HOST].dropped);
	if (p->have_host && p->host.kind == CTL_LINK_UDP)
		printf("  host clients    on %s: %u admitted, %u dropped after %u ms of silence, %u now (at most %u); "
		       "%u packets of senders refused (table full)\n",
		       addr_str(&p->host.local, 1, 0, abuf, sizeof(abuf)), p->host.peers.clients_admitted,
		       p->host.peers.clients_silent, SWELL_UDP_CLIENT_SILENT_MS, swell_peers_clients(&p->host.peers),
		       SWELL_PEERS_CLIENTS, p->host.peers.clients_refused);
	if (p->dev.kind == CTL_LINK_HM) {
		hm_client_report(&p->dev.hm, stdout);
		hm_fx_report(&p->dev.hmfx, stdout);
	}
	report_link("device", &p->dev);
	if (p->have_host)
		report_link("host  ", &p->host);
	printf("  parameters      %u set, %u refused\n", p->c.n.params_set, p->c.n.params_refused);
	printf("  waves           largest |h| %.3f mm (sampled once a second), %u solver saturations "
	       "(row segments clamped)\n",
	       peak_h / (double)SWELL_H_ONE_MM, p->c.wave.saturations);
	printf("  final force     %+.3f N (zero sent on exit)\n", p->c.force_dev_uN[2] / 1e6);
	{
		struct swell_energy_account e;

		(void)swell_ctl_energy(&p->c, &e);
		/* docs/energy.md: the last run's account at the controller's port */
		printf("  energy          created %.3f mJ; W %.3f mJ, S - S(0) %.3f mJ (water %.3f mJ), D %.3f mJ "
		       "over %u ticks of the last run\n",
		       e.created_uJ / 1e3, e.work_uJ / 1e3, e.stored_uJ / 1e3, e.water_uJ / 1e3, e.balance_uJ / 1e3,
		       e.ticks);
		printf("  passivity       %s: damping on %u ticks, %.3f mJ taken out\n",
		       p->c.cfg.passivity ? "on" : "off (observing only)", e.controller_ticks, e.damped_uJ / 1e3);
	}
}
