#!/bin/sh
# The worst whole tick of the self-test's core run at 2500 Hz, in cycles by the model of
# docs/stm32f405.md ("A cycle model": tools/bench/m4-tick-trace.sh traces that tick's instructions
# under QEMU, tools/bench/m4-cycles.py weighs them), against its budget in % of the 400 us period at
# 168 MHz (67 200 cycles).
# usage: qemu-tick-cycles.sh QEMU GDB IMAGE.elf BUDGET_PCT
set -u
qemu=$1 gdb=$2 elf=$3 budget=$4
here=$(cd "$(dirname "$0")" && pwd)
out=$(mktemp -d) || exit 2
trap 'rm -rf "$out"' EXIT
sh "$here/../../../tools/bench/m4-tick-trace.sh" "$qemu" "$gdb" "$elf" "$out" 2500 >"$out/report" 2>&1
rc=$?
sed -n '1,12p' "$out/report"
[ $rc -eq 0 ] || { echo "qemu-tick-cycles: FAIL: the trace failed"; sed -n '13,$p' "$out/report"; exit 1; }
insn=$(sed -n 's/^executed: \([0-9]*\) instructions.*/\1/p' "$out/report")
cyc=$(sed -n 's/^cycles: \([0-9]*\),.*/\1/p' "$out/report")
[ -n "$insn" ] && [ -n "$cyc" ] || { echo "qemu-tick-cycles: FAIL: no figures in the trace's report"; exit 1; }
awk -v i="$insn" -v c="$cyc" -v b="$budget" 'BEGIN {
	printf "qemu-tick-cycles: worst whole tick at 2500 Hz: %d instructions (%.1f %% of 67200), %d cycles by the model (%.1f %% of the period; budget %s %%)\n", i, i * 100 / 67200, c, c * 100 / 67200, b
	exit !(c * 100 / 67200 <= b + 0) }' ||
	{ echo "qemu-tick-cycles: FAIL: the worst tick's cycles are over the budget"; exit 1; }
echo "qemu-tick-cycles: PASS"
