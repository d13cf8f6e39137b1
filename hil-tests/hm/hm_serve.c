/* The HapticMaster's TCP interface; see hm_serve.h. */
#define _GNU_SOURCE
#include "hm_serve.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "hm_client.h"
#include "swell/link.h"
#include "swell/num.h"

int hm_serve_parse(const char *spec, struct sockaddr_in *sa, char *err, size_t errlen)
{
	char addr[48] = "127.0.0.1";
	const char *colon = strrchr(spec, ':');
	long port = HM_SERVE_PORT;

	if (colon || strspn(spec, "0123456789") == strlen(spec)) {
		const char *p = colon ? colon + 1 : spec;

		if (colon) {
			if ((size_t)(colon - spec) >= sizeof(addr) || colon == spec) {
				snprintf(err, errlen, "'%s' is not [ADDR:]PORT", spec);
				return -1;
			}
			memcpy(addr, spec, (size_t)(colon - spec));
			addr[colon - spec] = '\0';
		}
		if (swell_parse_long(p, 10, 0, 65535, &port) < 0) {
			snprintf(err, errlen, "port '%s' is not a number in [0, 65535] (0: any free port)", p);
			return -1;
		}
	} else {
		if (strlen(spec) >= sizeof(addr)) {
			snprintf(err, errlen, "address '%.40s...' is too long", spec);
			return -1;
		}
		snprintf(addr, sizeof(addr), "%s", spec);
	}
	memset(sa, 0, sizeof(*sa));
	sa->sin_family = AF_INET;
	sa->sin_port = htons((uint16_t)port);
	if (inet_pton(AF_INET, addr, &sa->sin_addr) != 1) {
		snprintf(err, errlen, "'%s' is not a dotted IPv4 address", addr);
		return -1;
	}
	return 0;
}

int hm_serve_open(struct hm_serve *s, const char *spec, char *err, size_t errlen)
{
	struct sockaddr_in sa;
	socklen_t sl = sizeof(sa);
	char addr[INET_ADDRSTRLEN];
	long port;
	int k, one = 1;

	memset(s, 0, sizeof(*s));
	s->lfd = -1;
	for (k = 0; k < HM_SERVE_CLIENTS; k++)
		s->c[k].fd = -1;
	if (hm_serve_parse(spec, &sa, err, errlen) < 0)
		return -1;
	inet_ntop(AF_INET, &sa.sin_addr, addr, sizeof(addr));
	port = ntohs(sa.sin_port);
	s->lfd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (s->lfd < 0) {
		snprintf(err, errlen, "socket: %s", strerror(errno));
		return -1;
	}
	setsockopt(s->lfd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
	if (bind(s->lfd, (struct sockaddr *)&sa, sizeof(sa)) < 0 || listen(s->lfd, HM_SERVE_CLIENTS) < 0) {
		snprintf(err, errlen, "cannot listen on %s:%ld: %s", addr, port, strerror(errno));
		close(s->lfd);
		s->lfd = -1;
		return -1;
	}
	if (getsockname(s->lfd, (struct sockaddr *)&sa, &sl) == 0) /* port 0: the one the kernel chose */
		port = ntohs(sa.sin_port);
	snprintf(s->name, sizeof(s->name), "tcp %s:%ld", addr, port);
	return 0;
}

static void drop(struct hm_serve *s, struct hm_dev *d, int k)
{
	close(s->c[k].fd);
	memset(&s->c[k], 0, sizeof(s->c[k]));
	s->c[k].fd = -1;
	hm_dev_client_gone(d, k);
}

/* Bytes of the reply buffer that may go out now (an injected delay holds the later ones). */
static size_t releasable(struct hm_conn *c, int64_t now)
{
	size_t end = c->out_len;
	unsigned k;

	for (k = 0; k < c->held_n; k++)
		if (c->held_until_ns[k] > now) {
			end = k ? c->held_end[k - 1] : 0;
			if (end > c->out_len)
				end = c->out_len;
			/* held replies are after any unheld bytes queued before the delay began */
			return end;
		}
	return end;
}

/* Writes what waits in the reply buffer; 0 while the connection is fine. */
static int flush(struct hm_serve *s, int k)
{
	struct hm_conn *c = &s->c[k];
	unsigned j, keep;
	size_t n;
	const int rc =
		swell_hm_frame_flush(c->fd, c->out, &c->out_len, releasable(c, (int64_t)swell_link_now_ns()), &n);

	s->st.bytes_out += (uint64_t)n;
	for (j = keep = 0; j < c->held_n; j++) {
		if (c->held_end[j] <= n)
			continue; /* sent */
		c->held_end[keep] = c->held_end[j] - n;
		c->held_until_ns[keep++] = c->held_until_ns[j];
	}
	c->held_n = keep;
	return rc;
}

/* Queues one framed reply; -1 when the client has not read enough of the earlier ones. */
static int queue(struct hm_serve *s, int k, const char *text, size_t n)
{
	struct hm_conn *c = &s->c[k];

	if (swell_hm_frame_put(c->out, sizeof(c->out), &c->out_len, text, n) < 0)
		return -1;
	s->st.replies++;
	if (s->reply_delay_ns > 0 && c->held_n < HM_SERVE_HELD) {
		c->held_end[c->held_n] = c->out_len;
		c->held_until_ns[c->held_n++] = (int64_t)swell_link_now_ns() + s->reply_delay_ns;
		s->st.delayed_replies++;
	}
	return 0;
}

static void accept_new(struct hm_serve *s)
{
	int fd, k, one = 1, sndbuf = HM_SERVE_SNDBUF;

	while ((fd = accept4(s->lfd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC)) >= 0) {
		for (k = 0; k < HM_SERVE_CLIENTS && s->c[k].fd >= 0; k++)
			;
		if (k == HM_SERVE_CLIENTS) {
			s->st.refused_full++;
			close(fd);
			continue;
		}
		setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
		/* a fixed kernel buffer too: a client that does not read is found out within a fraction of a
		 * second, not after megabytes of autotuned buffer */
		setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof(sndbuf));
		setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof(one)); /* arrival times, for the age */
		memset(&s->c[k], 0, sizeof(s->c[k]));
		s->c[k].fd = fd;
		s->st.accepted++;
	}
}

/* recv that also keeps the kernel's arrival time of the data read */
static ssize_t recv_stamped(struct hm_conn *c)
{
	union {
		char buf[CMSG_SPACE(sizeof(struct timespec))];
		struct cmsghdr align;
	} ctl;
	struct iovec iov = { c->in + c->in_len, sizeof(c->in) - c->in_len };
	struct msghdr mh;
	struct cmsghdr *cm;
	ssize_t n;

	memset(&mh, 0, sizeof(mh));
	mh.msg_iov = &iov;
	mh.msg_iovlen = 1;
	mh.msg_control = ctl.buf;
	mh.msg_controllen = sizeof(ctl.buf);
	n = recvmsg(c->fd, &mh, MSG_DONTWAIT);
	if (n <= 0)
		return n;
	for (cm = CMSG_FIRSTHDR(&mh); cm; cm = CMSG_NXTHDR(&mh, cm))
		if (cm->cmsg_level == SOL_SOCKET && cm->cmsg_type == SCM_TIMESTAMPNS) {
			struct timespec ts;

			memcpy(&ts, CMSG_DATA(cm), sizeof(ts));
			c->arrived_rt_ns = (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
		}
	return n;
}

void hm_serve_applied(struct hm_serve *s)
{
	struct timespec t;
	int64_t age;

	if (!s->tick_first_rt_ns)
		return;
	clock_gettime(CLOCK_REALTIME, &t);
	age = (int64_t)t.tv_sec * 1000000000 + t.tv_nsec - s->tick_first_rt_ns;
	s->tick_first_rt_ns = 0;
	if (age < 0)
		age = 0;
	s->st.age_hist[age / 1000 > HM_SERVE_AGE_US ? HM_SERVE_AGE_US : age / 1000]++;
	s->st.ages++;
	if (age > s->st.age_max_ns)
		s->st.age_max_ns = age;
}

/* Runs the whole requests in the input buffer, up to the tick's budget. -1: drop the client. */
static int run_requests(struct hm_serve *s, struct hm_dev *d, int k, int64_t now_ns)
{
	struct hm_conn *c = &s->c[k];
	int done = 0;
	size_t k2;

	while (c->in_len >= SWELL_HM_FRAME_HDR && done < HM_SERVE_REQS_PER_TICK) {
		uint32_t len, pad;
		const int whole = swell_hm_frame_next(c->in, c->in_len, HM_SERVE_TEXT_MAX, &len, &pad);
		size_t n;

		if (whole < 0) {
			n = (size_t)snprintf(
				s->reply, sizeof(s->reply),
				"--- ERROR: bad header (length %u, bytes 4-7 %08x; text of 1..%d bytes after a "
				"big-endian length and four zero bytes): closing",
				len, pad, HM_SERVE_TEXT_MAX);
			s->st.drop_header++;
			queue(s, k, s->reply, n);
			c->closing = 1;
			c->in_len = 0;
			return 0;
		}
		if (!whole) {
			if (!c->partial_since_ns)
				c->partial_since_ns = now_ns;
			return 0;
		}
		c->partial_since_ns = 0;
		if (c->arrived_rt_ns && (!s->tick_first_rt_ns || c->arrived_rt_ns < s->tick_first_rt_ns))
			s->tick_first_rt_ns = c->arrived_rt_ns;
		for (k2 = 0; k2 < len; k2++) {
			uint8_t b = c->in[SWELL_HM_FRAME_HDR + k2];

			if (!((b >= 0x20 && b < 0x7f) || b == '\t' || b == '\n' || b == '\r'))
				break;
		}
		s->st.requests++;
		if (k2 < len) {
			s->st.garbage++;
			d->errors++;
			n = (size_t)snprintf(s->reply, sizeof(s->reply),
					     "--- ERROR: byte 0x%02x at offset %zu is not text: request ignored",
					     c->in[SWELL_HM_FRAME_HDR + k2], k2);
		} else {
			n = hm_dev_request(d, k, (const char *)c->in + SWELL_HM_FRAME_HDR, len, s->reply,
					   sizeof(s->reply));
		}
		if (queue(s, k, s->reply, n) < 0) {
			s->st.drop_not_reading++;
			return -1;
		}
		swell_hm_frame_pop(c->in, &c->in_len, len);
		done++;
	}
	if (c->in_len >= SWELL_HM_FRAME_HDR && done == HM_SERVE_REQS_PER_TICK)
		s->st.deferred_ticks++;
	if (c->in_len > 0 && c->in_len < SWELL_HM_FRAME_HDR && !c->partial_since_ns)
		c->partial_since_ns = now_ns;
	return 0;
}

void hm_serve_poll(struct hm_serve *s, struct hm_dev *d, int64_t now_ns)
{
	int k;

	if (s->lfd < 0)
		return;
	accept_new(s);
	for (k = 0; k < HM_SERVE_CLIENTS; k++) {
		struct hm_conn *c = &s->c[k];
		ssize_t n;

		if (c->fd < 0)
			continue;
		if (c->closing) {
			if (flush(s, k) < 0 || c->out_len == 0)
				drop(s, d, k);
			continue;
		}
		/* read only what fits: a client's flood waits in its own socket, not in ours */
		if (c->in_len < sizeof(c->in)) {
			n = recv_stamped(c);
			if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
				s->st.vanished++;
				drop(s, d, k);
				continue;
			}
			if (n > 0) {
				c->in_len += (size_t)n;
				s->st.bytes_in += (uint64_t)n;
			}
		}
		if (run_requests(s, d, k, now_ns) < 0) {
			drop(s, d, k);
			continue;
		}
		if (flush(s, k) < 0) {
			s->st.vanished++;
			drop(s, d, k);
			continue;
		}
		if (c->partial_since_ns && now_ns - c->partial_since_ns > (int64_t)HM_SERVE_STALL_MS * 1000000) {
			s->st.drop_stalled++;
			drop(s, d, k);
		}
	}
}

void hm_serve_inject_reset(struct hm_serve *s, struct hm_dev *d)
{
	struct linger lg = { 1, 0 };
	int k;

	for (k = 0; k < HM_SERVE_CLIENTS; k++)
		if (s->c[k].fd >= 0) {
			setsockopt(s->c[k].fd, SOL_SOCKET, SO_LINGER, &lg, sizeof(lg)); /* close sends RST */
			s->st.injected_resets++;
			drop(s, d, k);
		}
}

void hm_serve_inject_garbage(struct hm_serve *s)
{
	static const char junk[16] = "\x7f\xde\xad garbage !!\x01";
	int k;

	for (k = 0; k < HM_SERVE_CLIENTS; k++) {
		struct hm_conn *c = &s->c[k];

		if (c->fd < 0 || c->out_len + sizeof(junk) > sizeof(c->out))
			continue;
		memcpy(c->out + c->out_len, junk, sizeof(junk));
		c->out_len += sizeof(junk);
		s->st.injected_garbage++;
	}
}

int hm_serve_clients(const struct hm_serve *s)
{
	int k, n = 0;

	for (k = 0; k < HM_SERVE_CLIENTS; k++)
		n += s->c[k].fd >= 0;
	return n;
}

void hm_serve_close(struct hm_serve *s, struct hm_dev *d)
{
	int k;

	for (k = 0; k < HM_SERVE_CLIENTS; k++)
		if (s->c[k].fd >= 0)
			drop(s, d, k);
	if (s->lfd >= 0)
		close(s->lfd);
	s->lfd = -1;
}
