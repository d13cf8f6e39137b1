#!/bin/busybox sh
# flash-link-vm.sh: runs inside the HIL VM after dfu-flash-vm.sh (run-vm --usb none, CAN up at 1 Mbit/s;
# see dfu-flash). For each carrier of the controller's host link, CAN (swell-ctl on can0, swell-flash on
# can1: kvaser_pci, one emulated bus) and USB (swell-ctl the FunctionFS gadget through vm-gadget,
# swell-flash the libusb host):
#   1. swell-ctl --fw-version 0.0.9 (the old image) runs the loop (--autorun) with swell-hm holding
#      the object (device link on UDP, lockstep); swell-flash --enter-bootloader refuses while it is
#      RUNNING: exit 2, and the controller goes on (still running 1 s later);
#   2. with --force: AUTORUN=0 and COMMAND=STOP, the request, swell-ctl exits 3; a supervisor here
#      plays the F405's reset into its ROM: the emulated DfuSe bootloader comes up (vm-dfu-gadget),
#      swell-flash flashes it with the real dfu-util, and after the leave the supervisor starts
#      swell-ctl --fw-version VERSION (the image's header) on the same carrier; swell-flash must find
#      it there and say "controller back, running version VERSION" (exit 0);
#   3. independently of swell-flash: the old swell-ctl's exit status 3 and its report; the device's
#      log (swell-hm --log) has a commanded force while running and fresh zero commands after the
#      last non-zero one, before the controller went silent; the DfuSe flash file equals the BIN;
#   4. swell-flash BIN --check-only --find LINK reports VERSION again.
# Usage: sh flash-link-vm.sh BIN [CARRIERS]   (CARRIERS default "can usb")
# Prints one "figure:" line per carrier (request to last heartbeat, new swell-ctl start to CTL_INFO
# found, both as swell-flash saw them) and "flash-link: N failed".
bin=$1 carriers=${2:-can usb}
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
up() { cut -d' ' -f1 /proc/uptime; } # CLOCK_BOOTTIME: the VM never suspends, so CLOCK_MONOTONIC too
wait_for() { # wait_for TENTHS TEST...
	t=$1; shift
	while ! "$@"; do
		[ "$t" -gt 0 ] || return 1
		sleep 0.1; t=$((t - 1))
	done
}
len=$(wc -c <"$bin")
ver=$(swell-flash "$bin" --check-only | sed -n 's/.*, version \([0-9.]*\),.*/\1/p')
[ -n "$ver" ] || { echo "FAIL: swell-flash --check-only gave no version for $bin"; exit 1; }
old=0.0.9
[ "$ver" != "$old" ] || old=0.0.8
port=47830 # the device link (swell-hm) on UDP, over the VM's loopback (init brings it up)

# swell-ctl with its pid and exit status in /tmp/ctl-TAG.pid, .rc and its output in .out:
# sh -c "$ctl" TAG ARGS... (also as vm-gadget's PROGRAM, which replaces @FFS@ in ARGS)
ctl='swell-ctl "$@" >/tmp/ctl-$0.out 2>&1 & echo $! >/tmp/ctl-$0.pid; wait $!; echo $? >/tmp/ctl-$0.rc'
start_ctl() { # start_ctl CARRIER TAG ARGS...
	c=$1 tag=$2; shift 2
	rm -f /tmp/ctl-$tag.rc /tmp/ctl-$tag.pid /tmp/ctl-$tag.out
	case $c in
	can) sh -c "$ctl" "$tag" --host can:can0 "$@" & ;;
	usb) vm-gadget up sh -c "$ctl" "$tag" --host usb:@FFS@ "$@" || return 1 ;;
	esac
	wait_for 50 test -s /tmp/ctl-$tag.pid
}
cleanup() { # cleanup CARRIER: stop whatever still runs (after a failed step too) and forget it
	for t in old new; do
		[ ! -f /tmp/ctl-$t.pid ] || [ -f /tmp/ctl-$t.rc ] || kill "$(cat /tmp/ctl-$t.pid)" 2>/dev/null
		[ ! -f /tmp/ctl-$t.pid ] || wait_for 100 test -f /tmp/ctl-$t.rc || fail "$1: swell-ctl $t did not stop"
	done
	[ -z "$hm" ] || { kill $hm 2>/dev/null; wait $hm 2>/dev/null; }
	[ ! -d /sys/kernel/config/usb_gadget/swell ] || vm-gadget down || fail "$1: vm-gadget down"
	vm-dfu-gadget down 2>/dev/null
	rm -f /tmp/ctl-* /tmp/hm.csv /tmp/fl.bin /tmp/dfuse.log /tmp/new-start
}
# What the F405 does after an accepted request, for swell-ctl (no ROM on Linux): when it has exited,
# the ROM DFU bootloader comes up; when dfu-util's leave has started the image, that is the new
# swell-ctl with the image's version, on the same carrier.
supervise() { # supervise CARRIER
	wait_for 600 test -f /tmp/ctl-old.rc || { echo "supervisor: swell-ctl did not exit"; return 1; }
	echo "supervisor: swell-ctl exited with $(cat /tmp/ctl-old.rc) at uptime $(up) s"
	[ "$1" != usb ] || vm-gadget down || return 1 # the ROM's DFU device needs the UDC
	rm -f /tmp/fl.bin /tmp/dfuse.log
	vm-dfu-gadget up --flash /tmp/fl.bin --log /tmp/dfuse.log || return 1
	vm-dfu-gadget wait-gone 90 || { echo "supervisor: the DFU target did not leave"; return 1; }
	vm-dfu-gadget down
	up >/tmp/new-start
	start_ctl "$1" new --no-rt --quiet --fw-version "$ver" --tick-hz 1000 --device udp:$((port + 1)) --seconds 120
	echo "supervisor: swell-ctl $ver started at uptime $(cat /tmp/new-start) s"
}

for c in $carriers; do
	case $c in can) link=can:can1 ;; usb) link=usb ;; *) fail "unknown carrier $c"; continue ;; esac
	hm=
	cleanup $c
	echo "=== $c: swell-ctl host link on $c, swell-flash --enter-bootloader $link"
	# 1. The old image runs the loop, the object held above the water (its weight commanded).
	start_ctl $c old --no-rt --quiet --fw-version $old --clock device --autorun --tick-hz 1000 \
		--silent-ticks 200 --device udp:$port || { fail "$c: swell-ctl did not start"; continue; }
	swell-hm --link udp --port $port --rate 1000 --lockstep --quiet --hand drop:z=20,hold=1000 \
		--log /tmp/hm.csv --seconds 120 >/tmp/hm.txt 2>&1 &
	hm=$!
	running() { [ -f /tmp/hm.csv ] && tail -n 20 /tmp/hm.csv | awk -F, '$17 == 3 { f = 1 } END { exit !f }'; }
	wait_for 300 running || fail "$c: the controller did not reach RUNNING in 30 s"
	swell-flash "$bin" --backend dfu --enter-bootloader $link >/tmp/out 2>&1
	rc=$?
	cat /tmp/out
	[ $rc -eq 2 ] || fail "$c: RUNNING: swell-flash exit $rc, expected 2"
	grep -q 'controller is RUNNING .*nothing sent' /tmp/out || fail "$c: RUNNING: no refusal"
	sleep 1
	[ ! -f /tmp/ctl-old.rc ] || fail "$c: RUNNING: swell-ctl ended (exit $(cat /tmp/ctl-old.rc)) after a refusal"
	echo "check: $c: RUNNING refused by swell-flash (exit $rc), swell-ctl still running 1 s later"

	# 2. --force: stop, enter the bootloader, flash the DfuSe target, find the new image.
	supervise $c >/tmp/supervisor.txt 2>&1 &
	sup=$!
	swell-flash "$bin" --backend dfu --enter-bootloader $link --force --dfu-wait 20 --find-timeout 30 >/tmp/out 2>&1
	rc=$?
	grep '^swell-flash' /tmp/out # (dfu-util's own lines left out)
	wait $sup || fail "$c: the supervisor failed"
	cat /tmp/supervisor.txt
	[ $rc -eq 0 ] || fail "$c: --force: swell-flash exit $rc, expected 0"
	grep -q 'sending AUTORUN=0 and COMMAND=STOP' /tmp/out || fail "$c: --force: no STOP"
	grep -q "verify ok: $len bytes" /tmp/out || fail "$c: no verify ok"
	grep -q "controller back, running version $ver (" /tmp/out || fail "$c: controller not found back with $ver"

	# 3. Independently of swell-flash.
	[ "$(cat /tmp/ctl-old.rc 2>/dev/null)" = 3 ] || fail "$c: old swell-ctl exit $(cat /tmp/ctl-old.rc 2>/dev/null), expected 3"
	grep -q 'enter-bootloader accepted in state armed' /tmp/ctl-old.out ||
		{ fail "$c: old swell-ctl did not report the request accepted in ARMED"; cat /tmp/ctl-old.out; }
	kill $hm; wait $hm
	# the device's view: fcmd_z ($10) while RUNNING, then fresh (cmd_age $15 = 0) zero commands
	awk -F, -v c=$c 'NR > 1 { if ($17 == 3 && ($10 > 0.5 || $10 < -0.5)) held++
		if ($8 != 0 || $9 != 0 || $10 != 0) { last = NR; zeros = 0 } else if ($15 == 0 && last) zeros++ }
		END { printf "check: %s: device log: %d ticks with the weight commanded while RUNNING, then %d fresh zero commands before the controller went silent\n", c, held, zeros
		      exit !(held > 0 && zeros > 0) }' /tmp/hm.csv || fail "$c: the device log does not show the force zeroed before the controller went"
	if cmp -n "$len" "$bin" /tmp/fl.bin >/tmp/cmp 2>&1; then
		echo "check: $c: DfuSe flash file equals the BIN over $len bytes"
	else
		fail "$c: DfuSe flash file differs from the BIN: $(cat /tmp/cmp)"
	fi
	# 4. Found again on its own.
	swell-flash "$bin" --check-only --find $link --find-timeout 10 >/tmp/out2 2>&1
	rc=$?
	grep 'controller back' /tmp/out2
	[ $rc -eq 0 ] && grep -q "controller back, running version $ver (" /tmp/out2 ||
		{ fail "$c: --check-only --find: exit $rc"; cat /tmp/out2; }
	gone=$(sed -n 's/.*(last heartbeat \([0-9.]*\) s after the request.*/\1/p' /tmp/out)
	bus=$(sed -n 's/.*device left the bus \([0-9.]*\) s after it.*/\1/p' /tmp/out)
	found=$(sed -n 's/.*controller back.*at \([0-9.]*\) s CLOCK_MONOTONIC.*/\1/p' /tmp/out)
	awk -v c=$c -v g="${gone:--}" -v b="${bus:--}" -v f="${found:-0}" -v s="$(cat /tmp/new-start 2>/dev/null || echo 0)" \
		'BEGIN { printf "figure: %s: request to last heartbeat %s s%s; new swell-ctl started to CTL_INFO found %.2f s (uptime %.2f -> %.3f)\n",
		 c, g, b == "-" ? "" : ", device left the bus " b " s", f - s, s, f }'
	cleanup $c
done
echo "flash-link: $fails failed"
[ $fails -eq 0 ]
