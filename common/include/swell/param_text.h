/* Parameter values as people write them ("80g", "0.08 kg", "12.5mm", "0.02") to the
 * raw integers of the parameter table (swell/param.h) and back. Host only (uses double). */
#ifndef SWELL_PARAM_TEXT_H
#define SWELL_PARAM_TEXT_H

#include <stddef.h>
#include <stdint.h>

#include "swell/param.h"

/* A number with an optional unit: the parameter's own unit or the same unit with another SI
 * prefix (k, c, m, u; g and kg, mm and m, N and mN, N/s and kN/s). Rounded to the nearest raw
 * step. 0, or -1 with a one-line reason in err (*raw untouched): not a number, a unit of another
 * kind, or outside the parameter's range (the range is printed in the parameter's unit). */
int swell_param_parse(const struct swell_param_desc *d, const char *text, int32_t *raw, char *err, size_t errlen);

/* raw x factor in the parameter's unit, e.g. "80 g", "0.2009", "10 N". */
void swell_param_format(const struct swell_param_desc *d, int32_t raw, char *buf, size_t len);

double swell_param_phys(const struct swell_param_desc *d, int32_t raw);

#endif
