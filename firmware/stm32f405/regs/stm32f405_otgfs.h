/* STM32F405 USB on-the-go full-speed core in device mode (RM0090 section 34.16). */
#ifndef SWELL_REGS_STM32F405_OTGFS_H
#define SWELL_REGS_STM32F405_OTGFS_H

#include "cortex_m4.h"

#define OTGFS_BASE 0x50000000u

struct otg_global_regs {
	volatile uint32_t GOTGCTL, GOTGINT, GAHBCFG, GUSBCFG, GRSTCTL, GINTSTS, GINTMSK, GRXSTSR, GRXSTSP, GRXFSIZ,
		DIEPTXF0, HNPTXSTS;
	uint32_t reserved0[2];
	volatile uint32_t GCCFG, CID;
	uint32_t reserved1[48];
	volatile uint32_t HPTXFSIZ;
	volatile uint32_t DIEPTXF[3]; /* DIEPTXF1..3 */
};
REG_CHECK(struct otg_global_regs, GRXFSIZ, 0x24);
REG_CHECK(struct otg_global_regs, GCCFG, 0x38);
REG_CHECK(struct otg_global_regs, CID, 0x3C);
REG_CHECK(struct otg_global_regs, DIEPTXF, 0x104);
#define OTG ((struct otg_global_regs *)OTGFS_BASE)

struct otg_dev_regs {
	volatile uint32_t DCFG, DCTL, DSTS;
	uint32_t reserved0;
	volatile uint32_t DIEPMSK, DOEPMSK, DAINT, DAINTMSK;
	uint32_t reserved1[2];
	volatile uint32_t DVBUSDIS, DVBUSPULSE;
	uint32_t reserved2;
	volatile uint32_t DIEPEMPMSK;
};
REG_CHECK(struct otg_dev_regs, DAINTMSK, 0x1C);
REG_CHECK(struct otg_dev_regs, DIEPEMPMSK, 0x34);
#define OTG_DEV ((struct otg_dev_regs *)(OTGFS_BASE + 0x800u))

struct otg_inep_regs {
	volatile uint32_t DIEPCTL;
	uint32_t reserved0;
	volatile uint32_t DIEPINT;
	uint32_t reserved1;
	volatile uint32_t DIEPTSIZ;
	uint32_t reserved2;
	volatile uint32_t DTXFSTS;
	uint32_t reserved3;
};
struct otg_outep_regs {
	volatile uint32_t DOEPCTL;
	uint32_t reserved0;
	volatile uint32_t DOEPINT;
	uint32_t reserved1;
	volatile uint32_t DOEPTSIZ;
	uint32_t reserved2[3];
};
_Static_assert(sizeof(struct otg_inep_regs) == 0x20, "IN endpoint stride");
_Static_assert(sizeof(struct otg_outep_regs) == 0x20, "OUT endpoint stride");
#define OTG_IN(n) ((struct otg_inep_regs *)(OTGFS_BASE + 0x900u + 0x20u * (n)))
#define OTG_OUT(n) ((struct otg_outep_regs *)(OTGFS_BASE + 0xB00u + 0x20u * (n)))
#define OTG_PCGCCTL (*(volatile uint32_t *)(OTGFS_BASE + 0xE00u))
#define OTG_FIFO(n) (*(volatile uint32_t *)(OTGFS_BASE + 0x1000u + 0x1000u * (n)))

#define OTG_GAHBCFG_GINTMSK (1u << 0)
#define OTG_GUSBCFG_PHYSEL (1u << 6)
#define OTG_GUSBCFG_TRDT_SHIFT 10
#define OTG_GUSBCFG_FDMOD (1u << 30)
#define OTG_GRSTCTL_CSRST (1u << 0)
#define OTG_GRSTCTL_RXFFLSH (1u << 4)
#define OTG_GRSTCTL_TXFFLSH (1u << 5)
#define OTG_GRSTCTL_TXFNUM_SHIFT 6
#define OTG_GRSTCTL_TXFNUM_ALL (0x10u << 6)
#define OTG_GRSTCTL_AHBIDL (1u << 31)
#define OTG_GINT_RXFLVL (1u << 4)
#define OTG_GINT_USBSUSP (1u << 11)
#define OTG_GINT_USBRST (1u << 12)
#define OTG_GINT_ENUMDNE (1u << 13)
#define OTG_GINT_IEPINT (1u << 18)
#define OTG_GINT_OEPINT (1u << 19)
#define OTG_GINT_WKUPINT (1u << 31)
#define OTG_GRXSTS_EPNUM_MASK 0xFu
#define OTG_GRXSTS_BCNT_SHIFT 4
#define OTG_GRXSTS_BCNT_MASK 0x7FFu
#define OTG_GRXSTS_PKTSTS_SHIFT 17
#define OTG_GRXSTS_PKTSTS_MASK 0xFu
#define OTG_PKTSTS_OUT_DATA 2u
#define OTG_PKTSTS_SETUP_DATA 6u
#define OTG_GCCFG_PWRDWN (1u << 16)
#define OTG_GCCFG_NOVBUSSENS (1u << 21)

#define OTG_DCFG_DSPD_FS 3u
#define OTG_DCFG_DAD_SHIFT 4
#define OTG_DCFG_DAD_MASK (0x7Fu << 4)
#define OTG_DCTL_SDIS (1u << 1)
#define OTG_DCTL_CGINAK (1u << 8)

#define OTG_EPCTL_MPSIZ_MASK 0x7FFu
#define OTG_EPCTL_USBAEP (1u << 15)
#define OTG_EPCTL_EPTYP_SHIFT 18
#define OTG_EPTYP_BULK 2u
#define OTG_EPCTL_STALL (1u << 21)
#define OTG_EPCTL_TXFNUM_SHIFT 22
#define OTG_EPCTL_CNAK (1u << 26)
#define OTG_EPCTL_SNAK (1u << 27)
#define OTG_EPCTL_SD0PID (1u << 28)
#define OTG_EPCTL_EPDIS (1u << 30)
#define OTG_EPCTL_EPENA (1u << 31)
#define OTG_EPINT_XFRC (1u << 0)
#define OTG_EPINT_EPDISD (1u << 1)
#define OTG_DOEPINT_STUP (1u << 3)
#define OTG_TSIZ_PKTCNT_SHIFT 19
#define OTG_DOEPTSIZ0_STUPCNT_SHIFT 29

#endif
