#include "can.h"

#include "../logic/can_busoff.h"
#include "../logic/can_tx.h"
#include "../regs/stm32f405_can.h"
#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"
#include "board.h"
#include "irq.h"
#include "isr.h"
#include "safe.h"

#define INAK_WAIT_LOOPS 100000u /* leaving init needs 11 recessive bits: 11 us at 1 Mbit/s */
#define RX_RING 16u

static struct {
	int running;
	uint32_t pend_id[3];
	struct fw_frame rx[RX_RING];
	volatile uint32_t rx_head, rx_tail;
	volatile uint32_t rx_overruns, tx_aborted, rx_dropped;
	struct can_busoff busoff; /* written by the status interrupt and can_poll (masked there) */
	volatile uint32_t now_ms;
} can;

static int wait_msr(uint32_t mask, uint32_t want)
{
	uint32_t n;

	for (n = 0; n < INAK_WAIT_LOOPS; n++)
		if ((CAN1->MSR & mask) == want)
			return 1;
	return 0;
}

int can_probe(void)
{
	int ok;

	RCC->APB1ENR |= RCC_APB1ENR_CAN1;
	(void)RCC->APB1ENR;
	CAN1->MCR = CAN_MCR_INRQ; /* out of sleep, into initialisation */
	ok = wait_msr(CAN_MSR_INAK | CAN_MSR_SLAK, CAN_MSR_INAK);
	RCC->APB1RSTR |= RCC_APB1RSTR_CAN1;
	RCC->APB1RSTR &= ~RCC_APB1RSTR_CAN1;
	if (!ok)
		RCC->APB1ENR &= ~RCC_APB1ENR_CAN1;
	return ok;
}

enum swell_err can_start(uint32_t pclk1_hz, uint32_t bitrate, const struct can_filter_spec *flt, unsigned nflt,
			 int loopback, uint8_t prio_rx, uint8_t prio_sce)
{
	struct can_filter_bank banks[CAN_FILTER_BANKS_CAN1];
	struct can_timing t;
	unsigned nb, b;
	enum swell_err err;

	err = can_timing_compute(pclk1_hz, bitrate, 875, &t);
	if (err != SWELL_OK)
		return err;
	err = can_filter_plan(flt, nflt, banks, CAN_FILTER_BANKS_CAN1, &nb);
	if (err != SWELL_OK)
		return err;
	err = safe_register(can_abort_all); /* before the first frame can be queued */
	if (err != SWELL_OK)
		return err;

	RCC->APB1ENR |= RCC_APB1ENR_CAN1;
	(void)RCC->APB1ENR;
	/* CAN1_RX and CAN1_TX, AF9, on the board's pins (PB8/PB9 on every board so far). */
	board_pin_af(SWELL_BOARD_CAN_RX_PORT, SWELL_BOARD_CAN_RX_PIN, 9u, 0);
	board_pin_af(SWELL_BOARD_CAN_TX_PORT, SWELL_BOARD_CAN_TX_PIN, 9u, 0);

	/* Initialisation mode, and with it: transmit by id priority (TXFP = 0), no automatic bus-off
	 * recovery (we rate-limit it), automatic retransmission on, and RFLM = 0: on a FIFO overrun the
	 * new frame replaces the last one stored, the two oldest stay (RM0090 32.7.5), so the newest
	 * position gets through. */
	CAN1->MCR = CAN_MCR_INRQ;
	if (!wait_msr(CAN_MSR_INAK | CAN_MSR_SLAK, CAN_MSR_INAK))
		return SWELL_ESTATE;
	CAN1->BTR = can_timing_btr(&t) | (loopback ? CAN_BTR_LBKM | CAN_BTR_SILM : 0);

	CAN1->FMR |= CAN_FMR_FINIT;
	CAN1->FA1R = 0;
	CAN1->FS1R = 0; /* 16-bit scale */
	CAN1->FM1R = 0;
	CAN1->FFA1R = 0;
	for (b = 0; b < nb; b++) {
		CAN1->FB[b].FR1 = banks[b].fr1;
		CAN1->FB[b].FR2 = banks[b].fr2;
		if (banks[b].list_mode)
			CAN1->FM1R |= 1u << b;
		if (banks[b].fifo)
			CAN1->FFA1R |= 1u << b;
	}
	CAN1->FA1R = (1u << nb) - 1u;
	CAN1->FMR &= ~CAN_FMR_FINIT;

	can.rx_head = can.rx_tail = 0;
	can_busoff_init(&can.busoff);
	CAN1->IER = CAN_IER_FMPIE0 | CAN_IER_FOVIE0 | CAN_IER_BOFIE | CAN_IER_EPVIE | CAN_IER_ERRIE;
	irq_enable_at(IRQ_CAN1_RX0, prio_rx);
	irq_enable_at(IRQ_CAN1_SCE, prio_sce);
	CAN1->MCR &= ~CAN_MCR_INRQ;
	if (!wait_msr(CAN_MSR_INAK, 0))
		return SWELL_ESTATE; /* no 11 recessive bits: bus stuck dominant or no transceiver */
	can.running = 1;
	return SWELL_OK;
}

enum swell_err can_send(const struct fw_frame *f)
{
	uint32_t tsr, primask;
	unsigned mb;
	int abort;
	enum swell_err err;

	if (!f || f->len > 8 || f->id > 0x7FFu)
		return SWELL_EINVAL;
	if (!can.running || (CAN1->ESR & CAN_ESR_BOFF))
		return SWELL_ESTATE;
	primask = irq_save();
	tsr = CAN1->TSR;
	err = can_tx_pick(tsr >> CAN_TSR_TME_SHIFT, can.pend_id, f->id, &mb, &abort);
	if (err == SWELL_OK && abort) {
		uint32_t n;

		CAN1->TSR = CAN_TSR_ABRQ(mb);
		/* An abort completes at once unless the frame is on the wire (then it may still be sent):
		 * bounded wait for the mailbox to empty. */
		for (n = 0; n < 2000u && !(CAN1->TSR & CAN_TSR_TME(mb)); n++)
			;
		if (CAN1->TSR & CAN_TSR_TME(mb))
			can.tx_aborted++;
		else
			err = SWELL_ESIZE;
	}
	if (err == SWELL_OK) {
		struct can_txmb *m = &CAN1->TX[mb];

		m->TDTR = f->len;
		m->TDLR = (uint32_t)f->data[0] | (uint32_t)f->data[1] << 8 | (uint32_t)f->data[2] << 16 |
			(uint32_t)f->data[3] << 24;
		m->TDHR = (uint32_t)f->data[4] | (uint32_t)f->data[5] << 8 | (uint32_t)f->data[6] << 16 |
			(uint32_t)f->data[7] << 24;
		can.pend_id[mb] = f->id;
		m->TIR = (f->id << CAN_TIR_STID_SHIFT) | CAN_TIR_TXRQ;
	}
	irq_restore(primask);
	return err;
}

enum swell_err can_recv(struct fw_frame *f)
{
	if (can.rx_head == can.rx_tail)
		return SWELL_ETRUNC;
	*f = can.rx[can.rx_tail % RX_RING];
	can.rx_tail++;
	return SWELL_OK;
}

void can_abort_all(void)
{
	if (!can.running)
		return;
	CAN1->TSR = CAN_TSR_ABRQ(0) | CAN_TSR_ABRQ(1) | CAN_TSR_ABRQ(2);
}

void isr_can1_rx0(void)
{
	uint32_t n;

	if (CAN1->RF0R & CAN_RFR_FOVR) {
		CAN1->RF0R = CAN_RFR_FOVR; /* rc_w1 */
		can.rx_overruns++;
	}
	/* Bounded: the FIFO holds at most 3 frames. */
	for (n = 0; n < 3 && (CAN1->RF0R & CAN_RFR_FMP_MASK); n++) {
		const struct can_rxfifo *r = &CAN1->RX[0];
		uint32_t rir = r->RIR, lo = r->RDLR, hi = r->RDHR;
		struct fw_frame *f = &can.rx[can.rx_head % RX_RING];

		if (can.rx_head - can.rx_tail < RX_RING && !(rir & (CAN_TIR_IDE | CAN_TIR_RTR))) {
			f->id = rir >> CAN_TIR_STID_SHIFT;
			f->len = (uint8_t)(r->RDTR & 0xFu);
			if (f->len > 8)
				f->len = 8;
			for (unsigned i = 0; i < 4; i++) {
				f->data[i] = (uint8_t)(lo >> (8 * i));
				f->data[4 + i] = (uint8_t)(hi >> (8 * i));
			}
			can.rx_head++;
		} else {
			can.rx_dropped++;
		}
		CAN1->RF0R = CAN_RFR_RFOM; /* release the FIFO output mailbox */
	}
}

/* Status change: error passive or bus-off. Bus-off means our force frames are not getting out:
 * zero the force at once; recovery is requested from can_poll after the hold-off. */
void isr_can1_sce(void)
{
	uint32_t esr = CAN1->ESR;

	CAN1->MSR = CAN_MSR_ERRI; /* rc_w1 */
	if ((esr & CAN_ESR_BOFF) && !can.busoff.pending) {
		can_busoff_event(&can.busoff, can.now_ms);
		safe_force_zero();
	}
}

void can_poll(uint32_t now_ms)
{
	uint32_t primask;
	int due, ok = 0;

	can.now_ms = now_ms;
	primask = irq_save();
	due = can_busoff_due(&can.busoff, now_ms);
	irq_restore(primask);
	if (!due)
		return;
	/* Manual recovery (ABOM = 0): a pass through initialisation mode clears the error state once
	 * the controller has seen 128 x 11 recessive bits. Bounded waits; on failure try again later. */
	CAN1->MCR |= CAN_MCR_INRQ;
	if (wait_msr(CAN_MSR_INAK, CAN_MSR_INAK)) {
		CAN1->MCR &= ~CAN_MCR_INRQ;
		ok = wait_msr(CAN_MSR_INAK, 0);
	}
	primask = irq_save();
	can_busoff_attempted(&can.busoff, now_ms, ok);
	irq_restore(primask);
}

uint32_t can_bus_offs(void)
{
	return can.busoff.count;
}
