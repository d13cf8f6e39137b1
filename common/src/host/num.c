#include "swell/num.h"

#include <errno.h>
#include <stdlib.h>

int swell_parse_long(const char *s, int base, long lo, long hi, long *out)
{
	char *end;
	long v;

	if (!s)
		return -1;
	errno = 0;
	v = strtol(s, &end, base);
	if (errno || end == s || *end || v < lo || v > hi)
		return -1;
	*out = v;
	return 0;
}
