/* Error values shared by every swell module. A function that returns one of these other than
 * SWELL_OK has changed nothing. */
#ifndef SWELL_ERR_H
#define SWELL_ERR_H

enum swell_err {
	SWELL_OK = 0,
	SWELL_EINVAL, /* malformed argument: null pointer, unknown enum value */
	SWELL_ERANGE, /* a parameter outside its documented range */
	SWELL_EUNSTABLE, /* solver parameters outside the von Neumann stability region */
	SWELL_ESIZE, /* grid or buffer size out of range or storage too small */
	SWELL_ESTATE, /* not allowed in the current state */
	SWELL_ECRC, /* checksum mismatch */
	SWELL_EVERSION, /* protocol or image version mismatch */
	SWELL_ETRUNC, /* input shorter than its declared length */
	SWELL_EUNKNOWN, /* unknown message or identifier */
	SWELL_ETIMEOUT, /* a link went silent */
	SWELL_ESTOP, /* the device reported its emergency stop */
	SWELL_ERR_COUNT
};

/* Short constant text for an error value; "unknown error" for anything out of range. */
const char *swell_err_str(enum swell_err err);

#endif
