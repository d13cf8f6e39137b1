/* STM32F405 bxCAN model (RM0090 section 32); the interface and what is modelled: bxcan.h. */
#include "bxcan.h"

#include <stddef.h>
#include <string.h>

enum {
	MODE_SLEEP,
	MODE_INIT,
	MODE_NORMAL
};
enum {
	OUT_OK,
	OUT_ACK_ERR,
	OUT_BIT_ERR,
	OUT_ARB_LOST
};

#define NONE UINT64_MAX
#define MCR_RW                                                                                                  \
	(BXCAN_MCR_INRQ | BXCAN_MCR_SLEEP | BXCAN_MCR_TXFP | BXCAN_MCR_RFLM | BXCAN_MCR_NART | BXCAN_MCR_AWUM | \
	 BXCAN_MCR_ABOM | BXCAN_MCR_TTCM | BXCAN_MCR_DBF)
#define IER_RW 0x00038F7Fu
#define BTR_RW 0xC37F03FFu
#define TDTR_RW 0xFFFF010Fu
#define BANKS_MASK 0x0FFFFFFFu
#define FMR_FIXED 0x2A1C0000u /* reserved bits at their reset value (RM0090 32.9.4 CAN_FMR) */
#define BITS_SYNC 11u /* 11 consecutive recessive bits (RM0090 32.4.1) */
#define BITS_INTERMISSION 3u
#define BITS_ERROR_FRAME 14u /* 6-bit error flag + 8-bit delimiter (node alone: no echoed flags) */
#define BITS_SUSPEND 8u /* an error passive transmitter's suspend transmission */
#define BOFF_OCCURRENCES 128u /* RM0090 32.7.6: 128 occurrences of 11 recessive bits */

/* ---- frames on the wire (ISO 11898-1 classic frame format) ---- */

static uint16_t crc_step(uint16_t crc, unsigned bit)
{
	unsigned nxt = (bit & 1u) ^ ((crc >> 14) & 1u);

	crc = (uint16_t)((crc << 1) & 0x7FFFu);
	return nxt ? (uint16_t)(crc ^ 0x4599u) : crc;
}

uint16_t bxcan_crc15(const uint8_t *bytes, uint32_t nbits)
{
	uint16_t crc = 0;
	uint32_t i;

	if (!bytes)
		return 0;
	for (i = 0; i < nbits; i++)
		crc = crc_step(crc, (unsigned)bytes[i / 8] >> (7 - i % 8));
	return crc;
}

static int frame_ok(const struct bxcan_frame *f)
{
	return f && f->dlc <= 15 && f->ide <= 1 && f->rtr <= 1 && f->id <= (f->ide ? 0x1FFFFFFFu : 0x7FFu);
}

static unsigned put_bits(uint8_t *bits, unsigned n, uint32_t v, unsigned width)
{
	while (width--)
		bits[n++] = (uint8_t)((v >> width) & 1u);
	return n;
}

uint32_t bxcan_frame_bits(const struct bxcan_frame *f, uint32_t *stuffed)
{
	uint8_t bits[128];
	unsigned n = 0, i, run = 0, ndata, stuff = 0;
	uint16_t crc = 0;
	uint8_t last = 2;

	if (!frame_ok(f))
		return 0;
	ndata = f->rtr ? 0u : (f->dlc > 8 ? 8u : f->dlc);
	n = put_bits(bits, n, 0, 1); /* SOF */
	if (f->ide) {
		n = put_bits(bits, n, f->id >> 18, 11);
		n = put_bits(bits, n, 3, 2); /* SRR, IDE */
		n = put_bits(bits, n, f->id & 0x3FFFFu, 18);
		n = put_bits(bits, n, f->rtr, 1);
		n = put_bits(bits, n, 0, 2); /* r1, r0 */
	} else {
		n = put_bits(bits, n, f->id, 11);
		n = put_bits(bits, n, f->rtr, 1);
		n = put_bits(bits, n, 0, 2); /* IDE, r0 */
	}
	n = put_bits(bits, n, f->dlc, 4);
	for (i = 0; i < ndata; i++)
		n = put_bits(bits, n, f->data[i], 8);
	for (i = 0; i < n; i++)
		crc = crc_step(crc, bits[i]);
	n = put_bits(bits, n, crc, 15);
	/* A complementary bit after every 5 equal bits, SOF to the CRC's end; it starts the next run. */
	for (i = 0; i < n; i++) {
		run = bits[i] == last ? run + 1 : 1;
		last = bits[i];
		if (run == 5) {
			stuff++;
			last ^= 1u;
			run = 1;
		}
	}
	if (stuffed)
		*stuffed = n + stuff;
	return n + stuff + 1 + 1 + 1 + 7; /* CRC delimiter, ACK slot, ACK delimiter, EOF */
}

uint64_t bxcan_bits_ns(const struct bxcan *b, uint32_t nbits)
{
	/* RM0090 32.7.7 bit timing: tq = (BRP + 1) tPCLK, bit = tq (1 + (TS1 + 1) + (TS2 + 1)). */
	uint64_t brp = (b->btr & 0x3FFu) + 1u, ts1 = (b->btr >> 16) & 0xFu, ts2 = (b->btr >> 20) & 7u;
	uint64_t num = (uint64_t)nbits * brp * (ts1 + ts2 + 3u) * 1000000000u;

	if (!b->pclk_hz)
		return NONE;
	return (num + b->pclk_hz - 1u) / b->pclk_hz;
}

static uint64_t after(const struct bxcan *b, uint64_t t, uint32_t nbits)
{
	uint64_t d = bxcan_bits_ns(b, nbits);

	return t > NONE - 1 - d ? NONE - 1 : t + d;
}

/* ---- error counters (RM0090 32.7.6, CAN_ESR in 32.9.2) ---- */

static int passive(const struct bxcan *b)
{
	return b->tec > 127 || b->rec > 127;
}

static void esr_update(struct bxcan *b)
{
	uint32_t e = b->esr & BXCAN_ESR_LEC_MASK;

	if (b->tec >= 96 || b->rec >= 96)
		e |= BXCAN_ESR_EWGF;
	if (passive(b))
		e |= BXCAN_ESR_EPVF;
	if (b->boff)
		e |= BXCAN_ESR_BOFF;
	/* TEC reads the low byte of the 9-bit counter. */
	b->esr = e | (uint32_t)(b->tec & 0xFFu) << BXCAN_ESR_TEC_SHIFT | (uint32_t)b->rec << BXCAN_ESR_REC_SHIFT;
}

/* An error was detected (LEC written): ERRI is set when an ESR condition holds whose interrupt is
 * enabled (RM0090 32.8, "status change error" and CAN_MSR.ERRI). */
static void error_event(struct bxcan *b, unsigned lec)
{
	uint32_t e;

	b->esr = (b->esr & ~BXCAN_ESR_LEC_MASK) | (uint32_t)lec << BXCAN_ESR_LEC_SHIFT;
	esr_update(b);
	e = b->esr;
	if (((e & BXCAN_ESR_EWGF) && (b->ier & BXCAN_IER_EWGIE)) ||
	    ((e & BXCAN_ESR_EPVF) && (b->ier & BXCAN_IER_EPVIE)) ||
	    ((e & BXCAN_ESR_BOFF) && (b->ier & BXCAN_IER_BOFIE)) ||
	    ((e & BXCAN_ESR_LEC_MASK) && (b->ier & BXCAN_IER_LECIE)))
		b->msr |= BXCAN_MSR_ERRI;
}

/* The recovery sequence: occ more occurrences of 11 recessive bits from now (paused while the bus is
 * stuck dominant). */
static void start_recovery(struct bxcan *b, unsigned occ)
{
	b->boff_occ_left = (uint16_t)occ;
	b->boff_start_ns = b->t_ns;
	b->boff_end_ns = b->dominant ? NONE : after(b, b->t_ns, occ * BITS_SYNC);
}

static void stop_recovery(struct bxcan *b)
{
	b->boff_occ_left = 0;
	b->boff_end_ns = NONE;
}

static void enter_bus_off(struct bxcan *b)
{
	b->boff = 1;
	b->dom_role = 0; /* a bus-off node takes no part in the bus */
	b->dom_next_ns = NONE;
	/* RM0090 32.7.6: with ABOM the recovery sequence starts by itself; else on leaving init. */
	if (b->mcr & BXCAN_MCR_ABOM)
		start_recovery(b, BOFF_OCCURRENCES);
	else
		stop_recovery(b);
}

/* ---- transmit mailboxes (RM0090 32.7.1) ---- */

static int mb_pending(const struct bxcan *b, unsigned m)
{
	return !(b->tsr & BXCAN_TSR_TME(m));
}

/* Arbitration order of a mailbox's identifier: lower wins. Base id, then RTR of a standard frame
 * against SRR of an extended one, IDE, the 18 extension bits and RTR. */
static uint32_t arb_key(uint32_t tir)
{
	uint32_t base = tir >> 21, rtr = (tir >> 1) & 1u;

	if (tir & BXCAN_TIR_IDE)
		return base << 21 | 1u << 20 | 1u << 19 | ((tir >> 3) & 0x3FFFFu) << 1 | rtr;
	return base << 21 | rtr << 20;
}

/* Does mailbox a go before mailbox c (TXFP = 0: identifier, then mailbox number; TXFP = 1: request
 * order)? */
static int before(const struct bxcan *b, unsigned a, unsigned c)
{
	if (b->mcr & BXCAN_MCR_TXFP)
		return (int32_t)(b->tx[a].seq - b->tx[c].seq) < 0;
	if (arb_key(b->tx[a].tir) != arb_key(b->tx[c].tir))
		return arb_key(b->tx[a].tir) < arb_key(b->tx[c].tir);
	return a < c;
}

static void mb_frame(const struct bxcan *b, unsigned m, struct bxcan_frame *f)
{
	const struct bxcan_txmb *x = &b->tx[m];
	unsigned i;

	memset(f, 0, sizeof(*f));
	f->ide = (x->tir & BXCAN_TIR_IDE) ? 1u : 0u;
	f->rtr = (x->tir & BXCAN_TIR_RTR) ? 1u : 0u;
	f->id = f->ide ? (x->tir >> 3) & 0x1FFFFFFFu : x->tir >> 21;
	f->dlc = (uint8_t)(x->tdtr & 0xFu);
	for (i = 0; i < 4; i++) {
		f->data[i] = (uint8_t)(x->tdlr >> (8 * i));
		f->data[4 + i] = (uint8_t)(x->tdhr >> (8 * i));
	}
}

/* The mailbox becomes empty: request completed (RQCP), TXRQ and ABRQ cleared. */
static void mb_empty(struct bxcan *b, unsigned m, int ok)
{
	b->tsr |= BXCAN_TSR_TME(m) | BXCAN_TSR_RQCP(m);
	b->tsr &= ~BXCAN_TSR_ABRQ(m);
	if (ok)
		b->tsr = (b->tsr | BXCAN_TSR_TXOK(m)) & ~(BXCAN_TSR_ALST(m) | BXCAN_TSR_TERR(m));
	else
		b->tsr &= ~BXCAN_TSR_TXOK(m);
	b->tx[m].tir &= ~BXCAN_TIR_TXRQ;
}

/* ---- receive path: filters (RM0090 32.7.4) and FIFOs (32.7.5) ---- */

static unsigned can1_banks(const struct bxcan *b)
{
	unsigned sb = (b->fmr >> BXCAN_FMR_CAN2SB_SHIFT) & 0x3Fu;

	return sb > BXCAN_FILTER_BANKS ? BXCAN_FILTER_BANKS : sb; /* CAN1 owns banks 0..CAN2SB-1 */
}

struct match {
	int found;
	unsigned rank; /* priority class: 0 best (32-bit list) .. 3 (16-bit mask) */
	unsigned fifo, fmi;
};

/* Filter priority (32.7.4 "Filter priority rules"): 32-bit before 16-bit, list before mask, then the
 * lower filter number; across FIFOs the model takes the lower bank, then the lower filter in it. */
static void consider(struct match *m, unsigned rank, unsigned fifo, unsigned fmi)
{
	if (!m->found || rank < m->rank) {
		m->found = 1;
		m->rank = rank;
		m->fifo = fifo;
		m->fmi = fmi;
	}
}

static struct match filter(const struct bxcan *b, const struct bxcan_frame *f)
{
	struct match m = { 0, 0, 0, 0 };
	unsigned next[2] = { 0, 0 }, nb = can1_banks(b), k;
	uint32_t stid = f->ide ? f->id >> 18 : f->id, exid = f->ide ? f->id & 0x3FFFFu : 0;
	/* The frame as the filter registers lay it out (32.7.4, figure "Filter bank scale configuration"). */
	uint32_t w32 = stid << 21 | exid << 3 | (uint32_t)f->ide << 2 | (uint32_t)f->rtr << 1;
	uint32_t w16 = stid << 5 | (uint32_t)f->rtr << 4 | (uint32_t)f->ide << 3 | exid >> 15;

	if (b->fmr & BXCAN_FMR_FINIT)
		return m; /* filters in initialisation mode: none active */
	for (k = 0; k < nb; k++) {
		unsigned fifo = (b->ffa1r >> k) & 1u, list = (b->fm1r >> k) & 1u, s32 = (b->fs1r >> k) & 1u;
		unsigned first = next[fifo], rank = (s32 ? 0u : 2u) + (list ? 0u : 1u), i;
		uint32_t r1 = b->fr[k][0], r2 = b->fr[k][1];

		/* Filter numbers count every bank of the FIFO, active or not (32.7.4 "Filter match index"). */
		next[fifo] += s32 ? (list ? 2u : 1u) : (list ? 4u : 2u);
		if (!((b->fa1r >> k) & 1u))
			continue;
		if (s32 && list) {
			if (((w32 ^ r1) & ~1u) == 0)
				consider(&m, rank, fifo, first);
			else if (((w32 ^ r2) & ~1u) == 0)
				consider(&m, rank, fifo, first + 1);
		} else if (s32) {
			if (((w32 ^ r1) & r2 & ~1u) == 0)
				consider(&m, rank, fifo, first);
		} else if (list) {
			uint32_t ids[4] = { r1 & 0xFFFFu, r1 >> 16, r2 & 0xFFFFu, r2 >> 16 };

			for (i = 0; i < 4; i++)
				if (w16 == ids[i]) {
					consider(&m, rank, fifo, first + i);
					break;
				}
		} else {
			if (((w16 ^ r1) & (r1 >> 16) & 0xFFFFu) == 0)
				consider(&m, rank, fifo, first);
			else if (((w16 ^ r2) & (r2 >> 16) & 0xFFFFu) == 0)
				consider(&m, rank, fifo, first + 1);
		}
	}
	return m;
}

static enum bxcan_rx store(struct bxcan *b, const struct bxcan_frame *f)
{
	struct match m = filter(b, f);
	struct bxcan_rxmb *slot;
	uint32_t fmp;
	unsigned i;

	if (!m.found)
		return BXCAN_RX_FILTERED;
	fmp = b->rfr[m.fifo] & BXCAN_RFR_FMP_MASK;
	if (fmp == 3) {
		/* Overrun (32.7.5): RFLM = 0 overwrites the last message stored, RFLM = 1 drops the new one. */
		b->rfr[m.fifo] |= BXCAN_RFR_FOVR;
		if (b->mcr & BXCAN_MCR_RFLM)
			return BXCAN_RX_LOST;
		slot = &b->rx[m.fifo][(b->rx_head[m.fifo] + 2u) % 3u];
	} else {
		slot = &b->rx[m.fifo][(b->rx_head[m.fifo] + fmp) % 3u];
		fmp++;
		b->rfr[m.fifo] = (b->rfr[m.fifo] & ~BXCAN_RFR_FMP_MASK) | fmp;
		if (fmp == 3)
			b->rfr[m.fifo] |= BXCAN_RFR_FULL;
	}
	slot->rir = f->ide ? f->id << 3 | BXCAN_TIR_IDE : f->id << 21;
	slot->rir |= f->rtr ? BXCAN_TIR_RTR : 0u;
	slot->rdtr = (uint32_t)m.fmi << 8 | f->dlc;
	slot->rdlr = slot->rdhr = 0;
	for (i = 0; i < 4; i++) {
		slot->rdlr |= (uint32_t)f->data[i] << (8 * i);
		slot->rdhr |= (uint32_t)f->data[4 + i] << (8 * i);
	}
	return m.fifo ? BXCAN_RX_FIFO1 : BXCAN_RX_FIFO0;
}

/* ---- operating modes (RM0090 32.4) ---- */

static void set_mode(struct bxcan *b, unsigned mode)
{
	b->mode = (uint8_t)mode;
	b->sync_end_ns = NONE;
	b->msr &= ~(BXCAN_MSR_INAK | BXCAN_MSR_SLAK);
	if (mode == MODE_INIT)
		b->msr |= BXCAN_MSR_INAK;
	if (mode == MODE_SLEEP) {
		b->msr |= BXCAN_MSR_SLAK;
		if (b->ier & BXCAN_IER_SLKIE)
			b->msr |= BXCAN_MSR_SLAKI; /* set on entry only when SLKIE = 1 (32.9.2 CAN_MSR) */
	} else {
		b->msr &= ~BXCAN_MSR_SLAKI; /* cleared by hardware with SLAK */
	}
	if (mode != MODE_NORMAL && !(b->mcr & BXCAN_MCR_ABOM) && b->boff)
		stop_recovery(b); /* a manual recovery restarts on the next exit from init */
	if (mode != MODE_NORMAL) {
		b->dom_role = 0;
		b->dom_next_ns = NONE;
	}
}

/* Figure "bxCAN operating modes" (32.4): INRQ & !SLEEP -> init, SLEEP & !INRQ -> sleep, neither ->
 * normal after 11 recessive bits (SYNC); both set: no change. Init and sleep are entered once the
 * current frame on the wire is done (ACK). */
static void update_mode(struct bxcan *b)
{
	int inrq = (b->mcr & BXCAN_MCR_INRQ) != 0, sleep = (b->mcr & BXCAN_MCR_SLEEP) != 0;
	unsigned want;

	if (inrq && sleep)
		return;
	want = inrq ? MODE_INIT : sleep ? MODE_SLEEP : MODE_NORMAL;
	if (want == b->mode) {
		b->sync_end_ns = NONE;
		return;
	}
	if (want != MODE_NORMAL) {
		if (b->tx_mb < 0)
			set_mode(b, want);
		return;
	}
	if (b->sync_end_ns == NONE && !b->dominant)
		b->sync_end_ns = after(b, b->t_ns, BITS_SYNC);
}

static void sync_done(struct bxcan *b)
{
	int from_init = b->mode == MODE_INIT;

	set_mode(b, MODE_NORMAL);
	/* Manual bus-off recovery (ABOM = 0): the sync's 11 bits are the first of the 128 occurrences. */
	if (b->boff && from_init && !(b->mcr & BXCAN_MCR_ABOM))
		start_recovery(b, BOFF_OCCURRENCES - 1);
}

static void recovered(struct bxcan *b)
{
	b->boff = 0;
	b->tec = 0;
	b->rec = 0;
	stop_recovery(b);
	esr_update(b);
	if (b->bus_free_ns < b->t_ns)
		b->bus_free_ns = b->t_ns;
}

/* ---- transmission in time ---- */

static int best_pending(const struct bxcan *b)
{
	int best = -1;
	unsigned m;

	for (m = 0; m < 3; m++)
		if (mb_pending(b, m) && (best < 0 || before(b, m, (unsigned)best)))
			best = (int)m;
	return best;
}

static int can_start(const struct bxcan *b)
{
	int silent_only = (b->btr & BXCAN_BTR_SILM) && !(b->btr & BXCAN_BTR_LBKM);

	/* Silent mode "cannot start a transmission" (32.5.1): requests wait. */
	return b->mode == MODE_NORMAL && !b->boff && !b->dominant && b->tx_mb < 0 && !silent_only &&
		best_pending(b) >= 0;
}

static void start_tx(struct bxcan *b)
{
	struct bxcan_frame f;
	uint32_t stuffed = 0, total;
	unsigned m = (unsigned)best_pending(b);

	mb_frame(b, m, &f);
	total = bxcan_frame_bits(&f, &stuffed);
	b->tx_mb = (int8_t)m;
	b->msr |= BXCAN_MSR_TXM;
	if (b->btr & BXCAN_BTR_LBKM) {
		b->tx_outcome = OUT_OK; /* loopback ignores acknowledge errors (32.5.2) */
	} else if (b->arb_lost_left) {
		b->arb_lost_left--;
		b->tx_outcome = OUT_ARB_LOST;
	} else if (b->tx_errors_left) {
		b->tx_errors_left--;
		b->tx_outcome = OUT_BIT_ERR;
		total = stuffed + 2; /* detected at the ACK slot */
	} else if (b->no_ack) {
		b->tx_outcome = OUT_ACK_ERR;
		total = stuffed + 2;
	} else {
		b->tx_outcome = OUT_OK;
	}
	b->tx_end_ns = after(b, b->t_ns, total);
}

/* A failed attempt of mailbox m (RM0090 32.7.1 "Transmit handling", 32.7.6 fault confinement). */
static void tx_failed(struct bxcan *b, unsigned m, unsigned outcome)
{
	/* TXOK, ALST and TERR describe the last attempt (32.9.2 CAN_TSR). */
	b->tsr &= ~(BXCAN_TSR_TXOK(m) | BXCAN_TSR_ALST(m) | BXCAN_TSR_TERR(m));
	if (outcome == OUT_ARB_LOST) {
		b->tsr |= BXCAN_TSR_ALST(m);
		b->bus_free_ns = after(b, b->t_ns, BITS_INTERMISSION);
	} else {
		/* ISO 11898-1 fault confinement: a transmitter's error adds 8 to TEC, except an ACK error
		 * of an error passive transmitter (it sees no dominant bit in its passive error flag: the
		 * node is alone on the bus), which leaves TEC unchanged. */
		unsigned lec = outcome == OUT_ACK_ERR ? BXCAN_LEC_ACK : BXCAN_LEC_BIT_RECESSIVE;

		b->tsr |= BXCAN_TSR_TERR(m);
		if (!(outcome == OUT_ACK_ERR && passive(b)))
			b->tec = (uint16_t)(b->tec + 8u);
		if (b->tec > 255 && !b->boff)
			enter_bus_off(b); /* TEC over 255 (32.9.2 CAN_ESR.BOFF) */
		error_event(b, lec);
		b->bus_free_ns =
			after(b, b->t_ns, BITS_ERROR_FRAME + BITS_INTERMISSION + (passive(b) ? BITS_SUSPEND : 0u));
	}
	/* NART: one attempt only; an abort requested during the attempt takes effect now (32.7.1). */
	if ((b->mcr & BXCAN_MCR_NART) || (b->tsr & BXCAN_TSR_ABRQ(m)))
		mb_empty(b, m, 0);
}

static void end_tx(struct bxcan *b)
{
	unsigned m = (unsigned)b->tx_mb;

	b->tx_mb = -1;
	b->msr &= ~BXCAN_MSR_TXM;
	if (b->tx_outcome == OUT_OK) {
		struct bxcan_frame f;

		mb_frame(b, m, &f);
		if (b->tec > 0)
			b->tec--;
		b->esr &= ~BXCAN_ESR_LEC_MASK; /* cleared on an error-free transfer (CAN_ESR.LEC) */
		esr_update(b);
		mb_empty(b, m, 1);
		b->bus_free_ns = after(b, b->t_ns, BITS_INTERMISSION);
		if (b->on_tx && !(b->btr & BXCAN_BTR_SILM))
			b->on_tx(b->user, &f, b->t_ns);
		if (b->btr & BXCAN_BTR_LBKM)
			(void)store(b, &f); /* loopback: the node receives its own frame (32.5.2) */
	} else {
		tx_failed(b, m, b->tx_outcome);
	}
	update_mode(b); /* an init or sleep request waited for the frame's end */
}

/* Stuck dominant bus: 8 more dominant bits after the error flag (ISO 11898-1 fault confinement). */
static void dominant_bits(struct bxcan *b)
{
	unsigned lec = (b->esr & BXCAN_ESR_LEC_MASK) >> BXCAN_ESR_LEC_SHIFT;

	if (b->dom_role == 2) {
		b->tec = (uint16_t)(b->tec + 8u);
		if (b->tec > 255)
			enter_bus_off(b);
	} else {
		b->rec = (uint8_t)(b->rec > 247 ? 255u : b->rec + 8u);
	}
	error_event(b, lec);
	b->dom_next_ns = b->dom_role ? after(b, b->t_ns, 8) : NONE;
}

uint64_t bxcan_next_event_ns(const struct bxcan *b)
{
	uint64_t t = NONE;

	if (!b)
		return NONE;
	if (b->tx_mb >= 0 && b->tx_end_ns < t)
		t = b->tx_end_ns;
	if (b->sync_end_ns < t)
		t = b->sync_end_ns;
	if (b->boff && b->boff_end_ns < t)
		t = b->boff_end_ns;
	if (b->dom_role && b->dom_next_ns < t)
		t = b->dom_next_ns;
	if (can_start(b)) {
		uint64_t s = b->bus_free_ns > b->t_ns ? b->bus_free_ns : b->t_ns;

		if (s < t)
			t = s;
	}
	return t;
}

void bxcan_advance(struct bxcan *b, uint64_t now_ns)
{
	if (!b)
		return;
	if (now_ns < b->t_ns)
		now_ns = b->t_ns;
	for (;;) {
		uint64_t t = bxcan_next_event_ns(b);

		if (t > now_ns)
			break;
		b->t_ns = t;
		if (b->tx_mb >= 0 && b->tx_end_ns == t)
			end_tx(b);
		else if (b->sync_end_ns == t)
			sync_done(b);
		else if (b->boff && b->boff_end_ns == t)
			recovered(b);
		else if (b->dom_role && b->dom_next_ns == t)
			dominant_bits(b);
		else
			start_tx(b);
	}
	b->t_ns = now_ns;
}

/* ---- set-up and reset ---- */

static void core_reset(struct bxcan *b)
{
	b->mcr = 0x00010002u;
	b->msr = 0x00000C02u;
	b->tsr = 0x1C000000u;
	b->rfr[0] = b->rfr[1] = 0;
	b->ier = 0;
	b->esr = 0;
	b->btr = 0x01230000u;
	memset(b->tx, 0, sizeof(b->tx));
	memset(b->rx, 0, sizeof(b->rx));
	b->rx_head[0] = b->rx_head[1] = 0;
	b->tec = 0;
	b->rec = 0;
	b->mode = MODE_SLEEP;
	b->boff = 0;
	b->tx_mb = -1;
	b->tx_outcome = OUT_OK;
	b->tx_seq = 0;
	b->tx_end_ns = NONE;
	b->bus_free_ns = b->t_ns;
	b->sync_end_ns = NONE;
	b->boff_end_ns = NONE;
	b->boff_start_ns = 0;
	b->boff_occ_left = 0;
	b->dom_role = 0;
	b->dom_next_ns = NONE;
	if (b->dominant)
		b->msr &= ~(BXCAN_MSR_RX | BXCAN_MSR_SAMP);
}

void bxcan_reset(struct bxcan *b)
{
	if (!b)
		return;
	core_reset(b);
	b->fmr = 0x2A1C0E01u; /* CAN2SB = 14, FINIT = 1 */
	b->fm1r = b->fs1r = b->ffa1r = b->fa1r = 0;
	memset(b->fr, 0, sizeof(b->fr));
}

int bxcan_init(struct bxcan *b, uint32_t pclk_hz)
{
	if (!b || !pclk_hz)
		return -1;
	memset(b, 0, sizeof(*b));
	b->pclk_hz = pclk_hz;
	bxcan_reset(b);
	return 0;
}

void bxcan_set_tx_callback(struct bxcan *b, bxcan_tx_fn fn, void *user)
{
	if (!b)
		return;
	b->on_tx = fn;
	b->user = user;
}

int bxcan_set_pclk(struct bxcan *b, uint32_t pclk_hz)
{
	if (!b || !pclk_hz)
		return -1;
	b->pclk_hz = pclk_hz;
	return 0;
}

/* ---- register access (RM0090 32.9) ---- */

static uint32_t tsr_value(const struct bxcan *b)
{
	uint32_t v = b->tsr & ~(0x7u << 29 | 0x3u << BXCAN_TSR_CODE_SHIFT);
	unsigned m, npend = 0;
	int low = -1, code = -1;

	for (m = 0; m < 3; m++) {
		if (!mb_pending(b, m)) {
			if (code < 0)
				code = (int)m; /* the next free mailbox */
			continue;
		}
		npend++;
		if (low < 0 || before(b, (unsigned)low, m))
			low = (int)m;
	}
	if (npend > 1)
		v |= BXCAN_TSR_LOW((unsigned)low); /* LOW only with more than one pending */
	if (code < 0)
		code = low; /* all pending: the lowest priority one */
	return v | (uint32_t)code << BXCAN_TSR_CODE_SHIFT;
}

uint32_t bxcan_read(struct bxcan *b, uint32_t off, uint64_t now_ns)
{
	if (!b || (off & 3u))
		return 0;
	bxcan_advance(b, now_ns);
	switch (off) {
	case BXCAN_MCR:
		return b->mcr;
	case BXCAN_MSR:
		return b->msr;
	case BXCAN_TSR:
		return tsr_value(b);
	case BXCAN_RF0R:
		return b->rfr[0];
	case BXCAN_RF1R:
		return b->rfr[1];
	case BXCAN_IER:
		return b->ier;
	case BXCAN_ESR:
		return b->esr;
	case BXCAN_BTR:
		return b->btr;
	case BXCAN_FMR:
		return b->fmr;
	case BXCAN_FM1R:
		return b->fm1r;
	case BXCAN_FS1R:
		return b->fs1r;
	case BXCAN_FFA1R:
		return b->ffa1r;
	case BXCAN_FA1R:
		return b->fa1r;
	default:
		break;
	}
	if (off >= BXCAN_TIR(0) && off < BXCAN_RIR(0)) {
		const struct bxcan_txmb *x = &b->tx[(off - BXCAN_TIR(0)) / 16u];
		const uint32_t r[4] = { x->tir, x->tdtr, x->tdlr, x->tdhr };

		return r[(off & 0xFu) / 4u];
	}
	if (off >= BXCAN_RIR(0) && off < BXCAN_RIR(2)) {
		unsigned f = (off - BXCAN_RIR(0)) / 16u;
		const struct bxcan_rxmb *x = &b->rx[f][b->rx_head[f]]; /* the FIFO's output mailbox */
		const uint32_t r[4] = { x->rir, x->rdtr, x->rdlr, x->rdhr };

		return r[(off & 0xFu) / 4u];
	}
	if (off >= BXCAN_FR1(0) && off < BXCAN_FR1(BXCAN_FILTER_BANKS))
		return b->fr[(off - BXCAN_FR1(0)) / 8u][(off & 4u) / 4u];
	return 0;
}

static void write_tsr(struct bxcan *b, uint32_t v)
{
	unsigned m;

	for (m = 0; m < 3; m++) {
		uint32_t w1c = v & (BXCAN_TSR_RQCP(m) | BXCAN_TSR_TXOK(m) | BXCAN_TSR_ALST(m) | BXCAN_TSR_TERR(m));

		/* Clearing RQCP clears the mailbox's TXOK, ALST and TERR too (32.9.2 CAN_TSR). */
		if (w1c & BXCAN_TSR_RQCP(m))
			w1c |= BXCAN_TSR_TXOK(m) | BXCAN_TSR_ALST(m) | BXCAN_TSR_TERR(m);
		b->tsr &= ~w1c;
		/* ABRQ: a pending mailbox is aborted at once; one on the wire when its attempt ends
		 * (32.7.1 "Abort"); no effect on an empty one. */
		if ((v & BXCAN_TSR_ABRQ(m)) && mb_pending(b, m)) {
			if (b->tx_mb == (int)m)
				b->tsr |= BXCAN_TSR_ABRQ(m);
			else
				mb_empty(b, m, 0);
		}
	}
}

static void write_tx(struct bxcan *b, uint32_t off, uint32_t v)
{
	unsigned m = (off - BXCAN_TIR(0)) / 16u;
	struct bxcan_txmb *x = &b->tx[m];

	if (mb_pending(b, m))
		return; /* TX registers are write protected while the mailbox is pending (32.9.3) */
	switch ((off & 0xFu) / 4u) {
	case 0:
		x->tir = v;
		if (v & BXCAN_TIR_TXRQ) {
			b->tsr &= ~(BXCAN_TSR_TME(m) | BXCAN_TSR_RQCP(m) | BXCAN_TSR_TXOK(m) | BXCAN_TSR_ALST(m) |
				    BXCAN_TSR_TERR(m));
			x->seq = b->tx_seq++;
		}
		break;
	case 1:
		x->tdtr = v & TDTR_RW;
		break;
	case 2:
		x->tdlr = v;
		break;
	default:
		x->tdhr = v;
		break;
	}
}

static void write_rfr(struct bxcan *b, unsigned f, uint32_t v)
{
	b->rfr[f] &= ~(v & (BXCAN_RFR_FULL | BXCAN_RFR_FOVR));
	if ((v & BXCAN_RFR_RFOM) && (b->rfr[f] & BXCAN_RFR_FMP_MASK)) {
		/* Release the output mailbox (32.7.5); with none pending, no effect. */
		b->rx_head[f] = (uint8_t)((b->rx_head[f] + 1u) % 3u);
		b->rfr[f] = (b->rfr[f] & ~BXCAN_RFR_FMP_MASK) | ((b->rfr[f] & BXCAN_RFR_FMP_MASK) - 1u);
	}
}

static void write_mcr(struct bxcan *b, uint32_t v)
{
	if (v & BXCAN_MCR_RESET) {
		core_reset(b); /* master reset: back to sleep, filters kept (32.9.2 CAN_MCR) */
		return;
	}
	b->mcr = v & MCR_RW;
	if (b->boff && (b->mcr & BXCAN_MCR_ABOM) && !b->boff_occ_left)
		start_recovery(b, BOFF_OCCURRENCES);
	update_mode(b);
}

void bxcan_write(struct bxcan *b, uint32_t off, uint32_t v, uint64_t now_ns)
{
	int finit;

	if (!b || (off & 3u))
		return;
	bxcan_advance(b, now_ns);
	finit = (b->fmr & BXCAN_FMR_FINIT) != 0;
	switch (off) {
	case BXCAN_MCR:
		write_mcr(b, v);
		break;
	case BXCAN_MSR:
		b->msr &= ~(v & (BXCAN_MSR_ERRI | BXCAN_MSR_WKUI | BXCAN_MSR_SLAKI));
		break;
	case BXCAN_TSR:
		write_tsr(b, v);
		break;
	case BXCAN_RF0R:
	case BXCAN_RF1R:
		write_rfr(b, off == BXCAN_RF1R, v);
		break;
	case BXCAN_IER:
		b->ier = v & IER_RW;
		break;
	case BXCAN_ESR:
		b->esr = (b->esr & ~BXCAN_ESR_LEC_MASK) | (v & BXCAN_ESR_LEC_MASK); /* only LEC is rw */
		break;
	case BXCAN_BTR:
		if (b->msr & BXCAN_MSR_INAK)
			b->btr = v & BTR_RW; /* accessible in initialisation mode only (32.9.2 CAN_BTR) */
		break;
	case BXCAN_FMR:
		b->fmr = FMR_FIXED | (v & (0x3Fu << BXCAN_FMR_CAN2SB_SHIFT | BXCAN_FMR_FINIT));
		break;
	case BXCAN_FM1R: /* these three: only with FINIT = 1 (32.9.4) */
		if (finit)
			b->fm1r = v & BANKS_MASK;
		break;
	case BXCAN_FS1R:
		if (finit)
			b->fs1r = v & BANKS_MASK;
		break;
	case BXCAN_FFA1R:
		if (finit)
			b->ffa1r = v & BANKS_MASK;
		break;
	case BXCAN_FA1R:
		b->fa1r = v & BANKS_MASK;
		break;
	default:
		if (off >= BXCAN_TIR(0) && off < BXCAN_RIR(0)) {
			write_tx(b, off, v);
		} else if (off >= BXCAN_FR1(0) && off < BXCAN_FR1(BXCAN_FILTER_BANKS)) {
			unsigned k = (off - BXCAN_FR1(0)) / 8u;

			/* A bank's registers: only while it is inactive or with FINIT = 1 (32.9.4 CAN_FiRx). */
			if (finit || !((b->fa1r >> k) & 1u))
				b->fr[k][(off & 4u) / 4u] = v;
		}
		break;
	}
	bxcan_advance(b, now_ns); /* a transmission may start now */
}

/* ---- the bus side ---- */

static enum bxcan_rx receive(struct bxcan *b, const struct bxcan_frame *f)
{
	/* A good reception: REC - 1, or 120 when above 128 (32.9.2 CAN_ESR.REC); LEC cleared. */
	if (b->rec > 128)
		b->rec = 120;
	else if (b->rec > 0)
		b->rec--;
	b->esr &= ~BXCAN_ESR_LEC_MASK;
	esr_update(b);
	return store(b, f);
}

enum bxcan_rx bxcan_bus_rx(struct bxcan *b, const struct bxcan_frame *f, uint64_t t_ns)
{
	if (!b || !frame_ok(f))
		return BXCAN_RX_INVALID;
	bxcan_advance(b, t_ns);
	if (b->mode == MODE_SLEEP) {
		/* SOF in sleep mode: WKUI; with AWUM the hardware clears SLEEP (32.4.3, CAN_MCR.AWUM). */
		b->msr |= BXCAN_MSR_WKUI;
		if (b->mcr & BXCAN_MCR_AWUM) {
			b->mcr &= ~BXCAN_MCR_SLEEP;
			update_mode(b);
		}
		return BXCAN_RX_OFF;
	}
	if (b->mode != MODE_NORMAL || b->boff || b->dominant || (b->btr & BXCAN_BTR_LBKM))
		return BXCAN_RX_OFF;
	return receive(b, f);
}

unsigned bxcan_irq_lines(const struct bxcan *b)
{
	unsigned lines = 0, f;
	uint32_t ie = b ? b->ier : 0;

	if (!b)
		return 0;
	if ((ie & BXCAN_IER_TMEIE) && (b->tsr & (BXCAN_TSR_RQCP(0) | BXCAN_TSR_RQCP(1) | BXCAN_TSR_RQCP(2))))
		lines |= BXCAN_IRQ_TX;
	for (f = 0; f < 2; f++) {
		uint32_t r = b->rfr[f], fmpie = f ? BXCAN_IER_FMPIE1 : BXCAN_IER_FMPIE0;
		uint32_t ffie = f ? BXCAN_IER_FFIE1 : BXCAN_IER_FFIE0, fovie = f ? BXCAN_IER_FOVIE1 : BXCAN_IER_FOVIE0;

		if (((ie & fmpie) && (r & BXCAN_RFR_FMP_MASK)) || ((ie & ffie) && (r & BXCAN_RFR_FULL)) ||
		    ((ie & fovie) && (r & BXCAN_RFR_FOVR)))
			lines |= f ? BXCAN_IRQ_RX1 : BXCAN_IRQ_RX0;
	}
	if (((ie & BXCAN_IER_ERRIE) && (b->msr & BXCAN_MSR_ERRI)) ||
	    ((ie & BXCAN_IER_WKUIE) && (b->msr & BXCAN_MSR_WKUI)) ||
	    ((ie & BXCAN_IER_SLKIE) && (b->msr & BXCAN_MSR_SLAKI)))
		lines |= BXCAN_IRQ_SCE;
	return lines;
}

/* ---- injected bus errors ---- */

void bxcan_inject_no_ack(struct bxcan *b, bool on)
{
	if (b)
		b->no_ack = on;
}

void bxcan_inject_tx_errors(struct bxcan *b, uint32_t n)
{
	if (b)
		b->tx_errors_left = n;
}

void bxcan_inject_arbitration_lost(struct bxcan *b, uint32_t n)
{
	if (b)
		b->arb_lost_left = n;
}

void bxcan_inject_bus_off(struct bxcan *b, uint64_t now_ns)
{
	if (!b)
		return;
	bxcan_advance(b, now_ns);
	if (b->boff)
		return;
	if (b->tx_mb >= 0) {
		unsigned m = (unsigned)b->tx_mb;

		b->tx_mb = -1;
		b->msr &= ~BXCAN_MSR_TXM;
		b->tsr = (b->tsr & ~(BXCAN_TSR_TXOK(m) | BXCAN_TSR_ALST(m))) | BXCAN_TSR_TERR(m);
		if ((b->mcr & BXCAN_MCR_NART) || (b->tsr & BXCAN_TSR_ABRQ(m)))
			mb_empty(b, m, 0);
	}
	b->tec = 256;
	enter_bus_off(b);
	error_event(b, BXCAN_LEC_BIT_RECESSIVE);
	update_mode(b);
}

void bxcan_inject_rx_errors(struct bxcan *b, uint32_t n, uint64_t now_ns)
{
	if (!b)
		return;
	bxcan_advance(b, now_ns);
	if (b->mode != MODE_NORMAL || b->boff || !n)
		return;
	b->rec = (uint8_t)(b->rec + n > 255u ? 255u : b->rec + n);
	error_event(b, BXCAN_LEC_CRC);
}

void bxcan_inject_bus_dominant(struct bxcan *b, bool on, uint64_t now_ns)
{
	if (!b)
		return;
	bxcan_advance(b, now_ns);
	if (on == b->dominant)
		return;
	b->dominant = on;
	if (on) {
		b->msr &= ~(BXCAN_MSR_RX | BXCAN_MSR_SAMP);
		b->sync_end_ns = NONE;
		if (b->boff && b->boff_end_ns != NONE) {
			/* Pause the recovery, keeping the occurrences of 11 recessive bits already seen. */
			uint64_t done = (b->t_ns - b->boff_start_ns) / bxcan_bits_ns(b, BITS_SYNC);

			b->boff_occ_left = (uint16_t)(done >= b->boff_occ_left ? 1u : b->boff_occ_left - done);
			b->boff_end_ns = NONE;
		}
		if (b->mode != MODE_NORMAL || b->boff)
			return;
		if (b->tx_mb >= 0) {
			unsigned m = (unsigned)b->tx_mb;

			b->tx_mb = -1;
			b->msr &= ~BXCAN_MSR_TXM;
			b->dom_role = 2;
			tx_failed(b, m, OUT_BIT_ERR);
		} else {
			b->dom_role = 1;
			b->rec = (uint8_t)(b->rec == 255 ? 255u : b->rec + 1u);
			error_event(b, BXCAN_LEC_STUFF);
		}
		if (b->dom_role && !b->boff)
			b->dom_next_ns = after(b, b->t_ns, BITS_ERROR_FRAME);
		else
			b->dom_role = 0;
		update_mode(b);
		return;
	}
	b->msr |= BXCAN_MSR_RX | BXCAN_MSR_SAMP;
	b->dom_role = 0;
	b->dom_next_ns = NONE;
	if (b->boff && b->boff_occ_left) {
		b->boff_start_ns = b->t_ns;
		b->boff_end_ns = after(b, b->t_ns, b->boff_occ_left * BITS_SYNC);
	}
	b->bus_free_ns = after(b, b->t_ns, BITS_SYNC); /* bus idle: 11 recessive bits */
	update_mode(b);
}
