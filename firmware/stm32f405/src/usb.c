#include "usb.h"

#include "isr.h"

#include "../regs/stm32f405_otgfs.h"
#include "../regs/stm32f405_rcc.h"

#define AHBIDL_WAIT_LOOPS 100000u

int usb_probe(void)
{
	uint32_t n;

	RCC->AHB2ENR |= RCC_AHB2ENR_OTGFS;
	(void)RCC->AHB2ENR;
	for (n = 0; n < AHBIDL_WAIT_LOOPS; n++) {
		if (OTG->GRSTCTL & OTG_GRSTCTL_AHBIDL)
			return 1;
	}
	RCC->AHB2ENR &= ~RCC_AHB2ENR_OTGFS;
	return 0;
}
