/* USB OTG FS device (PA11 DM, PA12 DP, AF10), RM0090 section 34: vendor class, one interface
 * (class 0xFF) with bulk OUT 0x01 and bulk IN 0x81, 64-byte packets; the descriptors and the
 * control-request decisions come from logic/usb_desc (host-tested). Needs the 48 MHz clock from
 * the HSE path. */
#ifndef SWELL_FW_USB_H
#define SWELL_FW_USB_H

#include <stdint.h>

#include "swell/err.h"

/* Does an OTG FS core answer (AHB idle after a bounded wait)? */
int usb_probe(void);

/* Start the device; on_out receives every bulk OUT packet (interrupt context, <= 64 bytes). */
enum swell_err usb_start(uint8_t prio, void (*on_out)(const uint8_t *data, uint32_t len));

/* Queue one bulk IN packet (<= 64 bytes). SWELL_ESTATE when not configured or suspended (nothing is
 * queued for a bus without a host: the packet a suspend finds unread is taken back), SWELL_ESIZE when
 * the previous packet is still in flight or len > 64. */
enum swell_err usb_send(const uint8_t *data, uint32_t len);

/* Configured by a USB host and not suspended: a host reads the bulk IN endpoint. On silicon without
 * VBUS sensing a pulled cable shows as a suspend (6 ms after the last frame), so this falls back to 0
 * then; a bus reset or SET_CONFIGURATION 0 also makes it 0 (deconfigured) until the next
 * SET_CONFIGURATION. */
int usb_host_active(void);

#endif
