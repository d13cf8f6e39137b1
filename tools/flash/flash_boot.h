/* swell-flash: ask a running controller, over its UDP host link, to enter its bootloader
 * (ENTER_BOOTLOADER with the key), the way a viewer talks to it; after flashing, find it again and
 * read the firmware version it reports (CTL_INFO). */
#ifndef SWELL_FLASH_BOOT_H
#define SWELL_FLASH_BOOT_H

#include <stddef.h>
#include <stdint.h>

enum flash_boot_result {
	BOOT_ENTERED = 0,     /* request sent, the controller's heartbeat stopped (it reboots) */
	BOOT_STILL_RUNNING,   /* request sent, heartbeats go on: no bootloader entered */
	BOOT_REFUSED_RUNNING, /* controller RUNNING and not forced: nothing sent */
	BOOT_NOT_FOUND,       /* no heartbeat heard */
	BOOT_ERROR,           /* link or protocol failure (see msg) */
};

/* Listen on 127.0.0.1:port (the controller's viewer port) for a HEARTBEAT; when RUNNING refuse
 * unless force, in which case send PARAM_SET COMMAND=STOP and wait for it to leave RUNNING; then
 * send ENTER_BOOTLOADER and watch the heartbeat for watch_ms. Progress lines go to stdout; msg gets
 * a one-line outcome. */
enum flash_boot_result flash_enter_bootloader(uint16_t port, int force, int watch_ms, char *msg,
					      size_t msg_len);

/* What a controller reports in CTL_INFO. */
struct flash_found {
	uint8_t node;
	uint8_t version[3];       /* major, minor, patch */
	uint32_t obj_100um[3];    /* object a, b, H in 0.1 mm */
	double after_s;           /* from the start of the listening */
};

/* Listen on 127.0.0.1:port for up to timeout_ms for a CTL_INFO (sent at 1 Hz and at start).
 * 0 found (*out filled); -1 nothing heard (msg says so); -2 the port cannot be opened. */
int flash_find_controller(uint16_t port, int timeout_ms, struct flash_found *out, char *msg, size_t msg_len);

#endif
