/* Inside of a host link: every implementation starts its struct with struct swell_link. */
#ifndef SWELL_LINK_PRIV_H
#define SWELL_LINK_PRIV_H

#include "swell/link.h"

struct swell_link_ops {
	int (*send)(struct swell_link *l, const struct swell_frame *f);
	int (*recv)(struct swell_link *l, struct swell_frame *f, int timeout_ms);
	void (*close)(struct swell_link *l);
	int (*poll_fd)(const struct swell_link *l); /* NULL: nothing to poll */
};

struct swell_link {
	const struct swell_link_ops *ops;
	enum swell_carrier carrier;
	int fd; /* UDP, CAN: the socket, closed by swell_link_close_fd */
	struct swell_link_counters cnt;
	char name[80];
};

/* Milliseconds left until deadline_ns (CLOCK_MONOTONIC); -1 if timeout_ms was < 0. */
int swell_link_ms_left(uint64_t deadline_ns, int timeout_ms);
uint64_t swell_link_deadline(int timeout_ms);
/* Until fd is readable (0), the deadline (-ETIMEDOUT) or an error (a negative errno); a signal does not
 * end the wait. */
int swell_link_wait_in(int fd, uint64_t deadline_ns, int timeout_ms);
/* v as n little-endian bytes at p; returns p + n. */
uint8_t *swell_put_le(uint8_t *p, uint64_t v, int n);
/* The close of a link whose only resource is its socket. */
void swell_link_close_fd(struct swell_link *l);

#endif
