#!/bin/busybox sh
# dfu-flash-vm.sh: runs inside the HIL VM (run-vm --usb none; see dfu-flash). swell-flash flashes the
# emulated STM32F405 DFU bootloader (swell-vm-dfuse, vm-dfu-gadget) with the real dfu-util, and this
# script checks, independently of swell-flash, what the target stored.
# Usage: sh dfu-flash-vm.sh BIN ELF RUNS
#   1. a corrupted BIN is refused by swell-flash (exit 2) before dfu-util runs: the target logs no
#      DFU request and its flash stays erased;
#   1b. the target itself refuses an address outside its flash with the DFU error status: dfu-util
#      (set address 0x08100000, forced past its own layout check) fails on dfuERROR/errADDRESS, the
#      flash stays erased, and the next dfu-util clears the status and reads from 0x08000000;
#   2. RUNS times the BIN (--backend dfu), then once the ELF (no --backend: swell-flash must find
#      the DfuSe device on the VM's USB bus itself), each on a fresh erased target: swell-flash
#      exits 0 with "verify ok", the target leaves DFU (0483:df11 gone, start at 0x08000000), its
#      flash file equals the BIN byte for byte over the BIN's length and is 0xFF after it;
#   3. a target with a bad flash cell (swell-vm-dfuse --bad-cell): swell-flash's read-back verify
#      fails (exit 1, "verify FAILED at" the cell) and the leave request is never sent.
# Prints one "figure:" line per run (step times from swell-flash, bytes/s) and "dfu-flash: N failed".
bin=$1 elf=$2 runs=${3:-1}
flash=/tmp/dfu-flash.bin log=/tmp/dfuse.log
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
len=$(wc -c <"$bin")
erased_after() { # erased_after FILE OFFSET: number of bytes after OFFSET that are not 0xFF
	tail -c +$(($2 + 1)) "$1" | tr -d '\377' | wc -c
}
target_up() { # target_up [swell-vm-dfuse options]
	rm -f "$flash" "$log"
	vm-dfu-gadget up --flash "$flash" --log "$log" "$@" || { fail "the DFU target did not come up"; return 1; }
}
show_log() { echo "--- target log (last 15 lines):"; tail -n 15 "$log"; echo "---"; }

# 1. A corrupted image: one byte flipped after the header, so only the CRC-32 tells.
target_up || exit 1
cp "$bin" /tmp/bad.bin
b=$(dd if="$bin" bs=1 skip=1024 count=1 2>/dev/null | od -An -tu1 | tr -d ' ')
printf "\\$(printf %o $((b ^ 0x5A)))" | dd of=/tmp/bad.bin bs=1 seek=1024 conv=notrunc 2>/dev/null
cmp -s "$bin" /tmp/bad.bin && fail "could not corrupt the copy"
swell-flash /tmp/bad.bin --backend dfu >/tmp/out 2>&1
rc=$?
cat /tmp/out
[ $rc -eq 2 ] || fail "corrupted image: swell-flash exit $rc, expected 2"
grep -q 'corrupted' /tmp/out || fail "corrupted image: no 'corrupted' reason"
n=$(grep -c '^dfu ' "$log")
[ "$n" -eq 0 ] || { fail "corrupted image: the target saw $n DFU requests, expected none"; show_log; }
[ "$(erased_after "$flash" 0)" -eq 0 ] || fail "corrupted image: the flash is no longer erased"
echo "check: corrupted image refused by swell-flash (exit $rc), target saw $n DFU requests, flash erased"

# 1b. The target's own refusal, through the real dfu-util and USB.
dfu-util -d 0483:df11 -a 0 -s 0x08100000:force:16 -U /tmp/oob.bin >/tmp/out 2>&1
rc=$?
grep -E '^dfu-util: ' /tmp/out
[ $rc -ne 0 ] || fail "address outside flash: dfu-util exit 0"
grep -q 'set address 0x08100000 refused: outside flash' "$log" || fail "address outside flash: not refused by the target"
grep -q 'dfuERROR errADDRESS' "$log" || { fail "address outside flash: no dfuERROR errADDRESS"; show_log; }
dfu-util -d 0483:df11 -a 0 -s 0x08000000:16 -U /tmp/ok.bin >/tmp/out 2>&1 ||
	{ fail "after the refusal: dfu-util could not read 0x08000000"; cat /tmp/out; }
grep -q 'CLRSTATUS .* dfuIDLE OK: status cleared' "$log" || fail "after the refusal: no CLRSTATUS back to dfuIDLE"
[ "$(erased_after "$flash" 0)" -eq 0 ] || fail "address outside flash: the flash is no longer erased"
echo "check: set address 0x08100000 refused by the target (dfu-util exit $rc, dfuERROR errADDRESS), status cleared by the next dfu-util"
vm-dfu-gadget down || fail "vm-dfu-gadget down"

# 2. Real flashing: the BIN RUNS times, then the ELF.
i=0
for img in $(seq 1 "$runs" | sed "s|.*|$bin|") "$elf"; do
	i=$((i + 1))
	kind=BIN backend="--backend dfu"
	case "$img" in *.elf) kind=ELF backend="" ;; esac
	target_up || break
	swell-flash "$img" $backend >/tmp/out 2>&1
	rc=$?
	cat /tmp/out
	if [ -z "$backend" ]; then
		grep -q 'auto-detected a DfuSe bootloader (USB 0483:df11): backend dfu' /tmp/out ||
			fail "run $i ($kind): swell-flash did not auto-detect the DfuSe device"
	fi
	if [ $rc -ne 0 ]; then
		fail "run $i ($kind): swell-flash exit $rc"; show_log; vm-dfu-gadget down; continue
	fi
	grep -q "verify ok: $len bytes" /tmp/out || fail "run $i ($kind): no 'verify ok: $len bytes' from swell-flash"
	vm-dfu-gadget wait-gone 10 || fail "run $i ($kind): the target did not leave DFU"
	grep -q 'left DFU: disconnected, the image starts at 0x08000000' "$log" ||
		{ fail "run $i ($kind): the target log has no leave to 0x08000000"; show_log; }
	# Independent of swell-flash: what the target stored.
	if cmp -n "$len" "$bin" "$flash" >/tmp/cmp 2>&1; then
		echo "check: run $i ($kind): flash file equals swell-fw.bin over $len bytes"
	else
		fail "run $i ($kind): flash file differs from swell-fw.bin: $(cat /tmp/cmp)"
	fi
	nff=$(erased_after "$flash" "$len")
	[ "$nff" -eq 0 ] || fail "run $i ($kind): $nff bytes after the image are not erased (0xFF)"
	refused=$(sed -n 's/.* \([0-9]*\) refused$/\1/p' "$log")
	[ "$refused" = 0 ] || fail "run $i ($kind): the target refused $refused requests"
	grep 'summary:' "$log" | sed "s/^usb *[0-9.]* /target: run $i ($kind): /"
	awk -v run="$i" -v kind="$kind" -v len="$len" '
		/\[1\/3\] done in/ { w = $(NF-1) } /\[2\/3\] done in/ { r = $(NF-1) } /\[3\/3\] done in/ { l = $(NF-1) }
		/verify ok/ { v = "ok" } /flashed .* bytes in/ { t = $(NF-1) }
		END { printf "figure: run %d %s: %d bytes, download %.3f s (%.0f B/s), upload %.3f s (%.0f B/s), leave %.3f s, total %.3f s, verify %s\n",
		      run, kind, len, w, len / w, r, len / r, l, t, v }' /tmp/out
	vm-dfu-gadget down || fail "vm-dfu-gadget down"
done
# 3. A bad flash cell: the verify must catch it and the image must not be started.
if target_up --bad-cell 0x08000400; then
	swell-flash "$bin" --backend dfu >/tmp/out 2>&1
	rc=$?
	grep -vE '^(Erase|Download|Upload)' /tmp/out | grep -E '^swell-flash'
	[ $rc -eq 1 ] || fail "bad cell: swell-flash exit $rc, expected 1"
	grep -q 'verify FAILED at 0x08000400' /tmp/out || fail "bad cell: no 'verify FAILED at 0x08000400'"
	grep -q 'fault: bad cell 0x08000400' "$log" || fail "bad cell: the target never wrote the cell"
	n=$(grep -c 'leave request' "$log")
	[ "$n" -eq 0 ] || fail "bad cell: the target got $n leave requests after a failed verify"
	echo "check: bad cell at 0x08000400: swell-flash exit $rc, verify failed there, $n leave requests"
	vm-dfu-gadget down || fail "vm-dfu-gadget down"
fi
echo "dfu-flash: $fails failed"
[ $fails -eq 0 ]
