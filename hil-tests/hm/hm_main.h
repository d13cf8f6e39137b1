/* swell-hm's parts (see swell-hm.c): the options, the run's figures and the pieces both modes share.
 * hm_args.c parses the command line; hm_run.c paces, counts and reports; hm_proto.c is the device
 * side of the swell protocol, hm_serve_main.c the HapticMaster's own TCP interface (--serve). */
#ifndef SWELL_HM_MAIN_H
#define SWELL_HM_MAIN_H

#include <signal.h>
#include <stdint.h>
#include <stdio.h>

#include "hm_hand.h"
#include "hm_model.h"
#include "swell/link_spec.h"

#define RHO_KG_M3 1000.0

struct opts {
	const char *link, *host, *log, *serve;
	struct swell_link_spec ls; /* --link parsed */
	unsigned bias_watchdog_ms;
	double effect_fresh_ms; /* effect mode: a set older than this is not rendered */
	double link_delay_ms; /* what arrives is acted on this much later (whole ticks) */
	unsigned sample_every; /* while effect sets come: a sample every this many ticks; 0: auto */
	struct inject {
		char kind; /* 'd' delay, 'g' garbage, 'r' reset, 's' stop */
		double at_s, for_s, ms;
		int done;
	} inj[8];
	int n_inj;
	unsigned port, bind_port, node, iface;
	int lockstep, quiet, have_start, rt, watchdog_given;
	int uncalibrated; /* --serve: init does not calibrate (a device whose calibration fails) */
	unsigned timeout_ms;
	double seconds, start_mm[3], estop_s[2];
	double obj_mass_g, obj_a_mm, obj_b_mm, pool_mm[2];
	double obj_h_mm, depth_mm; /* from --scene: the object sinks to the floor when m > rho a b H */
	struct hm_params p;
	struct hm_hand hand;
	/* The scene's device-to-pool frame (frame.*, as the controller has it: pool = off + sign x scale x
	 * device[axis]). The device model, its samples and --start are in the device's own frame; the
	 * hand and the report's z in the reference frame's (pool - the default offset, 200, 200, 0 mm). */
	double frame_off_mm[3], frame_scale;
	int frame_axis[3], frame_sign[3];
};

#define HIST_US 10000

struct run {
	uint64_t ticks, timeouts, zeroed_ticks, late_ticks;
	uint32_t timeouts_in_row; /* lockstep: waits without an answer since the last answer */
	uint64_t own_ticks; /* lockstep: controller ticks that no sample drove (its seq moved against ours) */
	int have_offset;
	uint8_t offset, offset0; /* FORCE_CMD seq - n: now, and at the first answer */
	double peak_f_N, z_sum, z_min, z_max;
	uint64_t z_n;
	int held_late; /* the hand held the handle in the last second: no free float to compare */
	uint32_t hist[HIST_US + 1];
	int64_t late_max_ns;
	/* the energy at the device's port (docs/energy.md): W the work of the hand on what the device
	 * renders, -F_cmd . dx with the force it applied over the tick; D = W less the object's static
	 * energy gained since the start (its weight, the buoyancy with the water at rest, the floor) */
	double w_port_J, s0_J, d_port_J, d_min_J;
};

/* hm_args.c: the options from the command line; exits 2 with one line on stderr when they are bad. */
void parse(int argc, char **argv, struct opts *o);

/* hm_run.c */
extern volatile sig_atomic_t stop_flag; /* SIGINT or SIGTERM came */
void setup_signals(void);
void setup_rt(struct opts *o, int watchdog_given);
int64_t now_ns(void);
void print_lateness(const struct run *r); /* the summary's "tick lateness" line */
void sleep_deadline(struct run *r, int64_t *next, int64_t period_ns);
void account(struct run *r, const struct opts *o, const struct hm_state *s, double t, int holding);
/* The object's static energy at reference-frame z (m, its bottom), J (docs/energy.md). */
double static_energy_J(const struct opts *o, double z_m);
void print_energy(const struct run *r); /* the summary's "energy" line */
/* The frame: a position from the reference frame to the device's (metres), and back; the hand's
 * force for the device (reference-frame hand, forces mapped unscaled as the controller maps its own). */
void frame_to_dev(const struct opts *o, const double ref_m[3], double dev_m[3]);
void frame_from_dev(const struct opts *o, const double dev_m[3], double ref_m[3]);
int frame_hand_force(struct opts *o, double t, const double x_dev[3], const double v_dev[3], double f_dev[3]);
void summary_head(const struct opts *o, const struct hm_state *s, const struct run *r, uint32_t ctl_faults,
		  double wall_s);

/* The device loop of each mode, to the end of the run: the exit status. */
int proto_main(struct opts *o, FILE *log, const double x0[3]);
int serve_main(struct opts *o, FILE *log, const double x0[3]);

#endif
