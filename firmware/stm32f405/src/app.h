/* Controller mode on silicon: the core (firmware/core) driven by the TIM2 tick, messages in from
 * CAN and USB, out to them. The device link runs on CAN at 1000 Hz when CAN answers (docs/design.md, section 4),
 * else everything on USB at 2500 Hz. Messages are routed to the core's links by their sender in the
 * protocol table (DEV -> device link, VIEW -> host link), whatever carrier brought them. */
#ifndef SWELL_FW_APP_H
#define SWELL_FW_APP_H

#include <stdint.h>

#include "../logic/core_run.h"
#include "swell/ctl_pool.h"
#include "../logic/scene.h"
#include "clock.h"
#include "swell/ctl.h"

/* The core and its arena, shared with the self-test (never both at once). The arena is the SRAM
 * left beside the stack and the rest of .bss (120 KB): it holds the self-test scene's field, and the
 * pool's buffers with the fast block found at boot (src/mem.h, swell/ctl_pool.h): the largest pool is
 * about 100 x 100 cells (h, v, acc in SRAM; u and the sent samples in the fast block). */
#define APP_ARENA_WORDS 30720u
_Static_assert(APP_ARENA_WORDS >= FW_CORE_ARENA_WORDS && APP_ARENA_WORDS >= FW_SCENE_WORDS,
	       "the arena holds the reference pool's core and the self-test scene's field");
extern int32_t app_arena[APP_ARENA_WORDS];
extern struct swell_ctl app_ctl;
extern struct fw_mem app_mem; /* found at boot (mem_probe) */

struct app_prio {
	uint8_t tick, can_rx, can_sce, usb;
};

/* Never returns; the watchdog is refreshed only while the tick keeps running. */
__attribute__((noreturn)) void app_run(const struct clock_info *ci, int can_ok, int usb_ok, const struct app_prio *prio,
				       uint32_t watchdog_ms);

/* The firmware version CTL_INFO reports: the image header's, as stamped in flash (major saturated
 * to the 8 bits the message has). */
void app_fw_version(uint8_t v[3]);

#endif
