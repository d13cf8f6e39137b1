#!/bin/sh
# The enter-bootloader path of the image under QEMU netduinoplus2, as far as it goes without a ROM
# bootloader (QEMU maps nothing at 0x1FFF0000). Boot-mode word "BOOT" (QEMU's loader writes it at
# every reset): the core refuses ENTER_BOOTLOADER while RUNNING with a force on the object, accepts it
# in ARMED with the force zero; the image prints its line, leaves the magic word and resets; at the
# start of the next reset the magic is seen and the ROM's vector table read at 0x1FFF0000, which
# bus-faults here (BFAR must be 0x1FFF0000); the image boots again and says so.
# usage: qemu-bootloader.sh QEMU IMAGE.elf [TIMEOUT_S]
set -u
. "$(dirname "$0")/qemu-run.sh"
qemu=$1 elf=$2 limit=${3:-60}
out=$(mktemp) || exit 2
trap 'rm -f "$out"' EXIT
qemu_run "$out" '^boot test: end' "$limit" "$qemu" "$elf" -device loader,addr=0x2001fff0,data=0x544f4f42,data-len=4
fail() { echo "qemu-bootloader: FAIL: $*"; exit 1; }
# each step on its own line, in this order (the banner: the second boot)
n=0
for pat in \
	'^boot test: ENTER_BOOTLOADER in running (force z -\{0,1\}[1-9][0-9]* uN): refused$' \
	'^boot test: ENTER_BOOTLOADER in armed: accepted, force now 0 0 0 uN$' \
	'^boot: ENTER_BOOTLOADER accepted, force zeroed: resetting into the ROM bootloader at 0x1fff0000$' \
	'^swell-fw stm32f405 ' \
	'^boot: bootloader requested before this reset; the ROM table at 0x1fff0000 bus-faulted when read (bfar 0x1fff0000, ' \
	'^boot test: end, back in this image$'; do
	line=$(grep -n "$pat" "$out" | cut -d: -f1 | awk -v n="$n" '$1 > n { print; exit }')
	[ -n "$line" ] || fail "no line after line $n matching: $pat"
	n=$line
done
# CTL_INFO carries the version of the image header the boot check printed
hdr=$(sed -n 's/^image: version \([0-9]*\.[0-9]*\.[0-9]*\),.*/\1/p' "$out" | head -1)
info=$(sed -n 's/^boot test: CTL_INFO at the first tick: \(.*\)$/\1/p' "$out")
echo "qemu-bootloader: header version $hdr, CTL_INFO version $info"
[ -n "$hdr" ] && [ "$info" = "$hdr" ] || fail "CTL_INFO version '$info' is not the header's '$hdr'"
[ "$(grep -c '^swell-fw stm32f405 ' "$out")" -eq 2 ] || fail "expected exactly two boots (one reset)"
if grep -q '^selftest:' "$out"; then fail "the self-test ran in boot-mode BOOT"; fi
echo "qemu-bootloader: PASS (CTL_INFO has the header's version, refused in RUNNING, accepted in ARMED with zero force, reset, magic seen, ROM table read at 0x1fff0000, image back)"
