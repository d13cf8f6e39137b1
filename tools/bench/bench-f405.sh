#!/bin/sh
# bench-f405.sh: one swell-bench run that also reports the STM32F405 image's instruction counts:
# boots the image's self-test under QEMU (netduinoplus2, -icount shift=0: one instruction a
# nanosecond), keeps its output, and gives it to swell-bench --f405.
# usage: bench-f405.sh QEMU IMAGE.elf SWELL-BENCH OUT-DIR [swell-bench options...]
set -u
[ $# -ge 4 ] || { echo "usage: bench-f405.sh QEMU IMAGE.elf SWELL-BENCH OUT-DIR [options...]" >&2; exit 2; }
qemu=$1 elf=$2 bench=$3 out=$4
shift 4
mkdir -p "$out" || exit 2
. "$(dirname "$0")/../../firmware/stm32f405/tests/qemu-run.sh"
qemu_run "$out/f405-selftest.txt" '^selftest: end' 120 "$qemu" "$elf" >/dev/null
grep -q '^selftest: end ok' "$out/f405-selftest.txt" ||
	{ echo "bench-f405: the image's self-test did not end ok (see $out/f405-selftest.txt)"; exit 1; }
exec "$bench" --out "$out" --f405 "$out/f405-selftest.txt" "$@"
