#ifndef SWELL_VIEW_TEST_REPLAY_DRAIN_H
#define SWELL_VIEW_TEST_REPLAY_DRAIN_H

#include <stddef.h>
#include <stdint.h>

#include "feed.h"

/* Opens a replay source (spec "replay-fast:FILE"), delivers the whole recording to f at the
 * display time now_us and closes it. Returns the frames delivered; 0 and the reason in err when
 * it cannot be opened. */
uint32_t replay_drain(const char *spec, struct view_feed *f, uint64_t now_us, char *err, size_t errlen);

#endif
