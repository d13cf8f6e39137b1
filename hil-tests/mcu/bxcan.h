/* A register-level model of the STM32F405's bxCAN (CAN1 at 0x40006400), following RM0090 section 32
 * "Controller area network (bxCAN)". Pure C11 with no emulator dependency: the emulator forwards
 * CAN1's 32-bit register accesses with its clock (bxcan_read, bxcan_write), lets bus time pass
 * (bxcan_advance, bxcan_next_event_ns), delivers frames from other nodes (bxcan_bus_rx), collects the
 * node's frames (on_tx) and samples the four interrupt lines (bxcan_irq_lines).
 *
 * Time: every call carries the caller's clock in ns (never going back: an earlier time counts as the
 * latest one seen). The model first brings its state up to that time, so events between two calls
 * happen at their exact times whenever they are looked at. Durations on the bus come from CAN_BTR and
 * the APB1 clock (RM0090 32.7.7): one bit = (BRP + 1)(TS1 + TS2 + 3) periods of PCLK1, and n bits last
 * ceil(n * that / PCLK1) ns, rounded up per event.
 *
 * Frame length: exact, per ISO 11898-1 classic frames: the stuffed bits from SOF to the CRC's last bit
 * (the CRC-15 and the stuff bits of this very frame), then CRC delimiter, ACK slot, ACK delimiter and
 * 7 EOF bits; 3 bits of intermission separate the node's frames. See bxcan_frame_bits.
 *
 * Not modelled (the rest of the bus is ideal): bit-level arbitration against other nodes (frames from
 * bxcan_bus_rx never collide with the node's own; lost arbitration is injected), error frames from
 * other nodes beyond injected counts, time-triggered mode (TTCM: no time stamps, TIME fields read 0),
 * debug freeze (DBF), CAN2. */
#ifndef SWELL_MCU_BXCAN_H
#define SWELL_MCU_BXCAN_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define BXCAN_BASE 0x40006400u
#define BXCAN_SIZE 0x400u

/* Register offsets (RM0090 32.9.5, register map). */
#define BXCAN_MCR 0x000u
#define BXCAN_MSR 0x004u
#define BXCAN_TSR 0x008u
#define BXCAN_RF0R 0x00Cu
#define BXCAN_RF1R 0x010u
#define BXCAN_IER 0x014u
#define BXCAN_ESR 0x018u
#define BXCAN_BTR 0x01Cu
#define BXCAN_TIR(m) (0x180u + 0x10u * (m))
#define BXCAN_TDTR(m) (0x184u + 0x10u * (m))
#define BXCAN_TDLR(m) (0x188u + 0x10u * (m))
#define BXCAN_TDHR(m) (0x18Cu + 0x10u * (m))
#define BXCAN_RIR(f) (0x1B0u + 0x10u * (f))
#define BXCAN_RDTR(f) (0x1B4u + 0x10u * (f))
#define BXCAN_RDLR(f) (0x1B8u + 0x10u * (f))
#define BXCAN_RDHR(f) (0x1BCu + 0x10u * (f))
#define BXCAN_FMR 0x200u
#define BXCAN_FM1R 0x204u
#define BXCAN_FS1R 0x20Cu
#define BXCAN_FFA1R 0x214u
#define BXCAN_FA1R 0x21Cu
#define BXCAN_FR1(b) (0x240u + 8u * (b))
#define BXCAN_FR2(b) (0x244u + 8u * (b))

#define BXCAN_FILTER_BANKS 28u

/* Register bits (RM0090 32.9.2 to 32.9.4). */
#define BXCAN_MCR_INRQ (1u << 0)
#define BXCAN_MCR_SLEEP (1u << 1)
#define BXCAN_MCR_TXFP (1u << 2)
#define BXCAN_MCR_RFLM (1u << 3)
#define BXCAN_MCR_NART (1u << 4)
#define BXCAN_MCR_AWUM (1u << 5)
#define BXCAN_MCR_ABOM (1u << 6)
#define BXCAN_MCR_TTCM (1u << 7)
#define BXCAN_MCR_RESET (1u << 15)
#define BXCAN_MCR_DBF (1u << 16)

#define BXCAN_MSR_INAK (1u << 0)
#define BXCAN_MSR_SLAK (1u << 1)
#define BXCAN_MSR_ERRI (1u << 2)
#define BXCAN_MSR_WKUI (1u << 3)
#define BXCAN_MSR_SLAKI (1u << 4)
#define BXCAN_MSR_TXM (1u << 8)
#define BXCAN_MSR_RXM (1u << 9)
#define BXCAN_MSR_SAMP (1u << 10)
#define BXCAN_MSR_RX (1u << 11)

#define BXCAN_TSR_RQCP(m) (1u << (8 * (m) + 0))
#define BXCAN_TSR_TXOK(m) (1u << (8 * (m) + 1))
#define BXCAN_TSR_ALST(m) (1u << (8 * (m) + 2))
#define BXCAN_TSR_TERR(m) (1u << (8 * (m) + 3))
#define BXCAN_TSR_ABRQ(m) (1u << (8 * (m) + 7))
#define BXCAN_TSR_CODE_SHIFT 24
#define BXCAN_TSR_TME(m) (1u << (26 + (m)))
#define BXCAN_TSR_LOW(m) (1u << (29 + (m)))

#define BXCAN_RFR_FMP_MASK 3u
#define BXCAN_RFR_FULL (1u << 3)
#define BXCAN_RFR_FOVR (1u << 4)
#define BXCAN_RFR_RFOM (1u << 5)

#define BXCAN_IER_TMEIE (1u << 0)
#define BXCAN_IER_FMPIE0 (1u << 1)
#define BXCAN_IER_FFIE0 (1u << 2)
#define BXCAN_IER_FOVIE0 (1u << 3)
#define BXCAN_IER_FMPIE1 (1u << 4)
#define BXCAN_IER_FFIE1 (1u << 5)
#define BXCAN_IER_FOVIE1 (1u << 6)
#define BXCAN_IER_EWGIE (1u << 8)
#define BXCAN_IER_EPVIE (1u << 9)
#define BXCAN_IER_BOFIE (1u << 10)
#define BXCAN_IER_LECIE (1u << 11)
#define BXCAN_IER_ERRIE (1u << 15)
#define BXCAN_IER_WKUIE (1u << 16)
#define BXCAN_IER_SLKIE (1u << 17)

#define BXCAN_ESR_EWGF (1u << 0)
#define BXCAN_ESR_EPVF (1u << 1)
#define BXCAN_ESR_BOFF (1u << 2)
#define BXCAN_ESR_LEC_SHIFT 4
#define BXCAN_ESR_LEC_MASK (7u << 4)
#define BXCAN_ESR_TEC_SHIFT 16
#define BXCAN_ESR_REC_SHIFT 24

/* Last error codes (CAN_ESR.LEC). */
enum bxcan_lec {
	BXCAN_LEC_NONE = 0,
	BXCAN_LEC_STUFF = 1,
	BXCAN_LEC_FORM = 2,
	BXCAN_LEC_ACK = 3,
	BXCAN_LEC_BIT_RECESSIVE = 4,
	BXCAN_LEC_BIT_DOMINANT = 5,
	BXCAN_LEC_CRC = 6,
	BXCAN_LEC_SOFTWARE = 7,
};

#define BXCAN_BTR_SILM (1u << 31)
#define BXCAN_BTR_LBKM (1u << 30)

#define BXCAN_TIR_TXRQ (1u << 0)
#define BXCAN_TIR_RTR (1u << 1)
#define BXCAN_TIR_IDE (1u << 2)
#define BXCAN_TIR_STID_SHIFT 21
#define BXCAN_TIR_EXID_SHIFT 3

#define BXCAN_FMR_FINIT (1u << 0)
#define BXCAN_FMR_CAN2SB_SHIFT 8

/* The four interrupt lines (RM0090 32.8), bits of bxcan_irq_lines. */
#define BXCAN_IRQ_TX (1u << 0)
#define BXCAN_IRQ_RX0 (1u << 1)
#define BXCAN_IRQ_RX1 (1u << 2)
#define BXCAN_IRQ_SCE (1u << 3)

/* A classic CAN frame. id: 11 bits (ide = 0) or 29 bits (ide = 1); dlc 0..15 (more than 8 means 8
 * data bytes on the wire); data[i] for i < min(dlc, 8) unless rtr. */
struct bxcan_frame {
	uint32_t id;
	uint8_t ide, rtr, dlc;
	uint8_t data[8];
};

typedef void (*bxcan_tx_fn)(void *user, const struct bxcan_frame *f, uint64_t t_ns);

struct bxcan_txmb {
	uint32_t tir, tdtr, tdlr, tdhr;
	uint32_t seq; /* request order, for TXFP = 1 */
};

struct bxcan_rxmb {
	uint32_t rir, rdtr, rdlr, rdhr;
};

/* The whole state; treat as opaque (read it through the registers). No allocation. */
struct bxcan {
	uint32_t pclk_hz;
	bxcan_tx_fn on_tx;
	void *user;

	uint32_t mcr, msr, tsr, rfr[2], ier, esr, btr;
	struct bxcan_txmb tx[3];
	struct bxcan_rxmb rx[2][3];
	uint8_t rx_head[2];
	uint32_t fmr, fm1r, fs1r, ffa1r, fa1r;
	uint32_t fr[BXCAN_FILTER_BANKS][2];

	uint16_t tec; /* the 9-bit transmit error counter; > 255: bus-off */
	uint8_t rec;
	uint8_t mode; /* sleep, initialisation or normal (bxcan.c) */
	uint8_t boff;
	int8_t tx_mb; /* mailbox on the wire, -1: none */
	uint8_t tx_outcome;
	uint32_t tx_seq;
	uint64_t t_ns; /* the model's time */
	uint64_t tx_end_ns; /* end of the attempt on the wire */
	uint64_t bus_free_ns; /* earliest start of the node's next frame */
	uint64_t sync_end_ns; /* 11 recessive bits seen: leaving initialisation or sleep (UINT64_MAX: none) */
	uint64_t boff_end_ns; /* bus-off recovery done (UINT64_MAX: none running or paused) */
	uint64_t boff_start_ns; /* start of the running part of the recovery */
	uint16_t boff_occ_left; /* occurrences of 11 recessive bits still needed; 0: no recovery */
	uint8_t dom_role; /* stuck dominant bus: 0 not affected, 1 receiver, 2 transmitter */
	uint64_t dom_next_ns; /* next +8 on the error counter of a stuck dominant bus */

	/* injected bus conditions (they belong to the bus: a reset keeps them) */
	bool no_ack, dominant;
	uint32_t tx_errors_left, arb_lost_left;
};

/* Set up a model at reset with this APB1 clock (Hz). -1 (nothing done) when b is NULL or pclk_hz is 0. */
int bxcan_init(struct bxcan *b, uint32_t pclk_hz);
/* The transmitted-frame callback (NULL: none): called when a frame of the node completes on the bus
 * (acknowledged, or in loopback mode), at the time of its last EOF bit. Not called in silent mode. */
void bxcan_set_tx_callback(struct bxcan *b, bxcan_tx_fn fn, void *user);
/* The APB1 clock; -1 (unchanged) for 0. Takes effect for the next duration computed. */
int bxcan_set_pclk(struct bxcan *b, uint32_t pclk_hz);
/* Register reset (RCC's CAN1 reset, power-on): every register to its RM0090 reset value, the node in
 * sleep mode, counters 0, mailboxes empty; clock, callback, time and injections kept. */
void bxcan_reset(struct bxcan *b);

/* 32-bit register access at offset off from BXCAN_BASE (unaligned or unknown offsets: read 0, write
 * ignored). */
uint32_t bxcan_read(struct bxcan *b, uint32_t off, uint64_t now_ns);
void bxcan_write(struct bxcan *b, uint32_t off, uint32_t value, uint64_t now_ns);

/* Let bus time pass up to now_ns; the time of the next internal event (UINT64_MAX: none pending). */
void bxcan_advance(struct bxcan *b, uint64_t now_ns);
uint64_t bxcan_next_event_ns(const struct bxcan *b);

/* Outcomes of bxcan_bus_rx. FIFO0, FIFO1, FILTERED and LOST: the node received the frame and
 * acknowledged it (in silent mode it receives without acknowledging: CAN_BTR.SILM); OFF: it did not. */
enum bxcan_rx {
	BXCAN_RX_FIFO0 = 0, /* stored in FIFO 0 (RFLM = 0 overrun: it replaced the newest one) */
	BXCAN_RX_FIFO1 = 1,
	BXCAN_RX_FILTERED = 2, /* received and acknowledged, no active filter matched (or FINIT = 1) */
	BXCAN_RX_LOST = 3, /* matched, FIFO full and locked (RFLM = 1): discarded, FOVR set */
	BXCAN_RX_OFF = 4, /* not received: sleep, initialisation, bus-off or loopback mode */
	BXCAN_RX_INVALID = 5, /* bad frame (id or dlc out of range): nothing changed */
};
/* A frame from another node, its EOF completing at t_ns. In sleep mode its SOF sets WKUI and, with
 * AWUM, wakes the node (the frame itself is lost: the node synchronises after it). */
enum bxcan_rx bxcan_bus_rx(struct bxcan *b, const struct bxcan_frame *f, uint64_t t_ns);

/* Interrupt lines (RM0090 32.8), BXCAN_IRQ_* bits, as levels at the model's time (the last call that
 * carried a time: call bxcan_advance first to sample them at a later time). */
unsigned bxcan_irq_lines(const struct bxcan *b);

/* Bus errors for tests and the emulator. Transmit errors count per attempt of the node's frames. */
/* While on, nobody acknowledges the node's frames (ignored in loopback mode): each attempt ends in an
 * ACK error at the ACK slot. */
void bxcan_inject_no_ack(struct bxcan *b, bool on);
/* The next n attempts end in a bit error (LEC bit recessive), detected at the ACK slot. */
void bxcan_inject_tx_errors(struct bxcan *b, uint32_t n);
/* The next n attempts lose arbitration (ALST; no error counted); the bus stays busy for as long as
 * the node's own frame would have lasted. */
void bxcan_inject_arbitration_lost(struct bxcan *b, uint32_t n);
/* The node goes bus-off at now_ns (TEC over 255); an attempt on the wire fails. */
void bxcan_inject_bus_off(struct bxcan *b, uint64_t now_ns);
/* n receive errors (REC + 1 each, LEC CRC) at now_ns; only while in normal mode and not bus-off. */
void bxcan_inject_rx_errors(struct bxcan *b, uint32_t n, uint64_t now_ns);
/* From now_ns the bus is stuck dominant (on) or free again (off). While stuck: CAN_MSR.RX and SAMP
 * read 0, no 11 recessive bits come (initialisation and sleep cannot be left, a bus-off recovery
 * pauses with the occurrences it has counted), nothing is sent or received. A node in normal mode
 * detects an error at once: a frame on the wire fails (bit error, TEC + 8: the node is transmitter),
 * else a stuff error (REC + 1: receiver); then ISO 11898-1's rule for dominant bits after an error
 * flag adds 8 to that counter at the 14th dominant bit and every 8 bits after (a transmitter goes
 * bus-off, a receiver's REC stops at 255). Once free, the node sends again after 11 recessive bits. */
void bxcan_inject_bus_dominant(struct bxcan *b, bool on, uint64_t now_ns);

/* Helpers, public for the tests. CRC-15 of the first nbits bits of bytes (MSB first; ISO 11898-1
 * polynomial 0x4599, initial 0). */
uint16_t bxcan_crc15(const uint8_t *bytes, uint32_t nbits);
/* Bits of f on the wire from SOF to the last EOF bit, with its exact stuff bits; *stuffed (NULL: not
 * wanted) gets the stuffed count from SOF to the CRC's last bit. 0 for an invalid frame. */
uint32_t bxcan_frame_bits(const struct bxcan_frame *f, uint32_t *stuffed);
/* Duration of nbits bits at the current CAN_BTR and clock, in ns (rounded up). */
uint64_t bxcan_bits_ns(const struct bxcan *b, uint32_t nbits);

#ifdef __cplusplus
}
#endif

#endif
