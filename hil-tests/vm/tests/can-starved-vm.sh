#!/bin/sh
# can-starved-vm.sh: run in the hil-vm transports boot (run-vm --file; needs swell-ctl, swell-hm and
# iproute2's tc and can-utils' candump through run-vm --host-prog). The controller's "device starved"
# path on the kernel's CAN stack: swell-ctl runs the loop on can0 (--autorun, silence limit 200
# ticks) with swell-hm on can1 holding the object above the water (the weight is commanded), in
# lockstep as in the bench scenarios (swell-ctl --clock device, swell-hm --lockstep: on their own
# clocks an emulated machine's scheduling gaps leave controller ticks without a sample, which keep
# restarting the 250 ticks in a row of hearing the device that autorun's recovery needs). can0's
# root queue is a pfifo from the start; its limit goes to 0 (every frame swell-ctl writes is refused,
# ENOBUFS, while the device still talks) and back to 10. The limit is changed in place: replacing the
# queue (tc qdisc add/del) stops the interface for a moment, in which frames are dropped though the
# write succeeds, and the frames the test looks for went there. Checked:
#   - swell-ctl says once on stderr that no command reached the device, and its report counts the
#     device starved once;
#   - the device got nothing in that time (its command age passes the silence limit);
#   - on the bus (candump on can1), the first FORCE_CMD after the gap is disabled (zero force): the
#     device's own log cannot show it, as it takes the latest of the commands that came in since its
#     last tick, and the loop is RUNNING again two ticks later;
#   - the loop recovers by itself (--autorun): enabled commands with the weight again.
# Exit 0 when all hold, 1 otherwise (with the files shown).
set -u
out=/tmp/can-starved
rm -rf "$out"
mkdir -p "$out" || exit 1
show() {
	for f in ctl.txt ctl.err hm.txt; do echo "--- $f"; cat "$out/$f"; done
	echo "--- force.log: $(wc -l <"$out/force.log") FORCE_CMD frames, the first 3"
	head -3 "$out/force.log"
	echo "--- hm.csv: the header, the gap's first and last 5 rows and 10 after it"
	awk -F, 'NR == 1 { print; next } $15 > 100 { if (!g) print "..."; if (g < 5) print; g++; last[g % 5] = $0; next }
		g && !a { for (k = g + 1; k <= g + 5; k++) if (k > 5) print last[k % 5]; print "..." }
		g { print; a++ } a >= 10 { exit }' "$out/hm.csv"
}
fail() { echo "can-starved: FAIL: $*"; show; $tc qdisc del dev can0 root 2>/dev/null; exit 1; }
# iproute2's tc (run-vm --host-prog), not busybox's applet of the same name, which has no pfifo
tc=/swell/bin/tc
[ -x $tc ] || fail "$tc is not in the VM (run-vm --host-prog with iproute2's tc)"
command -v candump >/dev/null || fail "candump is not in the VM (run-vm --host-prog with can-utils' candump)"
rows() { wc -l 2>/dev/null <"$out/hm.csv" || echo 0; }
wait_for() { # wait_for SECONDS COMMAND...: until COMMAND succeeds (polled every 0.1 s)
	n=$(($1 * 10)); shift
	while ! "$@"; do n=$((n - 1)); [ $n -gt 0 ] || return 1; sleep 0.1; done
}

$tc qdisc add dev can0 root pfifo limit 10 || fail "tc could not put a pfifo on can0"
candump -L can1,010:7FF >"$out/force.log" 2>&1 & # FORCE_CMD of node 0 (id 0x010)
dump=$!
swell-ctl --clock device --no-rt --autorun --quiet --tick-hz 1000 --silent-ticks 200 \
	--device can:can0 --host none >"$out/ctl.txt" 2>"$out/ctl.err" &
ctl=$!
sleep 0.3
swell-hm --link can:can1 --rate 1000 --lockstep --quiet --hand drop:z=20,hold=1000 --log "$out/hm.csv" \
	--seconds 6 >"$out/hm.txt" 2>&1 &
hm=$!
# running for a while (the log is written in blocks: about 1 s of rows)
wait_for 60 sh -c "[ \$(wc -l 2>/dev/null <'$out/hm.csv' || echo 0) -ge 1000 ]" ||
	fail "swell-hm logged no second of running ($(rows) rows)"
$tc qdisc change dev can0 root pfifo limit 0 || fail "tc could not set can0's queue limit to 0"
echo "can-starved: can0 refuses every frame from row $(rows) of the device's log"
wait_for 30 grep -q "no command reached the device" "$out/ctl.err" ||
	fail "swell-ctl did not say it starved within 30 s"
sleep 1 # the longest pause on the bus by far (the device's exit leaves one of 0.2 s)
$tc qdisc change dev can0 root pfifo limit 10 || fail "tc could not set can0's queue limit back to 10"
echo "can-starved: can0 sends again from row $(rows)"
wait $hm || fail "swell-hm exited $?"
kill -TERM $ctl
wait $ctl || fail "swell-ctl exited $? after SIGTERM"
kill $dump
wait $dump
$tc qdisc del dev can0 root || fail "tc could not give can0 its own queue back"

n=$(grep -c "no command reached the device" "$out/ctl.err")
[ "$n" = 1 ] || fail "swell-ctl said $n times that it starved, not once"
grep -q "device starved  1 times" "$out/ctl.txt" || fail "the report does not count the device starved once"
# hm.csv columns: 14 enable, 15 cmd_age, 10 fcmd_z_N. Before the gap: enabled with the weight; in the
# gap the age passes the silence limit; after it enabled with the weight again (recovered).
awk -F, -v limit=200 '
	NR == 1 { next }
	gap == 0 && $15 == 0 && $14 == 1 && $10 < -0.5 { before++ }
	gap == 0 && before >= 100 && $15 > limit { gap = 1; age = $15; next }
	gap == 1 && $15 > age { age = $15 }
	gap == 1 && $15 == 0 { gap = 2; next }
	gap == 2 && $14 == 1 && $10 < -0.5 { after++ }
	END {
		printf "can-starved: device log: %d rows enabled with the weight before, nothing heard for %d ticks, " \
		       "%d rows enabled with the weight after\n", before, age, after
		if (before < 100 || gap < 2 || after < 100)
			exit 1
	}' "$out/hm.csv" || fail "the device's log does not show the weight, the gap and the recovery"
# force.log lines: (SECONDS) can1 010#DATA; DATA's byte 7 bit 0 is enable, bytes 4-5 fz_cN (little
# endian). The longest pause between two FORCE_CMD frames is the gap; the frame after it is disabled.
awk '{
		t = substr($1, 2, length($1) - 2) + 0
		d = substr($3, index($3, "#") + 1)
		en = index("13579BDF", substr(d, 16, 1)) > 0
		if (n && t - last > gap) { gap = t - last; first = en; at = n; frame = $0 }
		last = t; n++
	}
	END {
		printf "can-starved: bus: %d FORCE_CMD frames, longest pause %.3f s, the frame after it: %s (enable %d)\n",
		       n, gap, frame, first
		if (gap < 0.5 || first != 0)
			exit 1
	}' "$out/force.log" || fail "on the bus the first FORCE_CMD after the gap is not the disabled one"
grep "device link\|device starved\|FAULTED" "$out/ctl.txt"
echo "can-starved: PASS"
