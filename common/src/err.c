#include "swell/err.h"

const char *swell_err_str(enum swell_err err)
{
	static const char *const text[SWELL_ERR_COUNT] = {
		[SWELL_OK] = "ok",
		[SWELL_EINVAL] = "invalid argument",
		[SWELL_ERANGE] = "parameter out of range",
		[SWELL_EUNSTABLE] = "parameters outside the stability limit",
		[SWELL_ESIZE] = "size out of range",
		[SWELL_ESTATE] = "not allowed in this state",
		[SWELL_ECRC] = "checksum mismatch",
		[SWELL_EVERSION] = "version mismatch",
		[SWELL_ETRUNC] = "truncated input",
		[SWELL_EUNKNOWN] = "unknown identifier",
		[SWELL_ETIMEOUT] = "link silent",
		[SWELL_ESTOP] = "emergency stop",
	};

	if ((unsigned)err >= SWELL_ERR_COUNT)
		return "unknown error";
	return text[err];
}
