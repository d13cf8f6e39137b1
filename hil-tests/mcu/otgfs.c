/* The OTG_FS device-mode model (otgfs.h). Section numbers are RM0090's (rev. 19): 34.13 FIFO RAM
 * allocation, 34.15 interrupts, 34.16 registers, 34.17 programming model. */
#include "otgfs.h"

#include <stddef.h>
#include <string.h>

/* Register offsets (34.16.6 register map). */
enum {
	R_GOTGCTL = 0x000,
	R_GAHBCFG = 0x008,
	R_GUSBCFG = 0x00C,
	R_GRSTCTL = 0x010,
	R_GINTSTS = 0x014,
	R_GINTMSK = 0x018,
	R_GRXSTSR = 0x01C,
	R_GRXSTSP = 0x020,
	R_GRXFSIZ = 0x024,
	R_DIEPTXF0 = 0x028,
	R_HNPTXSTS = 0x02C,
	R_GCCFG = 0x038,
	R_CID = 0x03C,
	R_DIEPTXF1 = 0x104, /* .. DIEPTXF3 at 0x10C */
	R_DCFG = 0x800,
	R_DCTL = 0x804,
	R_DSTS = 0x808,
	R_DIEPMSK = 0x810,
	R_DOEPMSK = 0x814,
	R_DAINT = 0x818,
	R_DAINTMSK = 0x81C,
	R_DIEPEMPMSK = 0x834,
	R_DIEP0 = 0x900, /* DIEPCTL +0, DIEPINT +8, DIEPTSIZ +0x10, DTXFSTS +0x18; stride 0x20 */
	R_DOEP0 = 0xB00, /* DOEPCTL +0, DOEPINT +8, DOEPTSIZ +0x10 */
	R_PCGCCTL = 0xE00,
	R_FIFO0 = 0x1000,
	R_FIFO_END = 0x1000 + 0x1000 * OTGFS_EPS,
};

#define BIT(n) (1u << (n))

#define GAHBCFG_GINT BIT(0)
#define GAHBCFG_TXFELVL BIT(7)
#define GUSBCFG_FHMOD BIT(29)
#define GRSTCTL_CSRST BIT(0)
#define GRSTCTL_RXFFLSH BIT(4)
#define GRSTCTL_TXFFLSH BIT(5)
#define GRSTCTL_TXFNUM(v) (((v) >> 6) & 0x1Fu)
#define GRSTCTL_AHBIDL BIT(31)
#define GINT_CMOD BIT(0)
#define GINT_SOF BIT(3)
#define GINT_RXFLVL BIT(4)
#define GINT_GINAKEFF BIT(6)
#define GINT_GONAKEFF BIT(7)
#define GINT_ESUSP BIT(10)
#define GINT_USBSUSP BIT(11)
#define GINT_USBRST BIT(12)
#define GINT_ENUMDNE BIT(13)
#define GINT_IEPINT BIT(18)
#define GINT_OEPINT BIT(19)
/* rc_w1 bits: MMIS, SOF, ESUSP, USBSUSP, USBRST, ENUMDNE, ISOODRP, EOPF, IISOIXFR, IPXFR,
 * CIDSCHG, DISCINT, SRQINT, WKUPINT */
#define GINT_RC_W1 0xF030FC0Au
#define GCCFG_PWRDWN BIT(16)
#define GCCFG_VBUSBSEN BIT(19)
#define GCCFG_NOVBUSSENS BIT(21)
#define DCFG_DAD(v) (((v) >> 4) & 0x7Fu)
#define DSTS_SUSPSTS BIT(0)
#define DCTL_SDIS BIT(1)
#define DCTL_GINSTS BIT(2)
#define DCTL_GONSTS BIT(3)
#define DCTL_SGINAK BIT(7)
#define DCTL_CGINAK BIT(8)
#define DCTL_SGONAK BIT(9)
#define DCTL_CGONAK BIT(10)
#define PCGCCTL_STPPCLK BIT(0)

#define EPCTL_MPSIZ 0x7FFu
#define EPCTL_USBAEP BIT(15)
#define EPCTL_DPID BIT(16)
#define EPCTL_NAKSTS BIT(17)
#define EPCTL_EPTYP (3u << 18)
#define EPCTL_STALL BIT(21)
#define EPCTL_TXFNUM(v) (((v) >> 22) & 0xFu)
#define EPCTL_CNAK BIT(26)
#define EPCTL_SNAK BIT(27)
#define EPCTL_SD0PID BIT(28)
#define EPCTL_SD1PID BIT(29)
#define EPCTL_EPDIS BIT(30)
#define EPCTL_EPENA BIT(31)
/* What the application writes and reads back as written (the rest is the core's or write-only). */
#define DIEPCTL_RW (EPCTL_MPSIZ | EPCTL_USBAEP | EPCTL_EPTYP | EPCTL_STALL | (0xFu << 22))
#define DOEPCTL_RW (EPCTL_MPSIZ | EPCTL_USBAEP | EPCTL_EPTYP | BIT(20) | EPCTL_STALL)
#define EPINT_XFRC BIT(0)
#define EPINT_EPDISD BIT(1)
#define DOEPINT_STUP BIT(3)
#define DIEPINT_TXFE BIT(7)
#define TSIZ_PKTCNT_SHIFT 19

#define PKTSTS_OUT_DATA 2u
#define PKTSTS_OUT_DONE 3u
#define PKTSTS_SETUP_DONE 4u
#define PKTSTS_SETUP_DATA 6u

enum {
	BUS_DETACHED = 0,
	BUS_RESET,
	BUS_RUNNING
};

static void fault(struct otgfs *m, const char *what)
{
	if (!m->fault)
		m->fault = what;
	m->faults++;
}

/* ---- FIFO RAM layout (34.13) ---- */

static uint32_t tx_depth(const struct otgfs *m, unsigned f)
{
	uint32_t d = m->dieptxf[f] >> 16;

	return d > OTGFS_RAM_WORDS ? OTGFS_RAM_WORDS : d;
}

static uint32_t rx_depth(const struct otgfs *m)
{
	uint32_t d = m->grxfsiz & 0xFFFFu;

	return d > OTGFS_RAM_WORDS ? OTGFS_RAM_WORDS : d;
}

/* A transmit FIFO in use must lie in the RAM after the receive FIFO, at least 16 words deep, and
 * apart from the other transmit FIFOs in use (those of enabled or written endpoints). */
static void check_tx_layout(struct otgfs *m, unsigned f)
{
	uint32_t start = m->dieptxf[f] & 0xFFFFu, depth = m->dieptxf[f] >> 16;

	if (depth < 16u || start + depth > OTGFS_RAM_WORDS || start < (m->grxfsiz & 0xFFFFu))
		fault(m,
		      "a transmit FIFO in use lies outside the FIFO RAM, overlaps the receive FIFO or is under 16 "
		      "words");
	for (unsigned k = 0; k < OTGFS_EPS; k++) {
		uint32_t s2 = m->dieptxf[k] & 0xFFFFu, d2 = m->dieptxf[k] >> 16;

		if (k != f && m->tx[k].count && start < s2 + d2 && s2 < start + depth)
			fault(m, "two transmit FIFOs in use overlap");
	}
	if ((m->grxfsiz & 0xFFFFu) < 16u || (m->grxfsiz & 0xFFFFu) > 256u)
		fault(m, "the receive FIFO is outside 16..256 words");
}

static void tx_flush(struct otgfs *m, unsigned f)
{
	m->tx[f].head = 0;
	m->tx[f].count = 0;
}

static void rx_flush(struct otgfs *m)
{
	m->rx_head = 0;
	m->rx_count = 0;
	m->rx_data_left = 0;
}

static uint32_t rx_free(const struct otgfs *m)
{
	uint32_t d = rx_depth(m);

	return m->rx_count >= d ? 0 : d - m->rx_count;
}

static void rx_push(struct otgfs *m, uint32_t w)
{
	m->rx[(m->rx_head + m->rx_count) % OTGFS_RAM_WORDS] = w;
	m->rx_count++;
}

static uint32_t rx_pop(struct otgfs *m)
{
	uint32_t w;

	if (!m->rx_count) {
		fault(m, "read of an empty receive FIFO");
		return 0;
	}
	w = m->rx[m->rx_head];
	m->rx_head = (m->rx_head + 1) % OTGFS_RAM_WORDS;
	m->rx_count--;
	return w;
}

/* Push one receive FIFO entry: status word then the data words. Returns 0 when it does not fit. */
static int rx_entry(struct otgfs *m, unsigned ep, uint32_t pktsts, const uint8_t *d, uint32_t len, uint32_t dpid)
{
	uint32_t words = (len + 3) / 4;

	if (rx_free(m) < 1 + words)
		return 0;
	rx_push(m, ep | (len << 4) | (dpid << 15) | (pktsts << 17));
	for (uint32_t i = 0; i < len; i += 4) {
		uint32_t w = 0;

		for (uint32_t k = 0; k < 4 && i + k < len; k++)
			w |= (uint32_t)d[i + k] << (8 * k);
		rx_push(m, w);
	}
	return 1;
}

static unsigned in_fifo(const struct otgfs *m, unsigned ep)
{
	return ep == 0 ? 0 : EPCTL_TXFNUM(m->diepctl[ep]) % OTGFS_EPS;
}

static uint32_t tx_free(const struct otgfs *m, unsigned f)
{
	uint32_t d = tx_depth(m, f);

	return m->tx[f].count >= d ? 0 : d - m->tx[f].count;
}

/* ---- interrupts (34.15) ---- */

static int tx_empty_level(const struct otgfs *m, unsigned ep)
{
	unsigned f = in_fifo(m, ep);
	uint32_t d = tx_depth(m, f);

	if (m->gahbcfg & GAHBCFG_TXFELVL)
		return m->tx[f].count == 0;
	return m->tx[f].count <= d / 2;
}

static uint32_t diepint_read(const struct otgfs *m, unsigned ep)
{
	return m->diepint[ep] | (tx_empty_level(m, ep) ? DIEPINT_TXFE : 0);
}

static uint32_t daint(const struct otgfs *m)
{
	uint32_t v = 0;

	for (unsigned n = 0; n < OTGFS_EPS; n++) {
		uint32_t in = diepint_read(m, n) & (m->diepmsk & 0x7Bu);

		if ((m->diepempmsk & BIT(n)) && (diepint_read(m, n) & DIEPINT_TXFE) && (m->diepctl[n] & EPCTL_EPENA))
			in |= DIEPINT_TXFE;
		if (in)
			v |= BIT(n);
		if (m->doepint[n] & (m->doepmsk & 0x1Bu))
			v |= BIT(16 + n);
	}
	return v;
}

static uint32_t gintsts(const struct otgfs *m)
{
	uint32_t v = m->gintsts & GINT_RC_W1, d = daint(m) & m->daintmsk;

	if (m->gusbcfg & GUSBCFG_FHMOD)
		v |= GINT_CMOD;
	if (m->rx_count && !m->rx_data_left)
		v |= GINT_RXFLVL;
	if (m->dctl & DCTL_GINSTS)
		v |= GINT_GINAKEFF;
	if (m->dctl & DCTL_GONSTS)
		v |= GINT_GONAKEFF;
	if (d & 0xFFFFu)
		v |= GINT_IEPINT;
	if (d >> 16)
		v |= GINT_OEPINT;
	return v;
}

int otgfs_irq(const struct otgfs *m)
{
	return m->clock_on && (m->gahbcfg & GAHBCFG_GINT) && (gintsts(m) & m->gintmsk);
}

/* ---- the bus ---- */

int otgfs_host_attached(const struct otgfs *m)
{
	int vbus = (m->gccfg & GCCFG_NOVBUSSENS) || ((m->gccfg & GCCFG_VBUSBSEN) && m->vbus);

	return m->clock_on && !(m->gusbcfg & GUSBCFG_FHMOD) && (m->gccfg & GCCFG_PWRDWN) && vbus &&
		!(m->pcgcctl & PCGCCTL_STPPCLK) && !(m->dctl & DCTL_SDIS);
}

static void check_attach(struct otgfs *m)
{
	if (!otgfs_host_attached(m)) {
		m->bus = BUS_DETACHED;
		/* off the bus: no suspend; the idle time of an unplugged cable counts from the attach */
		m->suspend_stage = 0;
		m->idle_since = m->now;
	}
}

/* The cable is out and the device's pull-up on: the lines idle (J), no SOF, no token. RM0090 34.6
 * ("Suspended state"): after 3 ms of idleness the core raises the early suspend (GINTSTS.ESUSP),
 * confirmed 3 ms later by the suspend (USBSUSP), and sets DSTS.SUSPSTS. The next stage's time. */
static uint64_t suspend_due(const struct otgfs *m)
{
	return m->idle_since + m->hz * OTGFS_SUSPEND_MS / 1000u * (m->suspend_stage + 1u);
}

static int suspend_counting(const struct otgfs *m)
{
	return m->cable_out && m->suspend_stage < 2 && m->bus == BUS_DETACHED && otgfs_host_attached(m);
}

void otgfs_advance(struct otgfs *m, uint64_t now)
{
	if (now < m->now)
		now = m->now; /* time never runs backwards */
	m->now = now;
	check_attach(m);
	while (suspend_counting(m) && now >= suspend_due(m)) {
		if (m->suspend_stage++ == 0) {
			m->gintsts |= GINT_ESUSP;
		} else {
			m->gintsts |= GINT_USBSUSP;
			m->suspend_at = m->idle_since + 2u * (m->hz * OTGFS_SUSPEND_MS / 1000u);
			m->stats.suspends++;
		}
	}
	if (m->bus == BUS_RESET && now >= m->reset_end) {
		/* 34.17.5 "Endpoint initialization on enumeration completion": full speed, EP0 64 bytes */
		m->bus = BUS_RUNNING;
		m->gintsts |= GINT_ENUMDNE;
		m->sof_origin = m->reset_end;
		m->last_frame = 0;
		m->gintsts |= GINT_SOF;
	}
	if (m->bus == BUS_RUNNING) {
		uint64_t frame = (now - m->sof_origin) / (m->hz / 1000u);

		if (frame != m->last_frame) {
			m->last_frame = frame;
			m->gintsts |= GINT_SOF;
		}
	}
}

uint64_t otgfs_next_event_ns(const struct otgfs *m)
{
	if (suspend_counting(m))
		return suspend_due(m);
	if (m->bus == BUS_RESET)
		return m->reset_end;
	if (m->bus == BUS_RUNNING && (m->gintmsk & GINT_SOF) && !(m->gintsts & GINT_SOF))
		return m->sof_origin + (m->last_frame + 1) * (m->hz / 1000u);
	return OTGFS_NO_EVENT;
}

int otgfs_host_reset(struct otgfs *m, uint64_t now)
{
	otgfs_advance(m, now);
	if (!otgfs_host_attached(m))
		return -1;
	/* A host that drives a reset is on the cable. The reset is activity on the lines: a suspended
	 * core leaves the suspend (DSTS.SUSPSTS clears; WKUPINT is for a host's resume, K state, only). */
	m->cable_out = 0;
	m->suspend_stage = 0;
	/* The core sees the reset (USBRST) and deactivates every endpoint but 0 (DIEPCTLx/DOEPCTLx
	 * USBAEP, 34.16.4); the application's part is 34.17.5 "Endpoint initialization on USB reset". */
	m->bus = BUS_RESET;
	m->reset_end = m->now + m->hz * OTGFS_RESET_MS / 1000u;
	m->gintsts |= GINT_USBRST;
	for (unsigned n = 1; n < OTGFS_EPS; n++) {
		m->diepctl[n] &= ~EPCTL_USBAEP;
		m->doepctl[n] &= ~EPCTL_USBAEP;
	}
	m->old_addr_valid = 0;
	m->setup_pending = 0;
	m->stats.resets++;
	return 0;
}

int otgfs_host_running(const struct otgfs *m)
{
	return m->bus == BUS_RUNNING && otgfs_host_attached(m);
}

void otgfs_host_unplug(struct otgfs *m, uint64_t now)
{
	otgfs_advance(m, now);
	if (m->cable_out)
		return;
	m->cable_out = 1;
	m->stats.unplugs++;
	/* no host: no reset, no frames, no token answered; the lines idle from now (or from the attach) */
	m->bus = BUS_DETACHED;
	m->idle_since = now;
	m->suspend_stage = 0;
}

int otgfs_host_plugged(const struct otgfs *m)
{
	return !m->cable_out;
}

uint8_t otgfs_host_address(const struct otgfs *m)
{
	return (uint8_t)DCFG_DAD(m->dcfg);
}

/* The control endpoint's packet size from DIEPCTL0.MPSIZ (34.16.4: 0 64, 1 32, 2 16, 3 8 bytes). */
static uint32_t mps(const struct otgfs *m, unsigned ep, int in)
{
	static const uint32_t ep0[4] = { 64, 32, 16, 8 };

	if (ep == 0)
		return ep0[m->diepctl[0] & 3u];
	return (in ? m->diepctl[ep] : m->doepctl[ep]) & EPCTL_MPSIZ;
}

/* Does the device answer a token to addr on ep? The old address still answers on EP0 until the
 * status stage of SET_ADDRESS is done (the application writes DAD before that stage). */
static int addressed(const struct otgfs *m, uint8_t addr, unsigned ep)
{
	if (!otgfs_host_running(m) || ep >= OTGFS_EPS)
		return 0;
	if (addr == DCFG_DAD(m->dcfg))
		return 1;
	return ep == 0 && m->old_addr_valid && addr == m->old_addr;
}

static enum otgfs_resp count(struct otgfs *m, enum otgfs_resp r)
{
	switch (r) {
	case OTGFS_NAK:
		m->stats.naks++;
		break;
	case OTGFS_STALL:
		m->stats.stalls++;
		break;
	case OTGFS_NORESP:
		m->stats.noresps++;
		break;
	default:
		break;
	}
	return r;
}

/* The first IN or OUT token after a SETUP pushes the "SETUP stage done" entry (34.17.6). */
static void setup_stage_done(struct otgfs *m)
{
	if (m->setup_pending && rx_entry(m, 0, PKTSTS_SETUP_DONE, NULL, 0, 0))
		m->setup_pending = 0;
}

enum otgfs_resp otgfs_host_setup(struct otgfs *m, uint64_t now, uint8_t addr, const uint8_t setup[8])
{
	uint32_t stupcnt;

	otgfs_advance(m, now);
	if (!addressed(m, addr, 0))
		return count(m, OTGFS_NORESP);
	setup_stage_done(m); /* back-to-back SETUPs: the earlier one's stage is done */
	/* SETUP is always ACKed when it fits (34.16.4 DOEPCTL NAKSTS: "irrespective of this bit"). */
	if (!rx_entry(m, 0, PKTSTS_SETUP_DATA, setup, 8, 0))
		return count(m, OTGFS_NORESP);
	m->setup_pending = 1;
	stupcnt = (m->doeptsiz[0] >> 29) & 3u;
	if (stupcnt)
		m->doeptsiz[0] = (m->doeptsiz[0] & ~(3u << 29)) | ((stupcnt - 1) << 29);
	/* A SETUP clears a STALL of the control endpoint (34.16.4 DIEPCTL0/DOEPCTL0 STALL) and sets
	 * both directions' data toggle for the next stage to DATA1. */
	m->diepctl[0] = (m->diepctl[0] & ~EPCTL_STALL) | EPCTL_DPID;
	m->doepctl[0] = (m->doepctl[0] & ~EPCTL_STALL) | EPCTL_DPID;
	m->stats.setups++;
	return OTGFS_ACK;
}

enum otgfs_resp otgfs_host_out(struct otgfs *m, uint64_t now, uint8_t addr, uint8_t ep, const uint8_t *data,
			       uint32_t len)
{
	uint32_t *ctl, *tsiz, pktcnt, xfrsiz, pktcnt_mask;

	otgfs_advance(m, now);
	if (!addressed(m, addr, ep) || (ep && !(m->doepctl[ep] & EPCTL_USBAEP)) || len > mps(m, ep, 0))
		return count(m, OTGFS_NORESP);
	if (ep == 0)
		setup_stage_done(m);
	ctl = &m->doepctl[ep];
	tsiz = &m->doeptsiz[ep];
	if (*ctl & EPCTL_STALL)
		return count(m, OTGFS_STALL);
	if (!(*ctl & EPCTL_EPENA) || (*ctl & EPCTL_NAKSTS) || (m->dctl & DCTL_GONSTS))
		return count(m, OTGFS_NAK);
	/* the data, then (end of transfer) the "OUT transfer completed" entry: both must fit */
	if (rx_free(m) < 2 + (len + 3) / 4)
		return count(m, OTGFS_NAK);
	rx_entry(m, ep, PKTSTS_OUT_DATA, data, len, (*ctl & EPCTL_DPID) ? 2u : 0u);
	*ctl ^= EPCTL_DPID;
	pktcnt_mask = ep == 0 ? 1u : 0x3FFu;
	pktcnt = (*tsiz >> TSIZ_PKTCNT_SHIFT) & pktcnt_mask;
	xfrsiz = *tsiz & (ep == 0 ? 0x7Fu : 0x7FFFFu);
	xfrsiz = len > xfrsiz ? 0 : xfrsiz - len;
	pktcnt = pktcnt ? pktcnt - 1 : 0;
	*tsiz = (*tsiz & ~((pktcnt_mask << TSIZ_PKTCNT_SHIFT) | (ep == 0 ? 0x7Fu : 0x7FFFFu))) |
		(pktcnt << TSIZ_PKTCNT_SHIFT) | xfrsiz;
	if (pktcnt == 0 || len < mps(m, ep, 0)) {
		/* transfer complete: the endpoint disables itself; XFRC when the entry is popped */
		rx_entry(m, ep, PKTSTS_OUT_DONE, NULL, 0, 0);
		*ctl &= ~EPCTL_EPENA;
	}
	m->stats.out_acks++;
	return OTGFS_ACK;
}

enum otgfs_resp otgfs_host_in(struct otgfs *m, uint64_t now, uint8_t addr, uint8_t ep, uint8_t *buf, uint32_t cap,
			      uint32_t *len)
{
	uint32_t *ctl, *tsiz, pktcnt, xfrsiz, pktcnt_mask, xfr_mask, p, words;
	struct otgfs_txfifo *f;

	*len = 0;
	otgfs_advance(m, now);
	if (!addressed(m, addr, ep) || (ep && !(m->diepctl[ep] & EPCTL_USBAEP)))
		return count(m, OTGFS_NORESP);
	if (ep == 0)
		setup_stage_done(m);
	ctl = &m->diepctl[ep];
	tsiz = &m->dieptsiz[ep];
	if (*ctl & EPCTL_STALL)
		return count(m, OTGFS_STALL);
	if (!(*ctl & EPCTL_EPENA) || (*ctl & EPCTL_NAKSTS) || (m->dctl & DCTL_GINSTS))
		return count(m, OTGFS_NAK);
	pktcnt_mask = ep == 0 ? 3u : 0x3FFu;
	xfr_mask = ep == 0 ? 0x7Fu : 0x7FFFFu;
	pktcnt = (*tsiz >> TSIZ_PKTCNT_SHIFT) & pktcnt_mask;
	xfrsiz = *tsiz & xfr_mask;
	if (!pktcnt) {
		fault(m, "an IN endpoint is enabled with a packet count of 0");
		return count(m, OTGFS_NAK);
	}
	p = xfrsiz < mps(m, ep, 1) ? xfrsiz : mps(m, ep, 1);
	words = (p + 3) / 4;
	f = &m->tx[in_fifo(m, ep)];
	if (f->count < words)
		return count(m, OTGFS_NAK); /* the packet is not all in the FIFO yet */
	if (p > cap) {
		fault(m, "babble: an IN packet longer than the host's buffer");
		return count(m, OTGFS_NORESP);
	}
	for (uint32_t i = 0; i < words; i++) {
		uint32_t w = f->words[f->head];

		f->head = (f->head + 1) % OTGFS_RAM_WORDS;
		f->count--;
		for (uint32_t k = 0; k < 4 && i * 4 + k < p; k++)
			buf[i * 4 + k] = (uint8_t)(w >> (8 * k));
	}
	*len = p;
	*ctl ^= EPCTL_DPID;
	pktcnt--;
	xfrsiz -= p;
	*tsiz = (*tsiz & ~((pktcnt_mask << TSIZ_PKTCNT_SHIFT) | xfr_mask)) | (pktcnt << TSIZ_PKTCNT_SHIFT) | xfrsiz;
	if (pktcnt == 0) {
		*ctl &= ~EPCTL_EPENA;
		m->diepint[ep] |= EPINT_XFRC;
		if (f->count)
			fault(m, "a transmit FIFO holds data after its endpoint's transfer completed");
	}
	if (ep == 0 && m->old_addr_valid)
		m->old_addr_valid = 0; /* the status stage of SET_ADDRESS is done: the new address only */
	m->stats.in_acks++;
	return OTGFS_ACK;
}

/* ---- registers ---- */

void otgfs_init(struct otgfs *m, uint64_t time_hz)
{
	memset(m, 0, sizeof(*m));
	m->hz = time_hz < 1000u ? 1000u : time_hz;
	m->gotgctl = BIT(16); /* CIDSTS: B-device (ID pin floating) */
	m->gusbcfg = 0x00000A00u;
	m->gintsts = 0;
	m->grxfsiz = 0x200u;
	m->dieptxf[0] = 0x00000200u;
	for (unsigned n = 1; n < OTGFS_EPS; n++)
		m->dieptxf[n] = 0x02000400u;
	m->dcfg = 0x02200000u;
	m->diepctl[0] = EPCTL_USBAEP;
	m->doepctl[0] = EPCTL_USBAEP;
	m->other[0x100 / 4] = 0x02000600u; /* HPTXFSIZ */
	m->clock_on = 1;
	m->vbus = 1;
}

void otgfs_set_clock(struct otgfs *m, int on)
{
	m->clock_on = on != 0;
	check_attach(m);
}

void otgfs_set_vbus(struct otgfs *m, int present)
{
	m->vbus = present != 0;
	check_attach(m);
}

const char *otgfs_fault(const struct otgfs *m)
{
	return m->fault;
}

uint32_t otgfs_fault_count(const struct otgfs *m)
{
	return m->faults;
}

/* Core soft reset (34.16.2 GRSTCTL CSRST): the state machines, the FIFOs, the interrupts and the
 * endpoints go back to reset; the configuration (GAHBCFG, GUSBCFG, GCCFG, FIFO sizes, DCFG,
 * DCTL, PCGCCTL) stays. The device leaves the bus until the host resets it again. */
static void core_reset(struct otgfs *m)
{
	for (unsigned n = 0; n < OTGFS_EPS; n++) {
		tx_flush(m, n);
		m->diepctl[n] = m->doepctl[n] = n ? 0 : EPCTL_USBAEP;
		m->diepint[n] = m->doepint[n] = 0;
		m->dieptsiz[n] = m->doeptsiz[n] = 0;
	}
	rx_flush(m);
	m->gintsts = 0;
	m->dctl &= ~(DCTL_GINSTS | DCTL_GONSTS);
	m->setup_pending = 0;
	m->old_addr_valid = 0;
	m->bus = BUS_DETACHED;
}

static uint32_t grstctl_read(struct otgfs *m)
{
	uint32_t busy = m->grstctl & (GRSTCTL_CSRST | GRSTCTL_RXFFLSH | GRSTCTL_TXFFLSH);

	if (busy && ++m->grstctl_reads >= 2) {
		if (busy & GRSTCTL_CSRST)
			core_reset(m);
		if (busy & GRSTCTL_RXFFLSH)
			rx_flush(m);
		if (busy & GRSTCTL_TXFFLSH) {
			uint32_t f = GRSTCTL_TXFNUM(m->grstctl);

			for (unsigned n = 0; n < OTGFS_EPS; n++)
				if (f == 0x10u || f == n)
					tx_flush(m, n);
		}
		m->grstctl &= ~busy;
	}
	return m->grstctl | GRSTCTL_AHBIDL;
}

static uint32_t fifo_read(struct otgfs *m)
{
	if (!m->rx_data_left) {
		fault(m, "a receive FIFO data read with no packet data left (pop GRXSTSP first)");
		return 0;
	}
	m->rx_data_left--;
	return rx_pop(m);
}

/* GRXSTSP: pop the top status entry; its data words follow on the FIFO window. Popping an OUT
 * transfer completed / SETUP stage done entry raises XFRC / STUP (34.17.6). */
static uint32_t grxstsp(struct otgfs *m)
{
	uint32_t s, ep, pkt;

	if (m->rx_data_left) {
		fault(m, "GRXSTSP popped while the previous packet's data was unread");
		while (m->rx_data_left) {
			(void)rx_pop(m);
			m->rx_data_left--;
		}
	}
	if (!m->rx_count) {
		fault(m, "GRXSTSP read with an empty receive FIFO");
		return 0;
	}
	s = rx_pop(m);
	ep = s & 0xFu;
	pkt = (s >> 17) & 0xFu;
	m->rx_data_left = (((s >> 4) & 0x7FFu) + 3) / 4;
	if (pkt == PKTSTS_OUT_DONE)
		m->doepint[ep] |= EPINT_XFRC;
	else if (pkt == PKTSTS_SETUP_DONE)
		m->doepint[ep] |= DOEPINT_STUP;
	return s;
}

static uint32_t dsts(const struct otgfs *m)
{
	uint32_t v = 0;

	if (m->bus == BUS_RUNNING)
		v |= (3u << 1) | ((uint32_t)(m->last_frame & 0x3FFFu) << 8); /* ENUMSPD full speed 48 MHz */
	if (m->suspend_stage == 2)
		v |= DSTS_SUSPSTS;
	return v;
}

static uint32_t dtxfsts(const struct otgfs *m, unsigned ep)
{
	return tx_free(m, in_fifo(m, ep));
}

uint32_t otgfs_read(struct otgfs *m, uint32_t off, uint64_t now)
{
	otgfs_advance(m, now);
	if (!m->clock_on)
		return 0;
	off &= ~3u;
	if (off >= R_FIFO0 && off < R_FIFO_END)
		return fifo_read(m); /* every window pops the shared receive FIFO */
	if (off >= R_DIEP0 && off < R_DIEP0 + 0x20u * OTGFS_EPS) {
		unsigned n = (off - R_DIEP0) / 0x20u;

		switch (off & 0x1Fu) {
		case 0x00:
			return m->diepctl[n];
		case 0x08:
			return diepint_read(m, n);
		case 0x10:
			return m->dieptsiz[n];
		case 0x18:
			return dtxfsts(m, n);
		default:
			return 0;
		}
	}
	if (off >= R_DOEP0 && off < R_DOEP0 + 0x20u * OTGFS_EPS) {
		unsigned n = (off - R_DOEP0) / 0x20u;

		switch (off & 0x1Fu) {
		case 0x00:
			return m->doepctl[n] | (n == 0 ? (m->diepctl[0] & 3u) : 0);
		case 0x08:
			return m->doepint[n];
		case 0x10:
			return m->doeptsiz[n];
		default:
			return 0;
		}
	}
	switch (off) {
	case R_GOTGCTL:
		return m->gotgctl;
	case R_GAHBCFG:
		return m->gahbcfg;
	case R_GUSBCFG:
		return m->gusbcfg;
	case R_GRSTCTL:
		return grstctl_read(m);
	case R_GINTSTS:
		return gintsts(m);
	case R_GINTMSK:
		return m->gintmsk;
	case R_GRXSTSR:
		return m->rx_count && !m->rx_data_left ? m->rx[m->rx_head] : 0;
	case R_GRXSTSP:
		return grxstsp(m);
	case R_GRXFSIZ:
		return m->grxfsiz;
	case R_DIEPTXF0:
		return m->dieptxf[0];
	case R_HNPTXSTS:
		return 0x00080200u;
	case R_GCCFG:
		return m->gccfg;
	case R_CID:
		return 0x00001200u;
	case R_DIEPTXF1:
	case R_DIEPTXF1 + 4:
	case R_DIEPTXF1 + 8:
		return m->dieptxf[1 + (off - R_DIEPTXF1) / 4];
	case R_DCFG:
		return m->dcfg;
	case R_DCTL:
		return m->dctl;
	case R_DSTS:
		return dsts(m);
	case R_DIEPMSK:
		return m->diepmsk;
	case R_DOEPMSK:
		return m->doepmsk;
	case R_DAINT:
		return daint(m);
	case R_DAINTMSK:
		return m->daintmsk;
	case R_DIEPEMPMSK:
		return m->diepempmsk;
	case R_PCGCCTL:
		return m->pcgcctl;
	default:
		return off < 0x1000u ? m->other[off / 4] : 0;
	}
}

static void fifo_write(struct otgfs *m, unsigned ep, uint32_t v)
{
	unsigned fi = in_fifo(m, ep);
	struct otgfs_txfifo *f = &m->tx[fi];

	if (!f->count)
		check_tx_layout(m, fi);
	if (!tx_free(m, fi)) {
		fault(m, "a transmit FIFO overflowed (write with no free word: DTXFSTS)");
		return;
	}
	f->words[(f->head + f->count) % OTGFS_RAM_WORDS] = v;
	f->count++;
}

/* DIEPCTLx/DOEPCTLx write (34.16.4): the read-write fields, the set/clear commands, EPENA and
 * EPDIS that only the application sets (the core clears them). */
static void epctl_write(struct otgfs *m, uint32_t *ctl, uint32_t *intr, uint32_t v, unsigned ep, int in)
{
	uint32_t rw = in ? DIEPCTL_RW : DOEPCTL_RW;

	if (ep == 0) /* EP0: MPSIZ (IN only), STALL and the commands; the type and USBAEP are fixed */
		rw = in ? (3u | EPCTL_STALL) : EPCTL_STALL;
	if (ep == 0 && !(v & EPCTL_STALL))
		v |= *ctl & EPCTL_STALL; /* EP0's STALL: set by the application, cleared by a SETUP */
	*ctl = (*ctl & ~rw) | (v & rw);
	if (v & EPCTL_SNAK)
		*ctl |= EPCTL_NAKSTS;
	if (v & EPCTL_CNAK)
		*ctl &= ~EPCTL_NAKSTS;
	if (v & EPCTL_SD0PID)
		*ctl &= ~EPCTL_DPID;
	if (v & EPCTL_SD1PID)
		*ctl |= EPCTL_DPID;
	if ((v & EPCTL_EPDIS) && (*ctl & EPCTL_EPENA)) {
		*ctl &= ~EPCTL_EPENA;
		*intr |= EPINT_EPDISD;
	} else if (v & EPCTL_EPENA) {
		*ctl |= EPCTL_EPENA;
		if (in)
			check_tx_layout(m, in_fifo(m, ep));
	}
}

void otgfs_write(struct otgfs *m, uint32_t off, uint32_t v, uint64_t now)
{
	otgfs_advance(m, now);
	if (!m->clock_on)
		return;
	off &= ~3u;
	if (off >= R_FIFO0 && off < R_FIFO_END) {
		fifo_write(m, (off - R_FIFO0) / 0x1000u, v);
		return;
	}
	if (off >= R_DIEP0 && off < R_DIEP0 + 0x20u * OTGFS_EPS) {
		unsigned n = (off - R_DIEP0) / 0x20u;

		if ((off & 0x1Fu) == 0x00)
			epctl_write(m, &m->diepctl[n], &m->diepint[n], v, n, 1);
		else if ((off & 0x1Fu) == 0x08)
			m->diepint[n] &= ~(v & ~DIEPINT_TXFE);
		else if ((off & 0x1Fu) == 0x10)
			m->dieptsiz[n] = v & (n == 0 ? ((3u << 19) | 0x7Fu) : 0x7FFFFFFFu);
		return;
	}
	if (off >= R_DOEP0 && off < R_DOEP0 + 0x20u * OTGFS_EPS) {
		unsigned n = (off - R_DOEP0) / 0x20u;

		if ((off & 0x1Fu) == 0x00)
			epctl_write(m, &m->doepctl[n], &m->doepint[n], v, n, 0);
		else if ((off & 0x1Fu) == 0x08)
			m->doepint[n] &= ~v;
		else if ((off & 0x1Fu) == 0x10)
			m->doeptsiz[n] = v & (n == 0 ? ((3u << 29) | (1u << 19) | 0x7Fu) : 0x7FFFFFFFu);
		return;
	}
	switch (off) {
	case R_GOTGCTL:
		m->gotgctl = (m->gotgctl & ~0xF03u) | (v & 0xF03u);
		break;
	case R_GAHBCFG:
		m->gahbcfg = v & 0x181u;
		break;
	case R_GUSBCFG:
		m->gusbcfg = v | BIT(6); /* PHYSEL: always the full-speed transceiver */
		break;
	case R_GRSTCTL:
		m->grstctl = v & (GRSTCTL_CSRST | BIT(1) | BIT(2) | GRSTCTL_RXFFLSH | GRSTCTL_TXFFLSH | (0x1Fu << 6));
		m->grstctl_reads = 0;
		break;
	case R_GINTSTS:
		if (v & m->gintsts & GINT_USBSUSP) { /* the application acknowledged the suspend */
			m->stats.suspends_seen++;
			m->suspend_seen_at = m->now;
		}
		m->gintsts &= ~(v & GINT_RC_W1);
		break;
	case R_GINTMSK:
		m->gintmsk = v;
		break;
	case R_GRXFSIZ:
		m->grxfsiz = v & 0xFFFFu;
		break;
	case R_DIEPTXF0:
		m->dieptxf[0] = v;
		break;
	case R_GCCFG:
		m->gccfg = v & 0x003F0000u;
		break;
	case R_DIEPTXF1:
	case R_DIEPTXF1 + 4:
	case R_DIEPTXF1 + 8:
		m->dieptxf[1 + (off - R_DIEPTXF1) / 4] = v;
		break;
	case R_DCFG:
		if (DCFG_DAD(v) != DCFG_DAD(m->dcfg)) {
			m->old_addr = (uint8_t)DCFG_DAD(m->dcfg);
			m->old_addr_valid = 1;
		}
		m->dcfg = v;
		break;
	case R_DCTL:
		m->dctl = (m->dctl & (DCTL_GINSTS | DCTL_GONSTS)) | (v & 0x873u);
		if (v & DCTL_SGINAK)
			m->dctl |= DCTL_GINSTS;
		if (v & DCTL_CGINAK)
			m->dctl &= ~DCTL_GINSTS;
		if (v & DCTL_SGONAK)
			m->dctl |= DCTL_GONSTS;
		if (v & DCTL_CGONAK)
			m->dctl &= ~DCTL_GONSTS;
		break;
	case R_DIEPMSK:
		m->diepmsk = v;
		break;
	case R_DOEPMSK:
		m->doepmsk = v;
		break;
	case R_DAINTMSK:
		m->daintmsk = v;
		break;
	case R_DIEPEMPMSK:
		m->diepempmsk = v & 0xFFFFu;
		break;
	case R_PCGCCTL:
		m->pcgcctl = v & 0x13u;
		break;
	case R_GRXSTSR:
	case R_GRXSTSP:
	case R_HNPTXSTS:
	case R_CID:
	case R_DSTS:
	case R_DAINT:
		break; /* read-only */
	default:
		if (off < 0x1000u)
			m->other[off / 4] = v;
		break;
	}
	check_attach(m);
}
