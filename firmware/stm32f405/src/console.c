#include "console.h"

#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"
#include "board.h"

#define TXE_WAIT_LOOPS 20000u /* > 1 character time at 9600 baud and 168 MHz */

/* The board's console USART: base address and its enable bit; USART1 and 6 sit on APB2, 2 and 3 on
 * APB1. */
#define CON_ON_APB2 (SWELL_BOARD_CON_USART == 1 || SWELL_BOARD_CON_USART == 6)
#define CON_ENR (*(CON_ON_APB2 ? &RCC->APB2ENR : &RCC->APB1ENR))
#if SWELL_BOARD_CON_USART == 1
#define CON ((struct usart_regs *)0x40011000u)
#define CON_EN (1u << 4)
#elif SWELL_BOARD_CON_USART == 2
#define CON ((struct usart_regs *)0x40004400u)
#define CON_EN (1u << 17)
#elif SWELL_BOARD_CON_USART == 3
#define CON ((struct usart_regs *)0x40004800u)
#define CON_EN (1u << 18)
#elif SWELL_BOARD_CON_USART == 6
#define CON ((struct usart_regs *)0x40011400u)
#define CON_EN (1u << 5)
#else
#error "SWELL_BOARD_CON_USART: 1, 2, 3 or 6 (boards/board.cmake checks it)"
#endif

static uint32_t dropped;

void con_init(uint32_t pclk1_hz, uint32_t pclk2_hz, uint32_t baud)
{
	const uint32_t f = CON_ON_APB2 ? pclk2_hz : pclk1_hz;

	CON_ENR |= CON_EN;
	(void)CON_ENR; /* the enable takes effect before the first register access */
	board_pin_af(SWELL_BOARD_CON_TX_PORT, SWELL_BOARD_CON_TX_PIN, SWELL_BOARD_CON_TX_AF, 1);
	CON->CR1 = 0;
	CON->BRR = (f + baud / 2) / baud; /* oversampling by 16: BRR = f / baud */
	CON->CR1 = USART_CR1_UE | USART_CR1_TE;
}

void con_drain(void)
{
	uint32_t n;

	for (n = 0; n < 2000000u && !(CON->SR & USART_SR_TC); n++) /* QEMU sets TC at once */
		;
}

void con_putc(char c)
{
	uint32_t n;

	for (n = 0; n < TXE_WAIT_LOOPS; n++) {
		if (CON->SR & USART_SR_TXE) {
			CON->DR = (uint8_t)c;
			return;
		}
	}
	dropped++;
}

void con_puts(const char *s)
{
	while (*s)
		con_putc(*s++);
}

void con_put_u64(uint64_t v)
{
	char buf[21];
	int i = 20;

	buf[i] = 0;
	do {
		buf[--i] = (char)('0' + v % 10);
		v /= 10;
	} while (v);
	con_puts(&buf[i]);
}

void con_puts_u32(const char *s, uint32_t v)
{
	con_puts(s);
	con_put_u64(v);
}

void con_put_i64(int64_t v)
{
	if (v < 0) {
		con_putc('-');
		con_put_u64(0 - (uint64_t)v);
	} else {
		con_put_u64((uint64_t)v);
	}
}

void con_puts_hex32(const char *s, uint32_t v)
{
	static const char hex[] = "0123456789abcdef";
	int k;

	con_puts(s);
	for (k = 28; k >= 0; k -= 4)
		con_putc(hex[(v >> k) & 0xFu]);
}

void con_put_ratio(uint64_t num, uint64_t den, unsigned decimals)
{
	uint64_t scale = 1, q, frac;
	unsigned d;

	if (den == 0) {
		con_puts("n/a");
		return;
	}
	for (d = 0; d < decimals; d++)
		scale *= 10;
	q = (num * scale + den / 2) / den;
	con_put_u64(q / scale);
	if (!decimals)
		return;
	con_putc('.');
	frac = q % scale;
	for (scale /= 10; scale > 1 && frac < scale; scale /= 10)
		con_putc('0');
	con_put_u64(frac);
}

uint32_t con_dropped(void)
{
	return dropped;
}
