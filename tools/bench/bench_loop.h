/* swell-bench loop: the coupled loop's stability map (bench_loop.c; the loop itself: loop.h). */
#ifndef SWELL_BENCH_LOOP_MAIN_H
#define SWELL_BENCH_LOOP_MAIN_H

#include <stdio.h>

/* DIR/NAME opened for writing, or exit 1 with a reason (main.c; every subcommand's outputs). */
FILE *open_out_in(const char *dir, const char *name);

/* swell-bench loop's arguments (argv[0] is "loop") and run; the exit status. */
int bench_loop_main(int argc, char **argv);
/* its --help text */
const char *bench_loop_usage(void);

#endif
