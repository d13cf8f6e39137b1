#!/bin/sh
# Boot the image under QEMU netduinoplus2 (-icount shift=0), wait for the self-test to end, and
# check its checksum against the host build of the same scene (and swell-sim when given).
# usage: qemu-selftest.sh QEMU IMAGE.elf SWELL-FW-SCENE [SWELL-SIM|-] [TIMEOUT_S]
set -u
qemu=$1 elf=$2 scene=$3 sim=${4:--} limit=${5:-120}
. "$(dirname "$0")/qemu-run.sh"
out=$(mktemp) || exit 2
trap 'rm -f "$out"' EXIT
qemu_run "$out" '^selftest: end' "$limit" "$qemu" "$elf"
grep -q '^selftest: end ok' "$out" || { echo "qemu-selftest: FAIL: self-test did not end ok"; exit 1; }
steps=$(sed -n 's/^steps \([0-9]*\).*/\1/p' "$out")
target=$(sed -n 's/^checksum \(0x[0-9a-f]*\).*/\1/p' "$out")
host=$("$scene" --steps "$steps" | sed -n 's/^checksum \(0x[0-9a-f]*\).*/\1/p')
echo "qemu-selftest: $steps steps: target checksum $target, host checksum $host"
[ -n "$target" ] && [ "$target" = "$host" ] || { echo "qemu-selftest: FAIL: checksums differ"; exit 1; }
# the scalar reference kernel on the host gives the same bits as the image's M4 kernel
ref=$("$scene" --steps "$steps" --kernel ref | sed -n 's/^checksum \(0x[0-9a-f]*\).*/\1/p')
echo "qemu-selftest: host scalar reference kernel checksum $ref"
[ "$target" = "$ref" ] || { echo "qemu-selftest: FAIL: the reference kernel differs"; exit 1; }
# the three cost scenes (damped: the M4's damped kernel), each against the host
costs=$(grep '^cost scene ' "$out" | sed -n 's/^cost scene \([a-z-]*\):.*checksum \(0x[0-9a-f]*\).*/\1 \2/p')
[ "$(echo "$costs" | grep -c .)" = 3 ] || { echo "qemu-selftest: FAIL: the image printed $(echo "$costs" | grep -c .) cost scenes, want 3"; exit 1; }
hcost=$("$scene" --steps 0 --cost --kernel ref | sed -n 's/^cost scene \([a-z-]*\) checksum \(0x[0-9a-f]*\).*/\1 \2/p')
echo "qemu-selftest: cost scenes, target: $(echo $costs); host (reference kernel): $(echo $hcost)"
[ "$costs" = "$hcost" ] || { echo "qemu-selftest: FAIL: cost scene checksums differ"; exit 1; }
# the M4 assembly kernel against the reference kernel on the image, on a field that clamps (the
# self-test fails on a difference; shown here)
grep '^velocity kernel check ' "$out" | sed 's/^/qemu-selftest: /'
# the solver's budget on the agitated pool (instructions per cell-step under -icount, exact; 8 bytes
# a cell, the heights' update and the fixers included; the measured figure: docs/benchmarks.md)
vel_budget=20
vel_ag=$(sed -n 's/^cost scene agitated: \([0-9.]*\) instructions.*/\1/p' "$out")
echo "qemu-selftest: agitated pool: $vel_ag instructions per cell-step (budget $vel_budget)"
awk -v v="$vel_ag" -v b="$vel_budget" 'BEGIN { exit !(v != "" && v + 0 <= b) }' ||
	{ echo "qemu-selftest: FAIL: the agitated cost $vel_ag is over its budget $vel_budget"; exit 1; }
ticks=$(sed -n 's/^core ticks \([0-9]*\).*/\1/p' "$out")
if [ -n "$ticks" ]; then
	tcore=$(sed -n 's/^core checksum \(0x[0-9a-f]*\).*/\1/p' "$out")
	hcore=$("$scene" --steps 0 --core "$ticks" | sed -n 's/^core checksum \(0x[0-9a-f]*\).*/\1/p')
	echo "qemu-selftest: core $ticks ticks: target checksum $tcore, host checksum $hcore"
	[ -n "$tcore" ] && [ "$tcore" = "$hcore" ] || { echo "qemu-selftest: FAIL: core checksums differ"; exit 1; }
fi
# the same core at 1000 Hz (classic CAN): its own schedule of the solver step, the same bits
ticks=$(sed -n 's/^core1000 ticks \([0-9]*\).*/\1/p' "$out")
if [ -n "$ticks" ]; then
	tcore=$(sed -n 's/^core1000 checksum \(0x[0-9a-f]*\).*/\1/p' "$out")
	hcore=$("$scene" --steps 0 --core "$ticks" --core-hz 1000 | sed -n 's/^core checksum \(0x[0-9a-f]*\).*/\1/p')
	echo "qemu-selftest: core at 1000 Hz, $ticks ticks: target checksum $tcore, host checksum $hcore"
	[ -n "$tcore" ] && [ "$tcore" = "$hcore" ] || { echo "qemu-selftest: FAIL: 1000 Hz core checksums differ"; exit 1; }
fi
# the larger pool chosen at start-up (PARAM_SET of pool.nx and pool.ny; 128 x 136 refused: it does
# not fit), 128 x 128 with u alone in the fast block: the same bits as the host's, at solver 250 Hz and
# tick 2500 Hz without an overrun (the self-test fails on one; checked here too)
pool=$(sed -n 's/^pool\([0-9]*\)x[0-9]* ticks \([0-9]*\).*/\1 \2/p' "$out")
[ -n "$pool" ] || { echo "qemu-selftest: FAIL: no run on a pool chosen at start-up"; exit 1; }
[ "${pool% *}" = 128 ] || { echo "qemu-selftest: FAIL: the pool chosen at start-up is ${pool% *}, want 128"; exit 1; }
grep -q '^pool: set pool.ny 136 in boot: NACK size out of range, pool still 128x64$' "$out" ||
	{ echo "qemu-selftest: FAIL: 128 x 136 was not refused as too big with nothing changed"; exit 1; }
grep -q '^pool128x128 at 2500 Hz: worst background [0-9].*; overruns 0$' "$out" ||
	{ echo "qemu-selftest: FAIL: the 128 x 128 pool overran its 2500 Hz tick"; exit 1; }
# and its worst whole tick at most 85 % of the period in instructions (the measured figure: docs/benchmarks.md)
pool_whole=$(sed -n 's/^pool128x128 at 2500 Hz: .*worst whole tick [0-9.]* (\([0-9.]*\) %).*/\1/p' "$out")
pool_budget_pct=85
awk -v w="$pool_whole" -v b="$pool_budget_pct" 'BEGIN { exit !(w != "" && w + 0 <= b) }' ||
	{ echo "qemu-selftest: FAIL: the 128 x 128 pool's worst whole tick $pool_whole % is over its budget of $pool_budget_pct %"; exit 1; }
{ grep '^memory: ' "$out"; grep '^pool: [0-9]' "$out" | tail -1; } | sed 's/^/qemu-selftest: /'
tpool=$(sed -n 's/^pool[0-9x]* checksum \(0x[0-9a-f]*\).*/\1/p' "$out")
hpool=$("$scene" --steps 0 --core "${pool#* }" --pool "${pool% *}" | sed -n 's/^core checksum \(0x[0-9a-f]*\).*/\1/p')
echo "qemu-selftest: pool ${pool% *} x ${pool% *}, ${pool#* } ticks: target checksum $tpool, host checksum $hpool"
[ -n "$tpool" ] && [ "$tpool" = "$hpool" ] || { echo "qemu-selftest: FAIL: the chosen pool's checksums differ"; exit 1; }
grep '^\(core\|pool\).* Hz: worst background [0-9]' "$out" | sed 's/^/qemu-selftest: /'
# the tick's budgets at 2500 Hz on the reference scene, in instructions under -icount (exact) and by
# the cycle model of docs/stm32f405.md (tools/bench/m4-cycles.py on a trace of the force path:
# 1.81 cycles an instruction; its solver kernels 1.27): the force path (device sample to FORCE_CMD,
# with the energy account's passivity controller acting: the self-test's core run turns it on and
# makes it act, firmware/stm32f405/logic/core_run.c) at most 3000 instructions; the worst whole tick at most 31 % of the period at one instruction a
# cycle (the aim of 35 % is reached; the measured figures and their cycles by the model are in
# docs/benchmarks.md, the model's check is qemu-arm.worst-tick-cycles-within-budget)
force_budget=3000 tick_budget_pct=31
line=$(grep '^core at 2500 Hz: worst background [0-9]' "$out")
force=$(echo "$line" | sed -n 's/.*worst force path \([0-9.]*\) .*/\1/p')
whole=$(echo "$line" | sed -n 's/.*worst whole tick [0-9.]* (\([0-9.]*\) %).*/\1/p')
if [ -n "$line" ]; then
	awk -v f="$force" -v w="$whole" 'BEGIN { printf "qemu-selftest: force path %s instructions, about %.0f cycles by the model (%.1f %% of 67200); worst whole tick %s %% of the period in instructions\n", f, f * 1.81, f * 1.81 * 100 / 67200, w }'
	awk -v f="$force" -v b="$force_budget" 'BEGIN { exit !(f != "" && f + 0 <= b) }' ||
		{ echo "qemu-selftest: FAIL: the force path's $force instructions are over its budget of $force_budget"; exit 1; }
	awk -v w="$whole" -v b="$tick_budget_pct" 'BEGIN { exit !(w != "" && w + 0 <= b) }' ||
		{ echo "qemu-selftest: FAIL: the worst whole tick's $whole % is over its budget of $tick_budget_pct %"; exit 1; }
fi
if [ "$sim" != "-" ] && [ -x "$sim" ]; then
	ref=$("$sim" --grid 64x64 --dt 0.004 --depth 0.05 --dx 0.00625 --init gauss:32,32,3,2 \
		--steps "$steps" | sed -n 's/^checksum *\(0x[0-9a-f]*\).*/\1/p')
	echo "qemu-selftest: swell-sim checksum $ref"
	[ "$target" = "$ref" ] || { echo "qemu-selftest: FAIL: swell-sim differs"; exit 1; }
fi
echo "qemu-selftest: PASS (bit-identical)"
