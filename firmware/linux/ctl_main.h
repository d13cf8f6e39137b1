/* swell-ctl's parts (see swell-ctl.c): the options, the port's state and the report. ctl_args.c parses
 * the command line and the scene file; ctl_report.c prints the report at exit. */
#ifndef SWELL_CTL_MAIN_H
#define SWELL_CTL_MAIN_H

#include <netinet/in.h>
#include <stddef.h>
#include <stdint.h>

#include "ctl_link.h"
#include "swell/ctl.h"
#include "swell/ctl_pool.h"
#include "swell/scene.h"

struct opts {
	const char *device, *host, *scene_path;
	int device_clock, rt, quiet, silent_given;
	int full_force; /* hm: keep the configured force limits (no first-run limits) */
	uint16_t pool_max; /* the arena holds a pool_max x pool_max pool (and at least the one configured) */
	double seconds;
	struct swell_ctl_config cfg;
	struct swell_scene scene;
};

struct port {
	struct swell_ctl c;
	struct ctl_link dev, host;
	int have_host;
	struct fw_mem mem; /* the arena, for a pool chosen at start-up (swell/ctl_pool.h) */
	struct fw_pool_at place;
	uint32_t bad_seen;
	uint32_t bus_offs_seen[2], restarts_seen[2]; /* CAN: device, host link */
	uint32_t starved; /* times nothing reached the device for silent_ticks ticks in a row */
	int starving; /* the present run of unsent ticks has been reported */
	uint32_t releases; /* times the device was declared lost and a learned UDP device let go */
	int64_t sample_ns; /* when the device's last DEVICE_POS came (0: none yet) */
	uint32_t faults_seen; /* the core's fault count after the last tick */
	int64_t fault_ns, fault_sample_ns; /* the last fault: when it began, and sample_ns then */
};

/* timing statistics: lateness of each wake-up against its deadline */
#define HIST_US 20000 /* 1 us bins up to 20 ms; later goes in the last bin */

struct jitter {
	uint32_t hist[HIST_US + 1];
	uint64_t n;
	int64_t max_ns;
};

/* ctl_args.c: the options (exits 2 with one line on stderr when they are bad), then the scene's
 * parameters through the core's own validated path once the core is up (-1 when it refuses one). */
void parse(int argc, char **argv, struct opts *o);
int scene_params(struct swell_ctl *c, const struct opts *o);

/* The gentle start on a HapticMaster (device hm:, no --full-force): force.max and force.rate lowered
 * to the first-run limits (never raised), said on stderr; -1 when the core refuses. */
#define CTL_FIRST_FORCE_MAX_UN 2000000 /* 2 N */
#define CTL_FIRST_FORCE_RATE 20000000 /* 20 N/s */
int first_run_limits(struct swell_ctl *c, const struct opts *o);

/* ctl_report.c: "ADDR:PORT" of a, "(fixed)" after a configured one, or "none yet"; the report. */
const char *addr_str(const struct sockaddr_in *a, int have, int fixed, char *buf, size_t len);
void report(const struct opts *o, const struct port *p, const struct jitter *jit, uint64_t ticks, double ran_s,
	    int32_t peak_h);

#endif
