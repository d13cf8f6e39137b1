#include "console.h"

#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"

#define TXE_WAIT_LOOPS 20000u /* > 1 character time at 9600 baud and 168 MHz */

static uint32_t dropped;

void con_init(uint32_t pclk2_hz, uint32_t baud)
{
	RCC->AHB1ENR |= RCC_AHB1ENR_GPIOA;
	RCC->APB2ENR |= RCC_APB2ENR_USART1;
	(void)RCC->APB2ENR; /* the enable takes effect before the first register access */
	/* PA9: alternate function 7 (USART1_TX). */
	GPIOA->AFR[1] = (GPIOA->AFR[1] & ~(0xFu << 4)) | (7u << 4);
	GPIOA->OSPEEDR = (GPIOA->OSPEEDR & ~(3u << 18)) | (GPIO_SPEED_HIGH << 18);
	GPIOA->MODER = (GPIOA->MODER & ~(3u << 18)) | (GPIO_MODE_AF << 18);
	USART1->CR1 = 0;
	USART1->BRR = (pclk2_hz + baud / 2) / baud; /* oversampling by 16: BRR = f / baud */
	USART1->CR1 = USART_CR1_UE | USART_CR1_TE;
}

void con_putc(char c)
{
	uint32_t n;

	for (n = 0; n < TXE_WAIT_LOOPS; n++) {
		if (USART1->SR & USART_SR_TXE) {
			USART1->DR = (uint8_t)c;
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

void con_put_hex32(uint32_t v)
{
	static const char hex[] = "0123456789abcdef";
	int s;

	for (s = 28; s >= 0; s -= 4)
		con_putc(hex[(v >> s) & 0xFu]);
}

void con_puts_hex32(const char *s, uint32_t v)
{
	con_puts(s);
	con_put_hex32(v);
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
