/* CAN1 (RM0090 section 32) on the bxCAN model: register accesses, time, interrupt lines, reset. */
#include "mcu_can1.h"

#define CAN1_TX_IRQ 19u
#define RCC_APB1RSTR 0x20u
#define RCC_APB1_CAN1 (1u << 25)

static void lines(struct mcu *m, struct mcu_can1_dev *c)
{
	const unsigned l = bxcan_irq_lines(&c->b);

	mcu_irq_line(m, CAN1_TX_IRQ, (l & BXCAN_IRQ_TX) != 0);
	mcu_irq_line(m, CAN1_TX_IRQ + 1u, (l & BXCAN_IRQ_RX0) != 0);
	mcu_irq_line(m, CAN1_TX_IRQ + 2u, (l & BXCAN_IRQ_RX1) != 0);
	mcu_irq_line(m, CAN1_TX_IRQ + 3u, (l & BXCAN_IRQ_SCE) != 0);
}

static void clock(struct mcu *m, struct mcu_can1_dev *c)
{
	if (m->clk.pclk1_hz && m->clk.pclk1_hz != c->b.pclk_hz)
		(void)bxcan_set_pclk(&c->b, m->clk.pclk1_hz);
}

static uint32_t can1_read(struct mcu *m, void *ctx, uint32_t off, unsigned size)
{
	struct mcu_can1_dev *c = ctx;
	uint32_t v;

	clock(m, c);
	v = bxcan_read(&c->b, off & ~3u, mcu_can1_ns(m->now));
	lines(m, c);
	return size == 4 ? v : (v >> (8 * (off & 3u))) & (size == 2 ? 0xFFFFu : 0xFFu);
}

static void can1_write(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v)
{
	struct mcu_can1_dev *c = ctx;

	clock(m, c);
	if (size != 4)
		mcu_unmodelled(m, "CAN1 (byte or halfword write)", BXCAN_BASE + off, 1, v);
	else
		bxcan_write(&c->b, off, v, mcu_can1_ns(m->now));
	lines(m, c);
}

static void can1_advance(struct mcu *m, void *ctx, uint64_t now)
{
	struct mcu_can1_dev *c = ctx;

	bxcan_advance(&c->b, mcu_can1_ns(now));
	lines(m, c);
}

static uint64_t can1_next_event(struct mcu *m, void *ctx)
{
	(void)m;
	return mcu_can1_units(bxcan_next_event_ns(&((struct mcu_can1_dev *)ctx)->b));
}

static void can1_reset(struct mcu *m, void *ctx)
{
	struct mcu_can1_dev *c = ctx;

	bxcan_advance(&c->b, mcu_can1_ns(m->now));
	bxcan_reset(&c->b);
	lines(m, c);
}

void mcu_can1_bus_rx(struct mcu *m, void *ctx, const struct bxcan_frame *f)
{
	struct mcu_can1_dev *c = ctx;

	clock(m, c);
	if (f)
		(void)bxcan_bus_rx(&c->b, f, mcu_can1_ns(m->now));
	else
		bxcan_advance(&c->b, mcu_can1_ns(m->now));
	lines(m, c);
}

int mcu_can1_add(struct mcu *m, struct mcu_can1_dev *c)
{
	const struct mcu_periph p = { "CAN1",     BXCAN_BASE,   BXCAN_SIZE,      c, can1_read,
				      can1_write, can1_advance, can1_next_event, 0 };

	if (bxcan_init(&c->b, m->clk.pclk1_hz ? m->clk.pclk1_hz : 16000000u) != 0)
		return -1;
	return mcu_add_periph(m, &p) || mcu_rcc_on_reset(m, RCC_APB1RSTR, RCC_APB1_CAN1, can1_reset, c) ||
			mcu_on_system_reset(m, can1_reset, c)
		? -1
		: 0;
}
