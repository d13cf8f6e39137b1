/* The HapticMaster's TCP framing; see swell/hm_frame.h. */
#define _GNU_SOURCE
#include "swell/hm_frame.h"

#include <errno.h>
#include <string.h>
#include <sys/socket.h>

static uint32_t be32(const uint8_t *p)
{
	return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

int swell_hm_frame_put(uint8_t *buf, size_t cap, size_t *used, const char *text, size_t n)
{
	uint8_t *h = buf + *used;

	if (*used + SWELL_HM_FRAME_HDR + n > cap)
		return -1;
	h[0] = (uint8_t)(n >> 24);
	h[1] = (uint8_t)(n >> 16);
	h[2] = (uint8_t)(n >> 8);
	h[3] = (uint8_t)n;
	memset(h + 4, 0, 4);
	memcpy(h + SWELL_HM_FRAME_HDR, text, n);
	*used += SWELL_HM_FRAME_HDR + n;
	return 0;
}

int swell_hm_frame_next(const uint8_t *buf, size_t used, uint32_t max, uint32_t *len, uint32_t *pad)
{
	const uint32_t p = be32(buf + 4);

	*len = be32(buf);
	if (pad)
		*pad = p;
	if (*len == 0 || *len > max || p != 0)
		return -1;
	return used >= SWELL_HM_FRAME_HDR + (size_t)*len;
}

void swell_hm_frame_pop(uint8_t *buf, size_t *used, uint32_t len)
{
	const size_t n = SWELL_HM_FRAME_HDR + (size_t)len;

	memmove(buf, buf + n, *used - n);
	*used -= n;
}

int swell_hm_frame_flush(int fd, uint8_t *buf, size_t *used, size_t want, size_t *sent)
{
	*sent = 0;
	while (want > 0) {
		const ssize_t n = send(fd, buf, want, MSG_DONTWAIT | MSG_NOSIGNAL);

		if (n < 0)
			return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? 0 : -1;
		memmove(buf, buf + n, *used - (size_t)n);
		*used -= (size_t)n;
		want -= (size_t)n;
		*sent += (size_t)n;
	}
	return 0;
}
