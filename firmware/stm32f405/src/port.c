#include "port.h"

#include "app.h"
#include "can.h"

volatile int32_t port_force_cN[3];

void port_force_zero(void)
{
	port_force_cN[0] = 0;
	port_force_cN[1] = 0;
	port_force_cN[2] = 0;
	can_abort_all(); /* a queued non-zero force frame must not go out after this point */
	app_send_zero_force(); /* and the device is told so, when it is on CAN */
}
