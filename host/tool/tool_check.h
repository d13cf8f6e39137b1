/* swell-tool check: the chain from this computer to the handle, one line a link of it, each failure
 * with its fix (docs/first-contact.md): the host link, the controller (protocol and firmware version,
 * state), the device (heard, its rate, status), the round trip of a request, the frame (where the
 * handle is in the pool), the force limits (against the first-run limits unless told otherwise), the
 * e-stop and the effects left on a HapticMaster (with --hm: its own TCP interface, read only). */
#ifndef SWELL_TOOL_CHECK_H
#define SWELL_TOOL_CHECK_H

#include "tool_session.h"

#define TOOL_CHECK_FORCE_N 2.0 /* the first-run limits (swell-ctl's for a HapticMaster) */
#define TOOL_CHECK_RATE_N_S 20.0
#define TOOL_CHECK_RTT_MS 20.0

struct tool_check_opts {
	const char *link; /* the link's spelling, for the messages */
	const char *hm; /* HOST[:PORT] of the HapticMaster's TCP interface, or NULL */
	double max_force_N, max_rate_N_s, max_rtt_ms;
	int timeout_ms;
};

/* Runs every check and prints one line for each ("ok", "FAIL" with the fix, or "skip" with why);
 * open_rc is tool_open's result (open_err its reason): the checks after a failed link are skipped.
 * TOOL_OK only when none failed; TOOL_CHECK_FAILED otherwise. */
int tool_check(struct tool_session *s, enum tool_rc open_rc, const char *open_err, const struct tool_check_opts *co);

#endif
