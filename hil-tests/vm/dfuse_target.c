/* DfuSe state machine of the emulated STM32F405 ROM bootloader. See dfuse_target.h. */
#include "dfuse_target.h"

#include <stdio.h>
#include <string.h>

#define CMD_GET 0x00u
#define CMD_SET_ADDRESS 0x21u
#define CMD_ERASE 0x41u

static const char *const state_names[] = {
	"appIDLE",        "appDETACH",        "dfuIDLE",     "dfuDNLOAD-SYNC",         "dfuDNBUSY",
	"dfuDNLOAD-IDLE", "dfuMANIFEST-SYNC", "dfuMANIFEST", "dfuMANIFEST-WAIT-RESET", "dfuUPLOAD-IDLE",
	"dfuERROR",
};

const char *swell_dfu_state_name(unsigned state)
{
	return state < sizeof(state_names) / sizeof(state_names[0]) ? state_names[state] : "?";
}

const char *swell_dfu_status_name(unsigned status)
{
	static const char *const names[SWELL_DFU_ERR_STALLEDPKT + 1] = {
		[SWELL_DFU_OK] = "OK",
		[SWELL_DFU_ERR_TARGET] = "errTARGET",
		[SWELL_DFU_ERR_CHECK_ERASED] = "errCHECK_ERASED",
		[SWELL_DFU_ERR_ADDRESS] = "errADDRESS",
		[SWELL_DFU_ERR_UNKNOWN] = "errUNKNOWN",
		[SWELL_DFU_ERR_STALLEDPKT] = "errSTALLEDPKT",
	};

	return status <= SWELL_DFU_ERR_STALLEDPKT && names[status] ? names[status] : "?";
}

int swell_dfuse_sector(uint32_t off, uint32_t *start, uint32_t *size)
{
	if (off >= SWELL_DFUSE_FLASH_SIZE)
		return -1;
	*size = off < 0x10000u ? 0x4000u : off < 0x20000u ? 0x10000u : 0x20000u; /* sectors 0-3, 4, 5-11 */
	*start = off & ~(*size - 1u); /* each sector starts at a multiple of its size */
	return 0;
}

enum swell_err swell_dfuse_init(struct swell_dfuse *t, uint32_t poll_ms, unsigned xfer)
{
	if (xfer == 0 || xfer > SWELL_DFUSE_XFER_MAX)
		return SWELL_ERANGE;
	memset(t, 0, sizeof(*t));
	t->xfer = (uint16_t)xfer;
	memset(t->flash, 0xFF, sizeof(t->flash));
	t->pointer = SWELL_DFUSE_FLASH_BASE;
	t->state = SWELL_DFU_IDLE; /* status SWELL_DFU_OK: 0 */
	t->poll_ms = poll_ms;
	return SWELL_OK;
}

int swell_dfuse_set_alt(struct swell_dfuse *t, unsigned alt)
{
	if (alt >= SWELL_DFUSE_ALTS)
		return -1;
	t->alt = (uint8_t)alt;
	return 0;
}

void swell_dfuse_take_dirty(struct swell_dfuse *t, uint32_t *lo, uint32_t *hi)
{
	const int any = t->dirty_lo < t->dirty_hi;

	*lo = any ? t->dirty_lo : 0;
	*hi = any ? t->dirty_hi : 0;
	t->dirty_lo = t->dirty_hi = 0;
}

static void dirty(struct swell_dfuse *t, uint32_t lo, uint32_t hi)
{
	const int any = t->dirty_lo < t->dirty_hi; /* else the range is [lo, hi) alone */

	t->dirty_lo = any && t->dirty_lo < lo ? t->dirty_lo : lo;
	t->dirty_hi = any && t->dirty_hi > hi ? t->dirty_hi : hi;
}

/* Flash offset of [addr, addr + len) or -1 when any of it is outside the flash. */
static int64_t flash_offset(uint32_t addr, uint32_t len)
{
	if (addr < SWELL_DFUSE_FLASH_BASE)
		return -1;
	uint64_t off = (uint64_t)addr - SWELL_DFUSE_FLASH_BASE;
	if (off + len > SWELL_DFUSE_FLASH_SIZE || (len == 0 && off >= SWELL_DFUSE_FLASH_SIZE))
		return -1;
	return (int64_t)off;
}

static uint32_t le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* A request that is not valid in this state: stall, dfuERROR, errSTALLEDPKT (DFU 1.1 section 6.1). */
static enum swell_dfuse_reply stall(struct swell_dfuse *t, const char *why)
{
	snprintf(t->note, sizeof(t->note), "stalled: %s in %s", why, swell_dfu_state_name(t->state));
	t->state = SWELL_DFU_ERROR;
	t->status = SWELL_DFU_ERR_STALLEDPKT;
	t->refused++;
	return SWELL_DFUSE_STALL;
}

/* The DfuSe command of a block 0 DNLOAD. Returns the DFU status; changes nothing unless OK. */
static uint8_t run_command(struct swell_dfuse *t)
{
	const uint8_t *d = t->block_data;
	uint32_t addr, start, size;

	if (t->block_len == 5 && d[0] == CMD_SET_ADDRESS) {
		addr = le32(d + 1);
		if (flash_offset(addr, 0) < 0) {
			snprintf(t->note, sizeof(t->note), "set address 0x%08x refused: outside flash", (unsigned)addr);
			return SWELL_DFU_ERR_ADDRESS;
		}
		t->pointer = addr;
		snprintf(t->note, sizeof(t->note), "set address 0x%08x", (unsigned)addr);
		return SWELL_DFU_OK;
	}
	if (t->block_len == 5 && d[0] == CMD_ERASE) {
		addr = le32(d + 1);
		int64_t off = flash_offset(addr, 1);
		if (off < 0 || swell_dfuse_sector((uint32_t)off, &start, &size) != 0) {
			snprintf(t->note, sizeof(t->note), "erase 0x%08x refused: outside flash", (unsigned)addr);
			return SWELL_DFU_ERR_ADDRESS;
		}
		memset(t->flash + start, 0xFF, size);
		dirty(t, start, start + size);
		t->sectors_erased++;
		snprintf(t->note, sizeof(t->note), "erase 0x%08x: sector 0x%08x, %u KiB", (unsigned)addr,
			 (unsigned)(SWELL_DFUSE_FLASH_BASE + start), (unsigned)(size / 1024u));
		return SWELL_DFU_OK;
	}
	if (t->block_len == 1 && d[0] == CMD_ERASE) {
		memset(t->flash, 0xFF, sizeof(t->flash));
		dirty(t, 0, SWELL_DFUSE_FLASH_SIZE);
		t->sectors_erased += 12;
		snprintf(t->note, sizeof(t->note), "mass erase");
		return SWELL_DFU_OK;
	}
	snprintf(t->note, sizeof(t->note), "command 0x%02x of %u bytes refused: unknown", (unsigned)d[0],
		 (unsigned)t->block_len);
	return SWELL_DFU_ERR_UNKNOWN;
}

/* A data block: (wBlockNum - 2) * wTransferSize + pointer. */
static uint8_t run_write(struct swell_dfuse *t)
{
	uint32_t addr = (uint32_t)(t->block - 2u) * t->xfer + t->pointer;
	int64_t off = flash_offset(addr, t->block_len);

	if (off < 0) {
		snprintf(t->note, sizeof(t->note), "write %u bytes at 0x%08x refused: outside flash",
			 (unsigned)t->block_len, (unsigned)addr);
		return SWELL_DFU_ERR_ADDRESS;
	}
	for (uint32_t i = 0; i < t->block_len; i++) {
		if (t->flash[off + i] != 0xFF) {
			snprintf(t->note, sizeof(t->note), "write %u bytes at 0x%08x refused: 0x%08x not erased",
				 (unsigned)t->block_len, (unsigned)addr, (unsigned)(addr + i));
			return SWELL_DFU_ERR_CHECK_ERASED;
		}
	}
	memcpy(t->flash + off, t->block_data, t->block_len);
	dirty(t, (uint32_t)off, (uint32_t)off + t->block_len);
	t->bytes_written += t->block_len;
	snprintf(t->note, sizeof(t->note), "write %u bytes at 0x%08x (block %u)", (unsigned)t->block_len,
		 (unsigned)addr, (unsigned)t->block);
	return SWELL_DFU_OK;
}

static enum swell_dfuse_reply dnload(struct swell_dfuse *t, const struct swell_dfuse_setup *s, const uint8_t *out,
				     size_t out_len)
{
	if (t->state != SWELL_DFU_IDLE && t->state != SWELL_DFU_DNLOAD_IDLE)
		return stall(t, "DNLOAD");
	if (s->length > t->xfer || out_len != s->length)
		return stall(t, "DNLOAD longer than wTransferSize or cut short");
	if (s->length == 0) {
		/* DfuSe leave: after a set address, start the image at the pointer. */
		if (t->state != SWELL_DFU_DNLOAD_IDLE)
			return stall(t, "zero-length DNLOAD");
		t->state = SWELL_DFU_MANIFEST_SYNC;
		snprintf(t->note, sizeof(t->note), "leave request (jump to 0x%08x)", (unsigned)t->pointer);
		return SWELL_DFUSE_ACK;
	}
	memcpy(t->block_data, out, out_len);
	t->block = s->value;
	t->block_len = s->length;
	t->state = SWELL_DFU_DNLOAD_SYNC;
	snprintf(t->note, sizeof(t->note), "block %u, %u bytes received", (unsigned)s->value, (unsigned)s->length);
	return SWELL_DFUSE_ACK;
}

static enum swell_dfuse_reply upload(struct swell_dfuse *t, const struct swell_dfuse_setup *s, uint8_t *in,
				     size_t in_cap, size_t *in_len)
{
	size_t n;

	if (t->state != SWELL_DFU_IDLE && t->state != SWELL_DFU_UPLOAD_IDLE)
		return stall(t, "UPLOAD");
	if (s->length > t->xfer || s->length > in_cap || s->length == 0)
		return stall(t, "UPLOAD longer than wTransferSize");
	if (t->alt != 0) {
		stall(t, "UPLOAD");
		t->status = SWELL_DFU_ERR_TARGET;
		snprintf(t->note, sizeof(t->note), "upload refused: alternate setting %u is not emulated",
			 (unsigned)t->alt);
		return SWELL_DFUSE_STALL;
	}
	if (s->value == 0) { /* DfuSe "get commands" */
		const uint8_t cmds[] = { CMD_GET, CMD_SET_ADDRESS, CMD_ERASE };
		n = s->length < sizeof(cmds) ? s->length : sizeof(cmds);
		memcpy(in, cmds, n);
		snprintf(t->note, sizeof(t->note), "get commands");
	} else if (s->value == 1) {
		return stall(t, "UPLOAD block 1");
	} else {
		uint64_t addr = (uint64_t)(s->value - 2u) * t->xfer + t->pointer;
		int64_t off = addr > UINT32_MAX ? -1 : flash_offset((uint32_t)addr, 1);
		if (off < 0) {
			stall(t, "UPLOAD");
			t->status = SWELL_DFU_ERR_ADDRESS;
			snprintf(t->note, sizeof(t->note), "upload at 0x%08llx refused: outside flash",
				 (unsigned long long)addr);
			return SWELL_DFUSE_STALL;
		}
		n = s->length;
		if ((uint64_t)off + n > SWELL_DFUSE_FLASH_SIZE) /* a short block ends the upload */
			n = SWELL_DFUSE_FLASH_SIZE - (size_t)off;
		memcpy(in, t->flash + off, n);
		t->bytes_read += (uint32_t)n;
		snprintf(t->note, sizeof(t->note), "read %u bytes at 0x%08x (block %u)", (unsigned)n, (unsigned)addr,
			 (unsigned)s->value);
	}
	t->state = n < s->length ? SWELL_DFU_IDLE : SWELL_DFU_UPLOAD_IDLE;
	*in_len = n;
	return SWELL_DFUSE_DATA;
}

static enum swell_dfuse_reply getstatus(struct swell_dfuse *t, const struct swell_dfuse_setup *s, uint8_t *in,
					size_t in_cap, size_t *in_len)
{
	uint32_t poll = 0;

	if (s->length < 6 || in_cap < 6)
		return stall(t, "GETSTATUS shorter than 6 bytes");
	switch (t->state) {
	case SWELL_DFU_DNLOAD_SYNC: /* run the operation now; the answer is "busy" */
		if (t->alt != 0) {
			t->result = SWELL_DFU_ERR_TARGET;
			snprintf(t->note, sizeof(t->note), "refused: alternate setting %u is not emulated",
				 (unsigned)t->alt);
		} else if (t->block == 0) {
			t->result = run_command(t);
		} else if (t->block == 1) {
			t->result = SWELL_DFU_ERR_UNKNOWN;
			snprintf(t->note, sizeof(t->note), "block 1 refused: not defined by DfuSe");
		} else {
			t->result = run_write(t);
		}
		t->state = SWELL_DFU_DNBUSY;
		poll = t->poll_ms;
		break;
	case SWELL_DFU_DNBUSY: /* the operation is done: its result */
		if (t->result != SWELL_DFU_OK) {
			t->state = SWELL_DFU_ERROR;
			t->status = t->result;
			t->refused++;
		} else {
			t->state = SWELL_DFU_DNLOAD_IDLE;
		}
		snprintf(t->note, sizeof(t->note), "%s", t->result == SWELL_DFU_OK ? "done" : "failed");
		break;
	case SWELL_DFU_MANIFEST_SYNC: /* not manifestation tolerant: report dfuMANIFEST and go */
		t->state = SWELL_DFU_MANIFEST;
		t->leave = 1;
		t->leave_address = t->pointer;
		snprintf(t->note, sizeof(t->note), "manifest: leaving DFU, start at 0x%08x", (unsigned)t->pointer);
		break;
	default:
		t->note[0] = '\0';
		break;
	}
	in[0] = t->status;
	for (int k = 0; k < 3; k++) /* bwPollTimeout, 24 bits little-endian */
		in[1 + k] = (uint8_t)(poll >> (8 * k));
	in[4] = t->state;
	in[5] = 0; /* iString */
	if (t->state == SWELL_DFU_MANIFEST)
		t->state = SWELL_DFU_MANIFEST_WAIT_RESET;
	*in_len = 6;
	return SWELL_DFUSE_DATA;
}

enum swell_dfuse_reply swell_dfuse_request(struct swell_dfuse *t, const struct swell_dfuse_setup *s, const uint8_t *out,
					   size_t out_len, uint8_t *in, size_t in_cap, size_t *in_len)
{
	const int is_in = (s->request_type & 0x80u) != 0;

	*in_len = 0;
	t->note[0] = '\0';
	if ((s->request_type & 0x7Fu) != 0x21u) /* class request to an interface */
		return stall(t, "not a class request to the interface");
	if (t->state == SWELL_DFU_MANIFEST_WAIT_RESET) {
		snprintf(t->note, sizeof(t->note), "ignored: waiting for reset after leave");
		return SWELL_DFUSE_STALL;
	}
	switch (s->request) {
	case SWELL_DFU_DNLOAD:
		return is_in ? stall(t, "DNLOAD as IN") : dnload(t, s, out, out_len);
	case SWELL_DFU_UPLOAD:
		return is_in ? upload(t, s, in, in_cap, in_len) : stall(t, "UPLOAD as OUT");
	case SWELL_DFU_GETSTATUS:
		return is_in ? getstatus(t, s, in, in_cap, in_len) : stall(t, "GETSTATUS as OUT");
	case SWELL_DFU_CLRSTATUS:
		if (is_in || t->state != SWELL_DFU_ERROR)
			return stall(t, "CLRSTATUS");
		t->state = SWELL_DFU_IDLE;
		t->status = SWELL_DFU_OK;
		snprintf(t->note, sizeof(t->note), "status cleared");
		return SWELL_DFUSE_ACK;
	case SWELL_DFU_GETSTATE:
		if (!is_in || s->length < 1 || in_cap < 1)
			return stall(t, "GETSTATE");
		in[0] = t->state;
		*in_len = 1;
		return SWELL_DFUSE_DATA;
	case SWELL_DFU_ABORT:
		if (is_in ||
		    (t->state != SWELL_DFU_IDLE && t->state != SWELL_DFU_DNLOAD_SYNC &&
		     t->state != SWELL_DFU_DNLOAD_IDLE && t->state != SWELL_DFU_MANIFEST_SYNC &&
		     t->state != SWELL_DFU_UPLOAD_IDLE))
			return stall(t, "ABORT");
		t->state = SWELL_DFU_IDLE;
		snprintf(t->note, sizeof(t->note), "aborted to dfuIDLE");
		return SWELL_DFUSE_ACK;
	default: /* DETACH is for run-time mode; the ROM bootloader is in DFU mode */
		return stall(t, "request not supported in DFU mode");
	}
}
