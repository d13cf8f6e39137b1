/* The HapticMaster's TCP framing, both ways: an 8-byte header (the text's length, 32-bit big-endian,
 * then four zero bytes) and that many bytes of text. Buffers are byte arrays with a fill count; the
 * client (swell-ctl --device hm:) and the emulator (swell-hm --serve) share this. Host only. */
#ifndef SWELL_HM_FRAME_H
#define SWELL_HM_FRAME_H

#include <stddef.h>
#include <stdint.h>

#define SWELL_HM_FRAME_HDR 8u

/* Appends the framed text (n bytes) to buf, *used of cap bytes filled; -1 when it does not fit
 * (nothing written). */
int swell_hm_frame_put(uint8_t *buf, size_t cap, size_t *used, const char *text, size_t n);

/* The first frame of buf (used bytes, at least a header): 1 when it is whole (its text at
 * buf + SWELL_HM_FRAME_HDR), 0 when more bytes must come, -1 when the header is bad: a length of 0
 * or over max, or bytes 4-7 not zero. *len: the header's length; pad (may be NULL): bytes 4-7. */
int swell_hm_frame_next(const uint8_t *buf, size_t used, uint32_t max, uint32_t *len, uint32_t *pad);

/* Removes the first frame, of len bytes of text, from buf. */
void swell_hm_frame_pop(uint8_t *buf, size_t *used, uint32_t len);

/* Sends the first want bytes of buf (of *used) on the socket fd without blocking and removes what
 * went: *sent bytes. 0 while the connection is fine (the rest waits while the socket is full), -1
 * when it failed. */
int swell_hm_frame_flush(int fd, uint8_t *buf, size_t *used, size_t want, size_t *sent);

#endif
