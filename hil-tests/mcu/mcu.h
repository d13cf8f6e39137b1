/* swell-mcu: an emulated STM32F405 (Cortex-M4 on unicorn) running the product image unmodified, with
 * register-level models of the peripherals the image touches, in deterministic virtual time
 * (docs/stm32f405-emulator.md).
 *
 * Virtual time counts units of 1/336 MHz (MCU_TIME_HZ): every clock the image runs on divides it (HSI
 * 16 MHz, SYSCLK 168 MHz, APB1 42 MHz, its timers 84 MHz, the 32 kHz LSI, a 1 Mbit/s CAN bit), so every
 * peripheral event falls on a whole unit. The CPU advances time by its instructions at a fixed cost
 * (cycles per instruction, --cpi), taken a translated block at a time; interrupts are taken between
 * blocks. Nothing reads the wall clock unless pacing is asked for (the CAN tunnel). */
#ifndef SWELL_MCU_H
#define SWELL_MCU_H

#include <stdint.h>
#include <stdio.h>

#include <unicorn/unicorn.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MCU_TIME_HZ 336000000ull
#define MCU_NEVER UINT64_MAX
#define MCU_IRQS 82 /* STM32F405 interrupt lines (RM0090 table 61) */
#define MCU_EXCS (16 + MCU_IRQS) /* exception numbers: 1..15 system, 16.. interrupts */
/* RCC_CSR's reset flags (RM0090 7.3.21) */
#define MCU_CSR_PINRSTF (1u << 26)
#define MCU_CSR_PORRSTF (1u << 27)
#define MCU_CSR_SFTRSTF (1u << 28)
#define MCU_CSR_IWDGRSTF (1u << 29)

/* Exit statuses of swell-mcu (its --help says the same). */
enum mcu_exit {
	MCU_EXIT_OK = 0, /* the virtual time ran out (or the tunnel peer left) */
	MCU_EXIT_ERROR = 1, /* an I/O or set-up error: the image could not be loaded, a socket failed */
	MCU_EXIT_USAGE = 2,
	MCU_EXIT_WATCHDOG = 3, /* the IWDG was not refreshed in time: a watchdog reset */
	MCU_EXIT_CPU = 4, /* the CPU stopped: an instruction or access the emulator cannot carry out */
	MCU_EXIT_RESET = 5, /* the image asked for a system reset (AIRCR.SYSRESETREQ) */
};

struct mcu;

/* A memory-mapped model: a block of the address space with its registers. Reads and writes come with
 * the byte offset and access size (1, 2 or 4); advance brings the model's own events up to now (it is
 * called before every access too); next_event says when the next one is due (MCU_NEVER: none). */
struct mcu_periph {
	const char *name;
	uint32_t base, size;
	void *ctx;
	uint32_t (*read)(struct mcu *m, void *ctx, uint32_t off, unsigned size);
	void (*write)(struct mcu *m, void *ctx, uint32_t off, unsigned size, uint32_t v);
	void (*advance)(struct mcu *m, void *ctx, uint64_t now);
	uint64_t (*next_event)(struct mcu *m, void *ctx);
	struct mcu *owner; /* set by mcu_add_periph */
};

#define MCU_PERIPHS_MAX 32

/* The peripherals' state that other models or the run loop read. */
struct mcu_clocks {
	uint32_t sysclk_hz, pclk1_hz, pclk2_hz, tim_apb1_hz;
	uint32_t units_per_cycle; /* MCU_TIME_HZ / sysclk_hz */
};

struct mcu_nvic {
	uint8_t enabled[MCU_EXCS], pending[MCU_EXCS], active[MCU_EXCS], line[MCU_EXCS];
	uint8_t prio[MCU_EXCS]; /* the priority byte as written (top 4 bits implemented) */
	uint32_t prigroup; /* AIRCR.PRIGROUP */
	/* the active exceptions, innermost last, each with the EXC_RETURN it returns with */
	uint32_t stack[MCU_EXCS], depth;
};

struct mcu_symbol {
	uint32_t addr, size;
	const char *name;
};

struct mcu {
	uc_engine *uc;
	void *cpu; /* mcu_cpu.c's own state */
	uint64_t now; /* virtual time, MCU_TIME_HZ units */
	uint64_t cycles; /* CPU cycles executed (DWT CYCCNT; stops in WFI sleep as on silicon) */
	uint32_t cpi_milli, cpi_acc; /* cycles per instruction x 1000, and the fraction carried */
	uint64_t deadline; /* the block hook stops the CPU once now reaches it */
	uint64_t insns; /* instructions executed */
	int stop_req; /* the emulator asked unicorn to stop (else a stop is a WFI or a fault) */
	int pend_check; /* an exception waits behind PRIMASK or BASEPRI: look at every block start */
	int exc_return; /* the CPU branched to an EXC_RETURN value: unstack */
	int cpu_intno; /* an exception unicorn raised that the emulator does not carry out (0: none) */
	struct mcu_clocks clk;
	struct mcu_nvic nvic;
	uint32_t vtor, ccr, shcsr, cfsr, hfsr, cpacr, demcr, dwt_ctrl, aircr_extra, bfar;
	uint32_t fault_addr; /* the address of the last access outside memory (for BFAR) */
	uint64_t faults; /* faults taken (UsageFault, BusFault, HardFault) */
	struct mcu_periph periph[MCU_PERIPHS_MAX];
	unsigned n_periph;
	/* unmodelled registers reported so far (reported once each) */
	uint32_t unmodelled[256];
	unsigned n_unmodelled;
	/* the image's symbols, for reports */
	struct mcu_symbol *sym;
	size_t n_sym;
	char *strtab;
	FILE *trace_irq; /* --trace-irq: every exception entry and return, with its time */
	FILE *report; /* warnings and the end-of-run report (stderr) */
	int watchdog_bit; /* the IWDG ran out (set by its model) */
	int reset_req; /* AIRCR.SYSRESETREQ written */
	int restart_on_reset; /* a reset restarts the MCU (else it ends the run: MCU_EXIT_WATCHDOG, _RESET) */
	uint64_t resets; /* system resets carried out */
	uint32_t reset_flags; /* RCC_CSR's flags of the reset being carried out */
	uint64_t tim2_stop_at; /* fault injection: TIM2's counter stops here until the next reset */
	struct {
		void (*fn)(struct mcu *m, void *ctx);
		void *ctx;
	} sys_reset[8];
	unsigned n_sys_reset;
	struct {
		uint32_t off, bit; /* an RCC reset register's offset and the peripheral's bit */
		void (*fn)(struct mcu *m, void *ctx);
		void *ctx;
	} rcc_reset[8];
	unsigned n_rcc_reset;
	struct {
		uint32_t off, bit; /* an RCC enable register's offset and the peripheral's bit */
		void (*fn)(struct mcu *m, void *ctx, int on);
		void *ctx;
	} rcc_enable[8];
	unsigned n_rcc_enable;
	uint64_t irq_taken[MCU_EXCS];
	uint64_t wfi_count, wfi_units; /* WFIs, and the virtual time slept in them */
	uint64_t iwdg_refreshes; /* IWDG_KR 0xAAAA writes while the watchdog runs */
};

/* Address to "symbol+0x12" (or the bare address) in buf. */
const char *mcu_symbolize(const struct mcu *m, uint32_t addr, char *buf, size_t len);
/* The address of a symbol by name, 0 when there is none. */
uint32_t mcu_symbol_addr(const struct mcu *m, const char *name);

/* Register a model (before mcu_start); 0, or -1 when the table is full or unicorn refuses the map. */
int mcu_add_periph(struct mcu *m, const struct mcu_periph *p);
/* An interrupt line of a peripheral (irq: 0..MCU_IRQS-1), level-sensitive as on the F405's NVIC. */
void mcu_irq_line(struct mcu *m, unsigned irq, int level);
/* Set an exception pending (exception number: 15 SysTick, 16 + irq for an interrupt). */
void mcu_exc_pend(struct mcu *m, unsigned exc);
/* A model's reset line in RCC (RM0090 7.3.5 to 7.3.9: AHB1RSTR 0x10 .. APB2RSTR 0x24): fn runs when
 * the image sets `bit` at offset `off`. 0, or -1 when the table is full. */
int mcu_rcc_on_reset(struct mcu *m, uint32_t off, uint32_t bit, void (*fn)(struct mcu *m, void *ctx), void *ctx);
/* A model's clock enable in RCC (RM0090 7.3.10 to 7.3.14: AHB1ENR 0x30 .. APB2ENR 0x44): fn runs
 * with the bit's new value when a write changes it. 0, or -1 when the table is full. */
int mcu_rcc_on_enable(struct mcu *m, uint32_t off, uint32_t bit, void (*fn)(struct mcu *m, void *ctx, int on),
		      void *ctx);
/* A model's part in a system reset (RM0090 7.1.2: every register but RCC_CSR's flags and the backup
 * domain back to its reset value, SRAM kept): fn runs in registration order. 0, or -1 when full. */
int mcu_on_system_reset(struct mcu *m, void (*fn)(struct mcu *m, void *ctx), void *ctx);
/* Report an access to a register nothing models, once per address. */
void mcu_unmodelled(struct mcu *m, const char *what, uint32_t addr, int is_write, uint32_t v);

/* Elapsed virtual time in seconds, for messages. */
static inline double mcu_seconds(uint64_t t)
{
	return (double)t / (double)MCU_TIME_HZ;
}

/* mcu_elf.c: load a little-endian ELF32 ARM executable's PT_LOAD segments (at their physical
 * addresses) and its symbols. 0, or -1 with a one-line reason in why. */
int mcu_load_elf(struct mcu *m, const char *path, char *why, size_t why_len);

/* mcu_scs.c: the Cortex-M4 system control space (SCB, NVIC, SysTick, DWT, CoreDebug). */
int mcu_scs_add(struct mcu *m);

/* mcu_stm32.c: RCC, FLASH, PWR, GPIO A..I, TIM2, IWDG, the console USART, SYSCFG. */
struct mcu_stm32_opts {
	FILE *console; /* the console USART's bytes (NULL: dropped) */
	uint32_t hse_hz; /* the board's crystal; 0: no crystal (HSE never ready) */
	uint32_t hse_delay_us; /* HSERDY this long after HSEON */
};
int mcu_stm32_add(struct mcu *m, const struct mcu_stm32_opts *o);

/* mcu_cpu.c: the CPU, exceptions and the run loop. */
int mcu_init(struct mcu *m, uint32_t cpi_milli, char *why, size_t why_len);
void mcu_free(struct mcu *m);
/* Reset the CPU: SP and PC from the vector table at 0x08000000 (the flash, aliased at 0). */
int mcu_reset(struct mcu *m, char *why, size_t why_len);
/* Run until virtual time `until` (or a stop); returns MCU_EXIT_OK or the reason it stopped. The
 * hook, when set, runs between slices of at most `slice` units: it may feed inputs, pace to the wall
 * clock, or end the run (a nonzero return is the run's exit status, a negative one ends with OK). */
typedef int (*mcu_io_hook)(struct mcu *m, void *ctx);
int mcu_run(struct mcu *m, uint64_t until, uint64_t slice, mcu_io_hook hook, void *hook_ctx);
/* The next peripheral event (MCU_NEVER: none). */
uint64_t mcu_next_event(struct mcu *m);

#ifdef __cplusplus
}
#endif

#endif
