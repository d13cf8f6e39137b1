#!/bin/sh
# qemu-arm.flash-gdb: QEMU netduinoplus2 starts with empty flash, halted at reset (-S) with its
# gdbserver on a free port; swell-flash flashes the ELF through the real gdb-multiarch, reads the
# flash back and compares it, resets and runs it, and reads USART1 (a file) until the image reports
# the version from its header. The test then checks, independently of swell-flash, that the serial
# output shows the image check passing with the header's version, length and CRC.
# The ELF goes through gdb's load, the BIN (FORMAT bin) through restore at 0x08000000.
# usage: qemu-gdb-flash.sh SWELL_FLASH QEMU IMAGE.elf IMAGE.bin [elf|bin]
set -u
flash=$1 qemu=$2 elf=$3 bin=$4 format=${5:-elf}
case $format in
elf) image=$elf ;;
bin) image=$bin ;;
*) echo "qemu-gdb-flash: format '$format' is not elf or bin"; exit 2 ;;
esac
dir=$(mktemp -d) || exit 2
qpid=""
cleanup() {
	[ -n "$qpid" ] && kill "$qpid" 2>/dev/null && wait "$qpid" 2>/dev/null
	rm -rf "$dir"
}
trap cleanup EXIT
fail() { echo "qemu-gdb-flash: FAIL: $*"; [ -f "$dir/serial" ] && sed 's/^/  serial: /' "$dir/serial" | head -20; exit 1; }

# The version the header carries, as swell-flash reads it (checked against the serial line below).
"$flash" "$image" --check-only >"$dir/check" 2>&1 || fail "image refused: $(cat "$dir/check")"
want=$(sed -n 's/.* version \([0-9.]*\), .*/\1/p' "$dir/check")
crc=$(sed -n 's/.* crc32 \(0x[0-9a-f]*\)$/\1/p' "$dir/check")
[ -n "$want" ] && [ -n "$crc" ] || fail "no version/crc in: $(cat "$dir/check")"

# A free port: QEMU is told the port and fails to start if it is taken; try a few.
port=""
for try in 1 2 3 4 5 6 7 8; do
	p=$((20000 + ($$ * 7 + try * 997) % 30000))
	: >"$dir/serial"
	"$qemu" -M netduinoplus2 -nographic -icount shift=0 -monitor none \
		-serial "file:$dir/serial" -S -gdb "tcp:127.0.0.1:$p" >"$dir/qemu.log" 2>&1 </dev/null &
	qpid=$!
	sleep 0.3
	if kill -0 "$qpid" 2>/dev/null; then port=$p; break; fi
	wait "$qpid" 2>/dev/null
	qpid=""
done
[ -n "$port" ] || fail "QEMU did not start with a gdbserver: $(cat "$dir/qemu.log")"
[ -s "$dir/serial" ] && fail "the empty machine printed before it was flashed"

"$flash" "$image" --backend gdb --gdb-server qemu --gdb-remote "127.0.0.1:$port" \
	--console "$dir/serial" --console-timeout 30 --work-dir "$dir" >"$dir/flash.out" 2>&1
rc=$?
sed 's/^/  /' "$dir/flash.out"
[ "$rc" -eq 0 ] || fail "swell-flash exited with $rc"
grep -q "verify ok: [0-9]* bytes read back at 0x08000000 equal the image" "$dir/flash.out" ||
	fail "no read-back verify reported"
grep -q "target runs version $want " "$dir/flash.out" || fail "swell-flash did not report version $want"
# Independent checks: what the flash holds equals the BIN, and the image's own boot check passed.
cmp "$dir/readback.bin" "$bin" || fail "read-back differs from $bin"
grep -q "^image: version $want, [0-9]* bytes, crc32 $crc ok" "$dir/serial" ||
	fail "the serial output does not show version $want crc32 $crc"
t=$(sed -n 's/.*flashed [0-9]* bytes in \([0-9.]*\) s/\1/p' "$dir/flash.out")
echo "qemu-gdb-flash: PASS: $format: version $want crc32 $crc flashed and verified in $t s through QEMU's gdbserver on port $port"
