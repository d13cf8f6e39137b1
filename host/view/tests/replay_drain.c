/* A C side for the tests: sources.h holds C11 atomics, which C++ cannot include. */
#include "replay_drain.h"

#include "sources.h"

uint32_t replay_drain(const char *spec, struct view_feed *f, uint64_t now_us, char *err, size_t errlen)
{
	struct source s = {0};
	uint32_t n = 0;

	if (!source_open(&s, spec, NULL, 0, err, errlen))
		return 0;
	for (int k = 0; k < 100 && !s.ended; k++)
		n += source_poll(&s, f, now_us);
	source_close(&s);
	return n;
}
