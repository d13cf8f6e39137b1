#!/bin/sh
# m4-tick-trace: the cycle estimate of one controller tick of the STM32F405 image (the worst whole tick
# of the self-test's core run unless a tick is given), from the instructions QEMU executes in it.
#
# usage: m4-tick-trace.sh QEMU GDB IMAGE.elf OUTDIR [HZ [TICK]]
#   QEMU  qemu-system-arm (7.2: netduinoplus2, -icount shift=0)
#   GDB   gdb-multiarch (drives QEMU's gdb stub)
#   HZ    the core run's rate: 2500 (default) or 1000
#   TICK  the tick's index in that run (default: the worst whole tick the self-test reports)
#
# 1. The self-test runs once as usual; its line "core at HZ Hz: ... worst whole tick ... at tick N"
#    names the tick.
# 2. It runs again under the debugger with QEMU logging every translated block (-d in_asm,nochain:
#    blocks are never chained, so each execution can be logged); the debugger writes HZ and N into
#    selftest_trace_hz / selftest_trace_tick once main() runs, and turns the execution log on at
#    selftest_trace_begin and off at selftest_trace_end (QEMU monitor "log"), which run around that
#    tick's force and background parts only.
# 3. tools/bench/m4-cycles.py weighs the window's instructions (the model: docs/stm32f405.md, "A cycle
#    model").
# Output: OUTDIR/selftest.log, OUTDIR/trace.log, OUTDIR/cycles.txt (printed; by function too when
# arm-none-eabi-nm is found). About 30 s on 2 cores.
set -u
[ $# -ge 4 ] || { sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
qemu=$1 gdb=$2 elf=$3 out=$4 hz=${5:-2500} tick=${6:-}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out" || exit 2
. "$here/../../firmware/stm32f405/tests/qemu-run.sh"
if [ -z "$tick" ]; then
	qemu_run "$out/selftest.log" '^selftest: end' 120 "$qemu" "$elf" >/dev/null
	tick=$(sed -n "s/^core at $hz Hz: worst background [0-9].* at tick \([0-9]*\),.*/\1/p" "$out/selftest.log")
	[ -n "$tick" ] || { echo "m4-tick-trace: no worst tick at $hz Hz in $out/selftest.log" >&2; exit 1; }
fi
# QEMU waits for the debugger (-S) on a port of its own; a port taken makes it exit: the next one
qpid="" n=0
while [ -z "$qpid" ] && [ $n -lt 6 ]; do
	n=$((n + 1))
	port=$((21000 + ($$ + n * 1009) % 28000))
	rm -f "$out/trace.log"
	"$qemu" -M netduinoplus2 -nographic -icount shift=0 -monitor none -serial file:"$out/serial.log" \
		-d in_asm,nochain -D "$out/trace.log" -S -gdb tcp:127.0.0.1:$port -kernel "$elf" </dev/null \
		>"$out/qemu.log" 2>&1 &
	qpid=$!
	sleep 0.3
	kill -0 "$qpid" 2>/dev/null || { wait "$qpid" 2>/dev/null; qpid=""; }
done
[ -n "$qpid" ] || { echo "m4-tick-trace: QEMU did not start: $(cat "$out/qemu.log")" >&2; exit 1; }
cat >"$out/gdb.cmd" <<EOF
set pagination off
set confirm off
target remote 127.0.0.1:$port
break main
continue
set var *(unsigned int *)&selftest_trace_hz = $hz
set var *(unsigned int *)&selftest_trace_tick = $tick
delete
break selftest_trace_begin
break selftest_trace_end
continue
monitor log in_asm,exec,nochain
continue
monitor log in_asm,nochain
kill
quit
EOF
timeout 300 "$gdb" -batch -nx -x "$out/gdb.cmd" "$elf" >"$out/gdb.log" 2>&1
rc=$?
kill "$qpid" 2>/dev/null
wait "$qpid" 2>/dev/null
[ $rc -eq 0 ] || { echo "m4-tick-trace: the debugger failed (rc $rc, $out/gdb.log)" >&2; exit 1; }
echo "tick $tick of the core run at $hz Hz"
nm=$(dirname "$gdb")/arm-none-eabi-nm
command -v arm-none-eabi-nm >/dev/null && nm=arm-none-eabi-nm
"$nm" -S "$elf" >"$out/nm.txt" 2>/dev/null || : >"$out/nm.txt"
python3 "$here/m4-cycles.py" "$out/trace.log" --nm "$out/nm.txt" | tee "$out/cycles.txt"
