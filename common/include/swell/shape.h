/* Initial water shapes in integers only, so that the host and the controller image start from the
 * same bits. Both add to an existing field (saturating to +-SWELL_H_MAX) and leave flows alone: call
 * swell_wave_rest() afterwards to start at rest. Accuracy: the integer exp and cos are within 2e-6
 * and 1e-8 of the exact functions (tested), far below the 2^-16 mm LSB for amplitudes under 1 m. */
#ifndef SWELL_SHAPE_H
#define SWELL_SHAPE_H

#include <stdint.h>

#include "swell/fixed.h"

/* exp(-x) for x >= 0 in Q15.16, result in Q1.30 (0 for x >= 32, 1.0 for x <= 0). */
q30_t swell_exp_neg_q16(q16_t x);

/* cos(pi * num / den) in Q1.30 for any num and den > 0 (exact rational argument reduction). */
q30_t swell_cos_pi_frac(int64_t num, int64_t den);

/* h[j*nx+i] += amp * exp(-((i - x)^2 + (j - y)^2) / (2 sigma^2)); x, y, sigma in cells (Q15.16),
 * sigma >= 0.5 cell, amp in height LSB. Nothing is written when sigma is out of range. */
void swell_shape_gauss(int32_t *h, uint16_t nx, uint16_t ny, q16_t x_cells, q16_t y_cells, q16_t sigma_cells,
		       int32_t amp_lsb);

/* h[j*nx+i] += amp * cos(m pi (i + 1/2) / nx) * cos(n pi (j + 1/2) / ny): the (m, n) mode of a pool
 * with reflecting walls. */
void swell_shape_seiche(int32_t *h, uint16_t nx, uint16_t ny, uint16_t m, uint16_t n, int32_t amp_lsb);

#endif
