#include "loopback.h"

#include <string.h>

#include "console.h"

static struct fw_frame ring[LOOPBACK_DEPTH];
static uint32_t head, tail; /* free-running; head - tail frames queued */

/* SWELL_EINVAL for a bad frame, SWELL_ESIZE when full; nothing queued then. */
static enum swell_err loopback_send(const struct fw_frame *f)
{
	if (!f || f->len > 8 || f->id > 0x7FFu)
		return SWELL_EINVAL;
	if (head - tail >= LOOPBACK_DEPTH)
		return SWELL_ESIZE;
	ring[head % LOOPBACK_DEPTH] = *f;
	head++;
	return SWELL_OK;
}

/* SWELL_ETRUNC when empty. */
static enum swell_err loopback_recv(struct fw_frame *f)
{
	if (head == tail)
		return SWELL_ETRUNC;
	*f = ring[tail % LOOPBACK_DEPTH];
	tail++;
	return SWELL_OK;
}

/* Every frame comes back unchanged and in order; a full ring refuses the next frame. */
int loopback_selftest(void)
{
	struct fw_frame f, g;
	uint32_t n, bad = 0, refused = 0;

	for (n = 0; n < LOOPBACK_DEPTH + 2; n++) {
		f = (struct fw_frame){ .id = 0x100u + n, .len = (uint8_t)(n % 9) };
		memset(f.data, (int)(0xA0u + n), f.len);
		if (loopback_send(&f) == SWELL_ESIZE)
			refused++;
	}
	for (n = 0; n < LOOPBACK_DEPTH; n++) {
		if (loopback_recv(&g) != SWELL_OK || g.id != 0x100u + n || g.len != n % 9 ||
		    (g.len && g.data[g.len - 1] != (uint8_t)(0xA0u + n)))
			bad++;
	}
	if (loopback_recv(&g) != SWELL_ETRUNC)
		bad++;
	con_puts_u32("link: loopback ", LOOPBACK_DEPTH);
	con_puts_u32(" frames round trip, ", bad);
	con_puts_u32(" bad, ", refused);
	con_puts(" refused when full (expect 2)\n");
	return bad == 0 && refused == 2;
}
