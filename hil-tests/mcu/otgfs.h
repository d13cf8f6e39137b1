/* A register-level model of the STM32F405 USB on-the-go full-speed core (OTG_FS) in device mode,
 * RM0090 section 34, as far as firmware/stm32f405/src/usb.c uses it, with the calls a USB host
 * makes on the bus (reset, SETUP, OUT, IN) so that a test or a USB/IP server can enumerate the
 * device and move bulk packets.
 *
 * The emulator side: the core occupies OTGFS_MODEL_BASE .. + OTGFS_MODEL_SIZE and raises IRQ
 * OTGFS_MODEL_IRQ (OTG_FS); every access is 32 bits at an offset from the base, with the virtual
 * time in ticks of the caller's clock (time_hz at otgfs_init; monotonic, the same clock for every
 * call). The model keeps no wall time and
 * allocates nothing: struct otgfs is the whole state (the caller's storage).
 *
 * What is modelled (register names as in RM0090 34.16, programming model 34.17):
 *   GRSTCTL   CSRST, RXFFLSH, TXFFLSH with TXFNUM (one FIFO or all); each clears on the second
 *             read of GRSTCTL after the write ("several clocks"); AHBIDL always set
 *   GINTSTS   CMOD (device), SOF, RXFLVL, ESUSP, USBSUSP, USBRST, ENUMDNE, IEPINT, OEPINT,
 *             GINAKEFF, GONAKEFF, the rc_w1 bits; GINTMSK; GAHBCFG GINTMSK and TXFELVL; the IRQ line
 *   GRXSTSR/P the receive FIFO (GRXFSIZ words): status entries interleaved with data words
 *             (34.17.6 "Packet read from the receive FIFO"): OUT data (2), OUT transfer completed
 *             (3, XFRC when popped), SETUP stage done (4, STUP when popped, pushed at the first
 *             token after the SETUP), SETUP data (6)
 *   DIEPTXF0/DIEPTXFx, DTXFSTSx: four transmit FIFOs in the 320-word FIFO RAM (34.13); the
 *             window at 0x1000 + n * 0x1000 pushes to IN endpoint n's FIFO (TXFNUM), and pops the
 *             receive FIFO on read
 *   DCFG (DAD, taken at once; the old address still answers the status stage of SET_ADDRESS),
 *   DCTL (SDIS, SGINAK/CGINAK, SGONAK/CGONAK), DSTS (SUSPSTS, ENUMSPD full speed, FNSOF)
 *   DIEPCTLx/DOEPCTLx (MPSIZ, USBAEP, DPID, NAKSTS, EPTYP, STALL, TXFNUM, CNAK, SNAK, SD0PID,
 *             SD1PID, EPDIS, EPENA), DIEPTSIZx/DOEPTSIZx (XFRSIZ, PKTCNT, STUPCNT),
 *             DIEPINTx/DOEPINTx (rc_w1; TXFE read-only), DIEPMSK, DOEPMSK, DAINT, DAINTMSK,
 *             DIEPEMPMSK, for endpoints 0..3
 *   GCCFG (PWRDWN, NOVBUSSENS, VBUSBSEN), GUSBCFG (FDMOD, FHMOD), PCGCCTL (STPPCLK)
 * The device is attached to the bus (D+ pull-up) while its clock runs, it is in device mode,
 * the PHY is powered (PWRDWN), VBUS is seen (NOVBUSSENS, or VBUSBSEN with VBUS), the PHY clock
 * runs (STPPCLK clear) and SDIS is clear. The cable (otgfs_host_unplug, otgfs_host_reset): pulled
 * out, the attached device sees idle lines and goes through the early suspend (ESUSP) into the
 * suspend (USBSUSP, DSTS.SUSPSTS); a host's reset brings it back. Other registers keep what is
 * written (host mode, OTG protocol, a host's suspend and resume signalling (WKUPINT), remote
 * wakeup, VBUS session end (GOTGINT.SEDET), isochronous transfers are not modelled).
 *
 * Programming errors the real core would turn into lost or wrong data are recorded
 * (otgfs_fault): a transmit FIFO overflow, FIFOs outside the FIFO RAM or overlapping, a read of
 * an empty receive FIFO, a status pop with unread data, a transmit FIFO with data left after its
 * endpoint's transfer. */
#ifndef SWELL_MCU_OTGFS_H
#define SWELL_MCU_OTGFS_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define OTGFS_MODEL_BASE 0x50000000u
#define OTGFS_MODEL_SIZE 0x40000u /* registers, FIFO windows, direct FIFO RAM access */
#define OTGFS_MODEL_IRQ 67 /* OTG_FS global interrupt */

#define OTGFS_EPS 4 /* endpoints 0..3, each IN and OUT */
#define OTGFS_RAM_WORDS 320 /* 1.25 KB of FIFO RAM */
#define OTGFS_RESET_MS 10u /* a host's bus reset: 10 ms (USB 2.0 7.1.7.5) */
#define OTGFS_SUSPEND_MS 3u /* idle lines: ESUSP after 3 ms, USBSUSP 3 ms later (RM0090 34.6) */
/* full-speed frames: 1 ms */
#define OTGFS_NO_EVENT UINT64_MAX

/* A transaction's handshake as the host sees it. */
enum otgfs_resp {
	OTGFS_ACK = 0, /* SETUP or OUT accepted, or IN data returned (possibly zero-length) */
	OTGFS_NAK, /* the endpoint is not ready: retry later */
	OTGFS_STALL, /* the endpoint is halted or the request refused */
	OTGFS_NORESP, /* no answer: detached, in reset, another address, an inactive endpoint, a full
			 receive FIFO on SETUP, a packet over the endpoint's size */
};

struct otgfs_txfifo {
	uint32_t words[OTGFS_RAM_WORDS];
	uint32_t head, count; /* ring: count words from head */
};

struct otgfs_stats {
	uint32_t setups, out_acks, in_acks, naks, stalls, noresps, resets;
	uint32_t unplugs, suspends, suspends_seen; /* cable pulled; USBSUSP raised; acknowledged by the driver */
};

struct otgfs {
	/* the registers as stored (computed bits are added on read) */
	uint32_t gotgctl, gahbcfg, gusbcfg, grstctl, gintsts, gintmsk, grxfsiz, dieptxf[OTGFS_EPS], gccfg;
	uint32_t dcfg, dctl, diepmsk, doepmsk, daintmsk, diepempmsk, pcgcctl;
	uint32_t diepctl[OTGFS_EPS], diepint[OTGFS_EPS], dieptsiz[OTGFS_EPS];
	uint32_t doepctl[OTGFS_EPS], doepint[OTGFS_EPS], doeptsiz[OTGFS_EPS];
	uint32_t other[0x1000 / 4]; /* every other register below 0x1000: kept as written */
	uint8_t grstctl_reads; /* GRSTCTL reads since a self-clearing command */
	/* receive FIFO: status and data words in one ring */
	uint32_t rx[OTGFS_RAM_WORDS];
	uint32_t rx_head, rx_count, rx_data_left; /* data words of the popped entry still to read */
	uint8_t setup_pending; /* a SETUP awaits its "SETUP stage done" entry */
	struct otgfs_txfifo tx[OTGFS_EPS];
	/* bus */
	int clock_on, vbus;
	int bus; /* 0 detached, 1 reset in progress, 2 running */
	uint64_t hz, now, reset_end, sof_origin, last_frame;
	uint8_t old_addr, old_addr_valid; /* the address before the last DAD change (SET_ADDRESS) */
	/* the cable: out (otgfs_host_unplug) until a host resets the bus; the lines idle since idle_since;
	 * suspend_stage 0 counting, 1 ESUSP raised, 2 USBSUSP raised (suspended, DSTS.SUSPSTS) */
	int cable_out;
	uint8_t suspend_stage;
	uint64_t idle_since, suspend_at, suspend_seen_at; /* the last USBSUSP raised, acknowledged */
	/* diagnostics */
	const char *fault;
	uint32_t faults;
	struct otgfs_stats stats;
};

/* Power-on reset (RM0090 34.16 reset values), clock running, VBUS present, detached; time in ticks
 * of time_hz (at least 1000: 1 ms is a frame). */
void otgfs_init(struct otgfs *m, uint64_t time_hz);

/* 32-bit register access at offset (below OTGFS_MODEL_SIZE) at virtual time now. */
uint32_t otgfs_read(struct otgfs *m, uint32_t offset, uint64_t now);
void otgfs_write(struct otgfs *m, uint32_t offset, uint32_t value, uint64_t now);

/* Let virtual time reach now: end of a bus reset (ENUMDNE), start of frames (SOF). */
void otgfs_advance(struct otgfs *m, uint64_t now);

/* The next time the model changes by itself (end of reset, the next SOF when SOF is unmasked),
 * OTGFS_NO_EVENT if none. */
uint64_t otgfs_next_event_ns(const struct otgfs *m);

/* Level of the OTG_FS interrupt line (GAHBCFG.GINTMSK and a pending unmasked GINTSTS bit). */
int otgfs_irq(const struct otgfs *m);

/* RCC AHB2ENR OTGFSEN: with the clock off, reads return 0, writes are ignored, the device
 * detaches. */
void otgfs_set_clock(struct otgfs *m, int on);
void otgfs_set_vbus(struct otgfs *m, int present);

/* The first programming error seen (a constant string) or NULL; how many so far. */
const char *otgfs_fault(const struct otgfs *m);
uint32_t otgfs_fault_count(const struct otgfs *m);

/* Host side. Each call first lets time reach now. */

/* Is the D+ pull-up on (the host sees a full-speed device)? */
int otgfs_host_attached(const struct otgfs *m);
/* Drive a bus reset now; it ends (ENUMDNE) OTGFS_RESET_MS later. Returns 0, -1 when detached. A
 * reset is a host on the cable: it plugs an unplugged cable back in and ends a suspend (SUSPSTS). */
int otgfs_host_reset(struct otgfs *m, uint64_t now);
/* The cable pulled out now: no host, no frames, nothing answered; with the pull-up on, the idle lines
 * raise GINTSTS.ESUSP 3 ms later and USBSUSP (DSTS.SUSPSTS) 3 ms after that (RM0090 34.6,
 * "Suspended state"; with NOVBUSSENS no session end is seen). Until the next otgfs_host_reset. */
void otgfs_host_unplug(struct otgfs *m, uint64_t now);
/* 0 while the cable is out. */
int otgfs_host_plugged(const struct otgfs *m);
/* Reset done, device attached: transactions are answered. */
int otgfs_host_running(const struct otgfs *m);
/* The device address the core answers (DCFG.DAD), for a host's checks. */
uint8_t otgfs_host_address(const struct otgfs *m);

enum otgfs_resp otgfs_host_setup(struct otgfs *m, uint64_t now, uint8_t addr, const uint8_t setup[8]);
enum otgfs_resp otgfs_host_out(struct otgfs *m, uint64_t now, uint8_t addr, uint8_t ep, const uint8_t *data,
			       uint32_t len);
/* IN token; on ACK *len bytes (at most the endpoint's packet size, never more than cap: a larger
 * packet is babble, counted as a fault of the host) are in buf. */
enum otgfs_resp otgfs_host_in(struct otgfs *m, uint64_t now, uint8_t addr, uint8_t ep, uint8_t *buf, uint32_t cap,
			      uint32_t *len);

#ifdef __cplusplus
}
#endif

#endif
