/* Self-test run when no CAN or USB peripheral answers at boot (QEMU netduinoplus2): the reference
 * scene for a fixed number of solver steps, its checksum, instruction counts per step and per
 * cell-step, a naive 9-point loop for comparison, the TIM2 tick, and a loopback link. */
#ifndef SWELL_FW_SELFTEST_H
#define SWELL_FW_SELFTEST_H

#include <stdint.h>

#ifndef SWELL_FW_SELFTEST_STEPS
#define SWELL_FW_SELFTEST_STEPS 200u
#endif

/* Returns 1 when every check passed. */
int selftest_run(uint32_t tim_clk_hz);

/* The trace window of one core tick (a debugger sets the rate and the tick's index, 0 based, and breaks
 * on the two functions: tools/bench/m4-tick-trace.sh). */
extern volatile uint32_t selftest_trace_hz, selftest_trace_tick;
void selftest_trace_begin(void);
void selftest_trace_end(void);

/* Boot mode "bootloader": the core refuses ENTER_BOOTLOADER in RUNNING and accepts it in ARMED, then
 * boot_request_reset() (no return). Returns only when a check failed (printed). */
void selftest_boot_request(void);

#endif
