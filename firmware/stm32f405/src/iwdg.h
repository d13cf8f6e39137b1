/* Independent watchdog on the 32 kHz LSI: once started it cannot be stopped. */
#ifndef SWELL_FW_IWDG_H
#define SWELL_FW_IWDG_H

#include <stdint.h>

/* Start with a timeout of timeout_ms (1..4095, clamped); returns 0 if the prescaler/reload update
 * did not complete within a bounded wait (the watchdog still runs with the default 512 ms). */
int iwdg_start(uint32_t timeout_ms);
void iwdg_kick(void);

#endif
