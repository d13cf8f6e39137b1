/* USART1 console (PA9 TX, 115200 8N1): text only, no printf. Writes never block forever: a
 * character that cannot be sent within a bounded wait is dropped and counted. */
#ifndef SWELL_FW_CONSOLE_H
#define SWELL_FW_CONSOLE_H

#include <stdint.h>

void con_init(uint32_t pclk2_hz, uint32_t baud);
void con_putc(char c);
void con_puts(const char *s);
void con_put_u64(uint64_t v);
void con_put_i64(int64_t v);
void con_put_hex32(uint32_t v);
/* s, then v in decimal or as 8 hex digits: a label and its value. */
void con_puts_u32(const char *s, uint32_t v);
void con_puts_hex32(const char *s, uint32_t v);
/* num / den with `decimals` digits after the point, rounded to nearest. */
void con_put_ratio(uint64_t num, uint64_t den, unsigned decimals);
uint32_t con_dropped(void);

#endif
