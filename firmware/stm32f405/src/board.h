/* The board the image is built for (firmware/stm32f405/boards/, chosen with -DSWELL_BOARD=NAME at
 * configure time): pins by port index (A = 0) and number, the console USART, the transceiver's
 * standby pin and the status LED. swell_board.h is generated and checked by boards/board.cmake. */
#ifndef SWELL_FW_BOARD_H
#define SWELL_FW_BOARD_H

#include <stdint.h>

#include "swell_board.h"

/* Pin to alternate function af (push-pull, high speed when fast). */
void board_pin_af(uint32_t port, uint32_t pin, uint32_t af, int fast);
/* Pin to a push-pull output at level (0 or 1), the level set before the pin drives. */
void board_pin_out(uint32_t port, uint32_t pin, uint32_t level);
/* Start-up: the transceiver out of standby (normal mode), the LED off. */
void board_init(void);
/* Status LED on or off (nothing on a board without one). */
void board_led(int on);

#endif
