/* swell-hm: the HapticMaster model for the bench and the demo. It speaks the device side of the
 * swell protocol (DEVICE_POS + DEVICE_VEL every tick, or every --sample-every ticks while effect sets
 * come; FORCE_CMD, the effect sets and HEARTBEAT back) over UDP, SocketCAN or USB (host links),
 * integrates the admittance model of hm_model.h with a scripted hand (hm_hand.h), logs every tick to
 * CSV and prints a summary.
 *
 * Pacing: real time (absolute-deadline clock_nanosleep on CLOCK_MONOTONIC at --rate), or lockstep:
 * after sending sample n wait for the controller's answer (the first FORCE_CMD or complete effect set
 * that arrives after it; swell-ctl --clock device ticks once per DEVICE_POS, in effect mode as many
 * ticks as its seq step), with a timeout, then integrate. Lockstep runs as fast as the two processes
 * go and is deterministic. --link-delay holds what arrives for a number of device ticks before the
 * device acts on it (lockstep too: the delay is in device ticks).
 *
 * Its parts: hm_main.h. */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "hm_main.h"

int main(int argc, char **argv)
{
	struct opts o;
	FILE *log = NULL;
	double x0[3];
	int k;

	parse(argc, argv, &o);
	if (o.have_start)
		for (k = 0; k < 3; k++)
			x0[k] = o.start_mm[k] * 1e-3;
	else {
		double ref[3];

		hm_hand_start(&o.hand, ref); /* where the hand starts, in the reference frame */
		frame_to_dev(&o, ref, x0);
	}
	if (o.log) {
		log = fopen(o.log, "w");
		if (!log) {
			fprintf(stderr, "swell-hm: cannot write %s: %s\n", o.log, strerror(errno));
			return 1;
		}
		fputs("t_s,x_mm,y_mm,z_mm,vx_mm_s,vy_mm_s,vz_mm_s,fcmd_x_N,fcmd_y_N,fcmd_z_N,"
		      "fhand_x_N,fhand_y_N,fhand_z_N,",
		      log);
		/* --serve: the effects' force; the ticks since a request was last run, the number of
		 * clients and the device state (0 off, 1 init, 2 home, 3 force, 4 position, 5 stop) instead
		 * of the swell protocol's command columns */
		fputs(o.serve ? "req_age,clients,applied,dev_state,holding,d_port_mJ\n"
			      : "enable,cmd_age,applied,ctl_state,holding,d_port_mJ\n",
		      log);
	}
	setup_signals();
	setup_rt(&o, o.watchdog_given);
	return o.serve ? serve_main(&o, log, x0) : proto_main(&o, log, x0);
}
