/* swell-flash: ask a running controller, over its host link (UDP, CAN or USB: swell/link_client.h), to
 * enter its bootloader (ENTER_BOOTLOADER with the key), the way a viewer talks to it; after
 * flashing, find it again and read the firmware version it reports (CTL_INFO). */
#ifndef SWELL_FLASH_BOOT_H
#define SWELL_FLASH_BOOT_H

#include <stddef.h>
#include <stdint.h>

#include "swell/link_client.h"

enum flash_boot_result {
	BOOT_ENTERED = 0, /* request sent, the controller's heartbeat stopped (it reboots) */
	BOOT_STILL_RUNNING, /* request sent, heartbeats go on: no bootloader entered */
	BOOT_REFUSED_RUNNING, /* controller RUNNING and not forced: nothing sent */
	BOOT_REFUSED_NODES, /* several controllers heard and no node chosen: nothing sent */
	BOOT_NOT_FOUND, /* no heartbeat heard */
	BOOT_ERROR, /* link or protocol failure (see msg) */
};

/* What the watch after the request saw (seconds after the request was sent; -1: not seen). */
struct flash_boot_times {
	double last_beat_s; /* the controller's last heartbeat */
	double dev_gone_s; /* the link said the device left (USB unplugged: -ENODEV) */
};

/* Listen on the link for the controller's HEARTBEAT (spec->node, or the one controller heard: the
 * listening lasts until its second heartbeat, and any other node heard meanwhile refuses); when
 * RUNNING refuse unless force, in which case send PARAM_SET AUTORUN=0 and COMMAND=STOP and wait for
 * it to leave RUNNING; then send ENTER_BOOTLOADER and watch the heartbeat for watch_ms. Progress
 * lines go to stdout; msg gets a one-line outcome; times (may be NULL) what the watch saw. */
enum flash_boot_result flash_enter_bootloader(const struct swell_client_spec *spec, int force, int watch_ms,
					      struct flash_boot_times *times, char *msg, size_t msg_len);

/* What a controller reports in CTL_INFO. */
struct flash_found {
	uint8_t node;
	uint8_t version[3]; /* major, minor, patch */
	uint32_t obj_100um[3]; /* object a, b, H in 0.1 mm */
	double after_s; /* from the start of the listening */
	double mono_s; /* when it came, CLOCK_MONOTONIC */
};

/* Listen on the link (a USB device is waited for) for up to timeout_ms for a CTL_INFO of
 * spec->node (any node when -1), sent at start and at 1 Hz.
 * 0 found (*out filled); -1 nothing heard (msg says so); -2 the link cannot be opened. */
int flash_find_controller(const struct swell_client_spec *spec, int timeout_ms, struct flash_found *out, char *msg,
			  size_t msg_len);

#endif
