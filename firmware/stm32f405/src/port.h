/* What the STM32F405 port offers the controller core (firmware/core), and what the core gives back.
 * The core never includes a register header. */
#ifndef SWELL_FW_PORT_H
#define SWELL_FW_PORT_H

#include <stdint.h>

/* Put every force output into its safe state now: the commanded force is set to zero and pending
 * force frames are aborted. Safe to call from any context, including fault handlers. */
void port_force_zero(void);

/* Last force command the port put on the wire, per axis, in 0.01 N (zero after port_force_zero). */
extern volatile int32_t port_force_cN[3];

/* Cycle counter: DWT CYCCNT where the core has one, else SysTick extended to 64 bits. */
uint64_t port_cycles(void);

#endif
