/* Console on the board's USART TX pin (src/board.h: USART1 PA9 on QEMU's netduinoplus2), 115200 8N1:
 * text only, no printf. Writes never block forever: a
 * character that cannot be sent within a bounded wait is dropped and counted. */
#ifndef SWELL_FW_CONSOLE_H
#define SWELL_FW_CONSOLE_H

#include <stdint.h>

/* pclk1_hz and pclk2_hz: the APB clocks (USART2/3 on APB1, USART1/6 on APB2). */
void con_init(uint32_t pclk1_hz, uint32_t pclk2_hz, uint32_t baud);
/* Wait (bounded) for the last character to leave the shift register. */
void con_drain(void);
void con_putc(char c);
void con_puts(const char *s);
void con_put_u64(uint64_t v);
void con_put_i64(int64_t v);
/* s, then v in decimal or as 8 hex digits: a label and its value. */
void con_puts_u32(const char *s, uint32_t v);
void con_puts_hex32(const char *s, uint32_t v);
/* num / den with `decimals` digits after the point, rounded to nearest. */
void con_put_ratio(uint64_t num, uint64_t den, unsigned decimals);
uint32_t con_dropped(void);

#endif
