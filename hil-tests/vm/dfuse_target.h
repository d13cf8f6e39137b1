/* The DfuSe side of an emulated STM32F405 ROM bootloader: the DFU 1.1 state machine with ST's
 * DfuSe extensions (set address pointer 0x21, erase 0x41, data blocks at
 * (wBlockNum - 2) * wTransferSize + pointer, leave by a zero-length DNLOAD) over a 1 MiB flash
 * held in RAM. No I/O and no allocation: swell-vm-dfuse (vm-dfuse.c) moves the control requests
 * between it and the USB device controller and keeps the flash in a file.
 *
 * Like the ROM bootloader, an operation runs when the host asks GETSTATUS after the DNLOAD: that
 * answer says dfuDNBUSY (with the poll timeout) and the next GETSTATUS gives the result,
 * dfuDNLOAD-IDLE or dfuERROR with the DFU status. A refused operation changes no flash byte. */
#ifndef SWELL_DFUSE_TARGET_H
#define SWELL_DFUSE_TARGET_H

#include <stddef.h>
#include <stdint.h>

#include "swell/err.h"

#define SWELL_DFUSE_FLASH_BASE 0x08000000u
#define SWELL_DFUSE_FLASH_SIZE (1024u * 1024u)
#define SWELL_DFUSE_XFER_MAX 2048u /* the F405 ROM's wTransferSize, the largest block held */
#define SWELL_DFUSE_ALTS 4u /* alternate settings; only 0 (internal flash) is emulated */
#define SWELL_DFUSE_NOTE_MAX 120u

/* DFU 1.1 class requests (bRequest). */
enum swell_dfu_request {
	SWELL_DFU_DETACH = 0,
	SWELL_DFU_DNLOAD = 1,
	SWELL_DFU_UPLOAD = 2,
	SWELL_DFU_GETSTATUS = 3,
	SWELL_DFU_CLRSTATUS = 4,
	SWELL_DFU_GETSTATE = 5,
	SWELL_DFU_ABORT = 6,
};

/* DFU 1.1 bState values. */
enum swell_dfu_state {
	SWELL_DFU_APP_IDLE = 0,
	SWELL_DFU_APP_DETACH = 1,
	SWELL_DFU_IDLE = 2,
	SWELL_DFU_DNLOAD_SYNC = 3,
	SWELL_DFU_DNBUSY = 4,
	SWELL_DFU_DNLOAD_IDLE = 5,
	SWELL_DFU_MANIFEST_SYNC = 6,
	SWELL_DFU_MANIFEST = 7,
	SWELL_DFU_MANIFEST_WAIT_RESET = 8,
	SWELL_DFU_UPLOAD_IDLE = 9,
	SWELL_DFU_ERROR = 10,
};

/* DFU 1.1 bStatus values (the ones this target reports). */
enum swell_dfu_status {
	SWELL_DFU_OK = 0x00,
	SWELL_DFU_ERR_TARGET = 0x01, /* operation on an alternate setting that is not emulated */
	SWELL_DFU_ERR_CHECK_ERASED = 0x05, /* write to bytes that are not erased (0xFF) */
	SWELL_DFU_ERR_ADDRESS = 0x08, /* address outside the 1 MiB flash */
	SWELL_DFU_ERR_UNKNOWN = 0x0E, /* malformed or unknown DfuSe command */
	SWELL_DFU_ERR_STALLEDPKT = 0x0F, /* request not valid in this state */
};

/* What the caller does with ep0 after a request. */
enum swell_dfuse_reply {
	SWELL_DFUSE_ACK, /* status stage: no data (OUT requests) */
	SWELL_DFUSE_DATA, /* send *in_len bytes of the IN buffer */
	SWELL_DFUSE_STALL, /* stall ep0 (state is dfuERROR, status errSTALLEDPKT or errADDRESS) */
};

struct swell_dfuse_setup {
	uint8_t request_type; /* bmRequestType: 0x21 class OUT to the interface, 0xA1 class IN */
	uint8_t request;
	uint16_t value; /* wValue: the block number for DNLOAD/UPLOAD */
	uint16_t index; /* wIndex: the interface */
	uint16_t length; /* wLength */
};

struct swell_dfuse {
	uint8_t flash[SWELL_DFUSE_FLASH_SIZE]; /* byte i is at SWELL_DFUSE_FLASH_BASE + i */
	uint32_t pointer; /* DfuSe address pointer */
	uint8_t state; /* enum swell_dfu_state */
	uint8_t status; /* enum swell_dfu_status */
	uint8_t alt; /* alternate setting in use */
	uint8_t result; /* status of the operation reported busy */
	uint32_t poll_ms; /* bwPollTimeout of the busy answers */
	uint16_t xfer; /* wTransferSize, 1..SWELL_DFUSE_XFER_MAX */
	uint16_t block; /* pending DNLOAD: block number, bytes */
	uint16_t block_len;
	uint8_t block_data[SWELL_DFUSE_XFER_MAX];
	uint32_t dirty_lo, dirty_hi; /* flash offsets changed since swell_dfuse_take_dirty, lo >= hi: none */
	uint32_t leave_address; /* valid once leave is set */
	int leave; /* the host made the target leave DFU (dfuMANIFEST reported) */
	/* Totals, for the log and the tests. */
	uint32_t bytes_written, bytes_read, sectors_erased, refused;
	char note[SWELL_DFUSE_NOTE_MAX]; /* what the last request did, one line, no newline */
};

/* Erased flash (0xFF), dfuIDLE, pointer at the flash base, alternate setting 0; transfer size xfer
 * (the F405 ROM: 2048). SWELL_ERANGE (nothing changed) for xfer outside 1..SWELL_DFUSE_XFER_MAX. */
enum swell_err swell_dfuse_init(struct swell_dfuse *t, uint32_t poll_ms, unsigned xfer);

/* One DFU class request. out/out_len: the data stage of an OUT request (already received);
 * in/in_cap: room for an IN data stage, *in_len set when the reply is SWELL_DFUSE_DATA. */
enum swell_dfuse_reply swell_dfuse_request(struct swell_dfuse *t, const struct swell_dfuse_setup *s, const uint8_t *out,
					   size_t out_len, uint8_t *in, size_t in_cap, size_t *in_len);

/* SET_INTERFACE: 0 on success, -1 for an alternate setting that does not exist (nothing changed). */
int swell_dfuse_set_alt(struct swell_dfuse *t, unsigned alt);

/* The flash offsets [*lo, *hi) changed since the last call (*lo == *hi: nothing); clears them. */
void swell_dfuse_take_dirty(struct swell_dfuse *t, uint32_t *lo, uint32_t *hi);

/* The sector holding flash offset off: 4 x 16 KiB, 1 x 64 KiB, 7 x 128 KiB. -1 when off is outside. */
int swell_dfuse_sector(uint32_t off, uint32_t *start, uint32_t *size);

const char *swell_dfu_state_name(unsigned state);
const char *swell_dfu_status_name(unsigned status);

#endif
