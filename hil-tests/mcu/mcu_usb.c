/* USB OTG FS (RM0090 section 34) on the OTG FS model: register accesses, time, interrupt line, the
 * RCC clock gate, and the USB/IP server's steps. The model counts time in the emulator's units. */
#include "mcu_usb.h"

#define RCC_AHB2ENR 0x34u
#define RCC_AHB2_OTGFS (1u << 7)

static void line(struct mcu *m, struct mcu_usb_dev *u)
{
	mcu_irq_line(m, OTGFS_MODEL_IRQ, otgfs_irq(&u->otg));
}

static uint32_t usb_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct mcu_usb_dev *u = ctx;
	uint32_t v = otgfs_read(&u->otg, off & ~3u, m->now);

	line(m, u);
	return size == 4 ? v : (v >> (8 * (off & 3u))) & (size == 2 ? 0xFFFFu : 0xFFu);
}

static void usb_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct mcu_usb_dev *u = ctx;

	if (size != 4)
		mcu_unmodelled(m, "OTG_FS (byte or halfword write)", OTGFS_MODEL_BASE + off, 1, v);
	else
		otgfs_write(&u->otg, off, v, m->now);
	line(m, u);
}

static void usb_advance(struct mcu *m, void *ctx, uint64_t now)
{
	struct mcu_usb_dev *u = ctx;

	otgfs_advance(&u->otg, now);
	line(m, u);
}

static uint64_t usb_next_event(struct mcu *m, void *ctx)
{
	uint64_t t = otgfs_next_event_ns(&((struct mcu_usb_dev *)ctx)->otg);

	(void)m;
	return t == OTGFS_NO_EVENT ? MCU_NEVER : t;
}

static void usb_clock(struct mcu *m, void *ctx, int on)
{
	struct mcu_usb_dev *u = ctx;

	otgfs_advance(&u->otg, m->now);
	otgfs_set_clock(&u->otg, on);
	line(m, u);
}

/* A system reset: the core back to its reset values, its clock off (the host side sees a detach). */
static void usb_reset(struct mcu *m, void *ctx)
{
	struct mcu_usb_dev *u = ctx;

	otgfs_init(&u->otg, MCU_TIME_HZ);
	otgfs_set_clock(&u->otg, 0);
	line(m, u);
}

int mcu_usb_add(struct mcu *m, struct mcu_usb_dev *u)
{
	const struct mcu_periph p = { "OTG_FS",  OTGFS_MODEL_BASE, OTGFS_MODEL_SIZE, u, usb_read,
				      usb_write, usb_advance,      usb_next_event,   0 };

	otgfs_init(&u->otg, MCU_TIME_HZ);
	otgfs_set_clock(&u->otg, 0); /* AHB2ENR.OTGFSEN is 0 at reset */
	return mcu_add_periph(m, &p) || mcu_rcc_on_enable(m, RCC_AHB2ENR, RCC_AHB2_OTGFS, usb_clock, u) ||
			mcu_on_system_reset(m, usb_reset, u)
		? -1
		: 0;
}

void mcu_usb_serve(struct mcu_usb_dev *u, int fd, uint8_t address)
{
	usbip_server_init(&u->srv, fd, &u->otg, address);
	u->served = 1;
}

enum usbip_step mcu_usb_step(struct mcu *m, struct mcu_usb_dev *u)
{
	enum usbip_step s = usbip_server_step(&u->srv, m->now);

	line(m, u);
	return s;
}
