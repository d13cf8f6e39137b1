/* swell-bench loop: the coupled loop's stability map (bench_loop.c; the loop itself: loop.h). */
#ifndef SWELL_BENCH_LOOP_MAIN_H
#define SWELL_BENCH_LOOP_MAIN_H

/* swell-bench loop's arguments (argv[0] is "loop") and run; the exit status. */
int bench_loop_main(int argc, char **argv);
/* its --help text */
const char *bench_loop_usage(void);

#endif
