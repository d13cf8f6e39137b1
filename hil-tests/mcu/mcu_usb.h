/* USB OTG FS of the emulated STM32F405: the OTG FS model (otgfs.h) at 0x50000000 with its interrupt
 * line (RM0090 table 61: 67 OTG_FS), its clock following RCC AHB2ENR.OTGFSEN (RM0090 7.3.11), and
 * optionally the USB/IP server (usbip.h) through which a host (the HIL VM) uses the device. */
#ifndef SWELL_MCU_USB_H
#define SWELL_MCU_USB_H

#include "mcu.h"
#include "otgfs.h"
#include "usbip.h"

struct mcu_usb_dev {
	struct otgfs otg;
	struct usbip_server srv;
	int served; /* the USB/IP server runs (mcu_usb_serve) */
};

/* Map OTG FS (before mcu_run). 0, or -1 when the map or the clock gate could not be set up. */
int mcu_usb_add(struct mcu *m, struct mcu_usb_dev *u);
/* Serve the device on the connected stream fd (USB/IP), as USB address `address`. */
void mcu_usb_serve(struct mcu_usb_dev *u, int fd, uint8_t address);
/* One step of the server at the emulator's time; the interrupt line after it. USBIP_CLOSED: the
 * host let go (u->srv.error says why), and the cable is out (the model's suspend follows); a new
 * session (mcu_usb_serve) puts it back with its bus reset. */
enum usbip_step mcu_usb_step(struct mcu *m, struct mcu_usb_dev *u);

#endif
