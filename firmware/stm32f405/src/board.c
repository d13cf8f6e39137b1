#include "board.h"

#include "../regs/stm32f405_periph.h"
#include "../regs/stm32f405_rcc.h"

#define GPIO_BASE 0x40020000u
#define GPIO_STRIDE 0x400u
#define GPIO_MODE_OUT 1u

static struct gpio_regs *gpio(uint32_t port)
{
	RCC->AHB1ENR |= 1u << port; /* GPIOAEN .. GPIOIEN are bits 0 .. 8 */
	(void)RCC->AHB1ENR;
	return (struct gpio_regs *)(GPIO_BASE + GPIO_STRIDE * port);
}

void board_pin_af(uint32_t port, uint32_t pin, uint32_t af, int fast)
{
	struct gpio_regs *g = gpio(port);
	uint32_t shift = 4u * (pin & 7u);

	g->AFR[pin >> 3] = (g->AFR[pin >> 3] & ~(0xFu << shift)) | (af << shift);
	if (fast)
		g->OSPEEDR = (g->OSPEEDR & ~(3u << (2u * pin))) | (GPIO_SPEED_HIGH << (2u * pin));
	g->MODER = (g->MODER & ~(3u << (2u * pin))) | (GPIO_MODE_AF << (2u * pin));
}

void board_pin_out(uint32_t port, uint32_t pin, uint32_t level)
{
	struct gpio_regs *g = gpio(port);

	g->BSRR = level ? 1u << pin : 1u << (pin + 16u);
	g->MODER = (g->MODER & ~(3u << (2u * pin))) | (GPIO_MODE_OUT << (2u * pin));
}

void board_init(void)
{
#if SWELL_BOARD_STBY
	board_pin_out(SWELL_BOARD_STBY_PORT, SWELL_BOARD_STBY_PIN, SWELL_BOARD_STBY_NORMAL);
#endif
	board_led(0);
}

void board_led(int on)
{
#if SWELL_BOARD_LED
	board_pin_out(SWELL_BOARD_LED_PORT, SWELL_BOARD_LED_PIN, on ? SWELL_BOARD_LED_ON : 1u - SWELL_BOARD_LED_ON);
#else
	(void)on;
#endif
}
