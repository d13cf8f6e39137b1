#include "can_busoff.h"

void can_busoff_init(struct can_busoff *b)
{
	*b = (struct can_busoff){ .holdoff_ms = CAN_BUSOFF_BASE_MS };
}

void can_busoff_event(struct can_busoff *b, uint32_t now_ms)
{
	if (b->pending)
		return;
	b->pending = 1;
	b->since_ms = now_ms;
	b->count++;
	if (b->recovered_once && now_ms - b->recovered_ms < CAN_BUSOFF_QUIET_MS)
		b->holdoff_ms = b->holdoff_ms * 2 > CAN_BUSOFF_MAX_MS ? CAN_BUSOFF_MAX_MS : b->holdoff_ms * 2;
	else
		b->holdoff_ms = CAN_BUSOFF_BASE_MS;
}

int can_busoff_due(const struct can_busoff *b, uint32_t now_ms)
{
	return b->pending && now_ms - b->since_ms >= b->holdoff_ms;
}

void can_busoff_attempted(struct can_busoff *b, uint32_t now_ms, int ok)
{
	if (!b->pending)
		return;
	if (ok) {
		b->pending = 0;
		b->recovered_once = 1;
		b->recovered_ms = now_ms;
	} else {
		b->since_ms = now_ms;
	}
}
