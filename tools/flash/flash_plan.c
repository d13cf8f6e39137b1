/* swell-flash backends: see flash_plan.h. Each backend wraps the standard tool. */
#include "flash_plan.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define BASE "0x08000000"

static const char *const names[FLASH_BACKEND_COUNT] = { "dfu", "swd", "uart", "gdb" };

const char *flash_backend_name(enum flash_backend b)
{
	return (unsigned)b < FLASH_BACKEND_COUNT ? names[b] : "?";
}

struct builder {
	struct flash_plan *p;
	struct flash_step *s;
	int overflow;
};

static void step(struct builder *b, enum flash_step_kind kind, const char *what)
{
	if (b->p->nsteps >= FLASH_MAX_STEPS) {
		b->overflow = 1;
		b->s = NULL;
		return;
	}
	b->s = &b->p->step[b->p->nsteps++];
	b->s->kind = kind;
	b->s->what = what;
	b->s->argc = 0;
}

static void arg(struct builder *b, const char *fmt, ...)
{
	va_list ap;
	int n;

	if (!b->s || b->s->argc >= FLASH_MAX_ARGS) {
		b->overflow = 1;
		return;
	}
	va_start(ap, fmt);
	n = vsnprintf(b->s->arg[b->s->argc], FLASH_ARG_LEN, fmt, ap);
	va_end(ap);
	if (n < 0 || n >= FLASH_ARG_LEN)
		b->overflow = 1;
	b->s->argc++;
}

/* Each of n strings as an argument of its own, as it is. */
static void words(struct builder *b, const char *const *w, size_t n)
{
	for (size_t i = 0; i < n; i++)
		arg(b, "%s", w[i]);
}

#define WORDS(b, ...) \
	words(b, (const char *const[]){ __VA_ARGS__ }, sizeof((const char *const[]){ __VA_ARGS__ }) / sizeof(char *))

/* 1 when path holds a character that gdb's file name parsing cuts at or keeps literally. */
static int gdb_unsafe(const char *path)
{
	return path && path[strcspn(path, " \t\n\"'\\")] != '\0';
}

static void gdb_begin(struct builder *b, const struct flash_opts *o, enum flash_step_kind kind, const char *what)
{
	step(b, kind, what);
	WORDS(b, "gdb-multiarch", "-nx", "-batch", "-ex", "set confirm off", "-ex");
	if (o->gdb_server == FLASH_GDB_BMP) {
		arg(b, "target extended-remote %s", o->gdb_remote);
		WORDS(b, "-ex", "monitor swdp_scan", "-ex", "attach 1");
	} else {
		arg(b, "target remote %s", o->gdb_remote);
	}
}

static void build_gdb(struct builder *b, const struct flash_opts *o)
{
	gdb_begin(b, o, STEP_WRITE, "write and read back through the GDB remote");
	if (o->gdb_server == FLASH_GDB_OPENOCD)
		WORDS(b, "-ex", "monitor reset halt");
	arg(b, "-ex");
	if (o->elf)
		arg(b, "load");
	else
		arg(b, "restore %s binary " BASE, o->bin);
	arg(b, "-ex");
	arg(b, "dump binary memory %s " BASE " 0x%08lx", o->readback, (unsigned long)(0x08000000ul + o->len));
	/* Leave the target halted: it runs only after the read-back has been compared. */
	WORDS(b, "-ex", "disconnect");
	if (o->elf)
		arg(b, "%s", o->elf);
	/* The dump is in the same session as the write: mark the step as the read-back too. */
	b->s->kind = STEP_READBACK;
	gdb_begin(b, o, STEP_RESET, "reset and run");
	arg(b, "-ex");
	switch (o->gdb_server) {
	case FLASH_GDB_QEMU:
		WORDS(b, "monitor system_reset", "-ex", "detach");
		break;
	case FLASH_GDB_OPENOCD:
		WORDS(b, "monitor reset run", "-ex", "detach");
		break;
	case FLASH_GDB_BMP:
		arg(b, "kill");
		break;
	}
}

int flash_plan_build(const struct flash_opts *o, struct flash_plan *p, char *why, size_t why_len)
{
	struct builder b = { p, NULL, 0 };

	memset(p, 0, sizeof(*p));
	switch (o->backend) {
	case FLASH_DFU:
		/* DfuSe (the STM32 ROM bootloader): download erases the pages it writes. */
		step(&b, STEP_WRITE, "write over USB DFU (DfuSe)");
		WORDS(&b, "dfu-util", "-d", o->dfu_device, "-a", "0", "-s", BASE, "-D", o->bin);
		step(&b, STEP_READBACK, "read back over USB DFU");
		WORDS(&b, "dfu-util", "-d", o->dfu_device, "-a", "0", "-s");
		arg(&b, BASE ":%zu", o->len);
		WORDS(&b, "-U", o->readback);
		/* Leaving DFU only after the read-back matched: a 4-byte upload with the leave modifier. */
		step(&b, STEP_RESET, "leave DFU and start the image");
		WORDS(&b, "dfu-util", "-d", o->dfu_device, "-a", "0", "-s");
		arg(&b, BASE ":4:leave"); /* a joined literal in WORDS reads as a missing comma to clang-tidy */
		arg(&b, "-U");
		arg(&b, "%s.leave", o->readback);
		break;
	case FLASH_SWD:
		if (o->swd_tool == FLASH_SWD_OPENOCD) {
			/* openocd erases, writes, reads back and compares itself ("verify"). */
			step(&b, STEP_WRITE, "write, verify and reset over SWD (openocd)");
			WORDS(&b, "openocd", "-f", o->openocd_interface, "-f", "target/stm32f4x.cfg", "-c");
			if (o->elf)
				arg(&b, "program %s verify reset exit", o->elf);
			else
				arg(&b, "program %s " BASE " verify reset exit", o->bin);
			p->verify_by_tool = 1;
			break;
		}
		step(&b, STEP_WRITE, "write over SWD (st-flash)");
		WORDS(&b, "st-flash", "write", o->bin, BASE);
		step(&b, STEP_READBACK, "read back over SWD (st-flash)");
		WORDS(&b, "st-flash", "read", o->readback, BASE);
		arg(&b, "%zu", o->len);
		step(&b, STEP_RESET, "reset (st-flash)");
		WORDS(&b, "st-flash", "reset");
		break;
	case FLASH_UART:
		/* The ROM bootloader on USART1 (BOOT0 high at reset); stm32flash -v verifies too. */
		step(&b, STEP_WRITE, "write and verify over the UART ROM bootloader (stm32flash)");
		WORDS(&b, "stm32flash", "-b");
		arg(&b, "%u", o->baud);
		WORDS(&b, "-w", o->bin, "-v", "-S", BASE, o->serial);
		step(&b, STEP_READBACK, "read back over the UART ROM bootloader");
		WORDS(&b, "stm32flash", "-b");
		arg(&b, "%u", o->baud);
		WORDS(&b, "-r", o->readback, "-S");
		arg(&b, BASE ":%zu", o->len);
		WORDS(&b, o->serial);
		step(&b, STEP_RESET, "start the image (stm32flash -g)");
		WORDS(&b, "stm32flash", "-b");
		arg(&b, "%u", o->baud);
		WORDS(&b, "-g", BASE, o->serial);
		break;
	case FLASH_GDB:
		if (!o->elf && o->gdb_server != FLASH_GDB_QEMU) {
			snprintf(why, why_len,
				 "the GDB backend with openocd or a Black Magic Probe needs the ELF "
				 "(flash writes go through 'load'); give swell-fw.elf");
			return -1;
		}
		/* gdb's restore and dump take the file name up to the first blank and do not parse
		 * quotes (gdb 13, Debian 12): a path with a blank or a quote would be cut short */
		if ((!o->elf && gdb_unsafe(o->bin)) || gdb_unsafe(o->readback)) {
			snprintf(why, why_len,
				 "the GDB backend cannot hand '%s' to gdb: its restore and dump cut a "
				 "file name at a blank and keep quotes; use a path without them",
				 !o->elf && gdb_unsafe(o->bin) ? o->bin : o->readback);
			return -1;
		}
		build_gdb(&b, o);
		break;
	default:
		snprintf(why, why_len, "unknown backend %d", (int)o->backend);
		return -1;
	}
	if (b.overflow) {
		snprintf(why, why_len, "an argument is longer than %d characters", FLASH_ARG_LEN - 1);
		return -1;
	}
	return 0;
}

static int plain(const char *s)
{
	if (!*s)
		return 0;
	for (; *s; s++)
		if (!strchr("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./:=,+@%", *s))
			return 0;
	return 1;
}

void flash_step_format(const struct flash_step *s, char *out, size_t out_len)
{
	size_t n = 0;
	int i;

	if (out_len)
		out[0] = '\0';
	for (i = 0; i < s->argc && n < out_len; i++) {
		const char *a = s->arg[i], *c;

		if (i)
			n += (size_t)snprintf(out + n, out_len - n, " ");
		if (n >= out_len)
			break;
		if (plain(a)) {
			n += (size_t)snprintf(out + n, out_len - n, "%s", a);
			continue;
		}
		n += (size_t)snprintf(out + n, out_len - n, "'");
		for (c = a; *c && n < out_len; c++)
			n += (size_t)(*c == '\'' ? snprintf(out + n, out_len - n, "'\\''")
						 : snprintf(out + n, out_len - n, "%c", *c));
		if (n < out_len)
			n += (size_t)snprintf(out + n, out_len - n, "'");
	}
}
