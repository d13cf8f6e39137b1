#!/bin/sh
# Boot the image under QEMU netduinoplus2 (-icount shift=0), wait for the self-test to end, and
# check its checksum against the host build of the same scene (and swell-sim when given).
# usage: qemu-selftest.sh QEMU IMAGE.elf SWELL-FW-SCENE [SWELL-SIM|-] [TIMEOUT_S]
set -u
qemu=$1 elf=$2 scene=$3 sim=${4:--} limit=${5:-120}
out=$(mktemp) || exit 2
trap 'rm -f "$out"' EXIT
"$qemu" -M netduinoplus2 -nographic -icount shift=0 -monitor none -serial stdio -kernel "$elf" \
	>"$out" 2>&1 </dev/null &
pid=$!
t=0
while ! grep -q '^selftest: end' "$out"; do
	if ! kill -0 "$pid" 2>/dev/null; then break; fi
	if [ "$t" -ge $((limit * 10)) ]; then echo "qemu-selftest: no end of self-test after ${limit} s"; break; fi
	sleep 0.1
	t=$((t + 1))
done
kill "$pid" 2>/dev/null
wait "$pid" 2>/dev/null
tr -d '\r' <"$out"
grep -q '^selftest: end ok' "$out" || { echo "qemu-selftest: FAIL: self-test did not end ok"; exit 1; }
steps=$(sed -n 's/^steps \([0-9]*\).*/\1/p' "$out" | tr -d '\r')
target=$(sed -n 's/^checksum \(0x[0-9a-f]*\).*/\1/p' "$out" | tr -d '\r')
host=$("$scene" --steps "$steps" | sed -n 's/^checksum \(0x[0-9a-f]*\).*/\1/p')
echo "qemu-selftest: $steps steps: target checksum $target, host checksum $host"
[ -n "$target" ] && [ "$target" = "$host" ] || { echo "qemu-selftest: FAIL: checksums differ"; exit 1; }
ticks=$(sed -n 's/^core ticks \([0-9]*\).*/\1/p' "$out" | tr -d '\r')
if [ -n "$ticks" ]; then
	tcore=$(sed -n 's/^core checksum \(0x[0-9a-f]*\).*/\1/p' "$out" | tr -d '\r')
	hcore=$("$scene" --steps 0 --core "$ticks" | sed -n 's/^core checksum \(0x[0-9a-f]*\).*/\1/p')
	echo "qemu-selftest: core $ticks ticks: target checksum $tcore, host checksum $hcore"
	[ -n "$tcore" ] && [ "$tcore" = "$hcore" ] || { echo "qemu-selftest: FAIL: core checksums differ"; exit 1; }
fi
if [ "$sim" != "-" ] && [ -x "$sim" ]; then
	ref=$("$sim" --grid 64x64 --dt 0.004 --depth 0.05 --dx 0.00625 --init gauss:32,32,3,2 \
		--steps "$steps" | sed -n 's/^checksum *\(0x[0-9a-f]*\).*/\1/p')
	echo "qemu-selftest: swell-sim checksum $ref"
	[ "$target" = "$ref" ] || { echo "qemu-selftest: FAIL: swell-sim differs"; exit 1; }
fi
echo "qemu-selftest: PASS (bit-identical)"
