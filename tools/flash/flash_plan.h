/* swell-flash backends: the command lines each backend runs, built from the options without
 * touching anything (pure, so the dry run and the tests see exactly what a real run executes). */
#ifndef SWELL_FLASH_PLAN_H
#define SWELL_FLASH_PLAN_H

#include <stddef.h>

enum flash_backend {
	FLASH_DFU,
	FLASH_SWD,
	FLASH_UART,
	FLASH_GDB,
	FLASH_BACKEND_COUNT
};
enum flash_swd_tool {
	FLASH_SWD_OPENOCD,
	FLASH_SWD_STFLASH
};
enum flash_gdb_server {
	FLASH_GDB_OPENOCD,
	FLASH_GDB_QEMU,
	FLASH_GDB_BMP
};

/* What a step is for: the runner compares the read-back file after a READBACK step, and runs
 * RESET steps only after the comparison succeeded. */
enum flash_step_kind {
	STEP_WRITE,
	STEP_READBACK,
	STEP_RESET
};

#define FLASH_MAX_ARGS 40
#define FLASH_ARG_LEN 512
#define FLASH_MAX_STEPS 4

struct flash_step {
	enum flash_step_kind kind;
	const char *what; /* progress text */
	int argc;
	char arg[FLASH_MAX_ARGS][FLASH_ARG_LEN];
};

struct flash_opts {
	enum flash_backend backend;
	const char *elf; /* the image as ELF, or NULL when the input is a BIN */
	const char *bin; /* the image as BIN (the input, or one written from the ELF) */
	const char *readback; /* where the read-back lands */
	size_t len; /* image bytes */
	const char *dfu_device; /* "0483:df11" */
	enum flash_swd_tool swd_tool;
	const char *openocd_interface; /* "interface/stlink.cfg" */
	const char *serial; /* "/dev/ttyUSB0" */
	unsigned baud;
	const char *gdb_remote; /* "localhost:3333", "localhost:1234" or "/dev/ttyACM0" */
	enum flash_gdb_server gdb_server;
};

struct flash_plan {
	int nsteps;
	struct flash_step step[FLASH_MAX_STEPS];
	int verify_by_tool; /* the tool compares itself (openocd program ... verify) */
};

const char *flash_backend_name(enum flash_backend b);

/* Build the steps of o->backend into *p. 0, or -1 with a one-line reason in why (e.g. an
 * argument that does not fit, a BIN given to a GDB server that needs the ELF). */
int flash_plan_build(const struct flash_opts *o, struct flash_plan *p, char *why, size_t why_len);

/* One step as a shell command line (arguments quoted where needed) into out. */
void flash_step_format(const struct flash_step *s, char *out, size_t out_len);

#endif
