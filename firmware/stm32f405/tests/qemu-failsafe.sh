#!/bin/sh
# Fail-safe behaviour of the image under QEMU netduinoplus2:
#   fault  - boot-mode word set by QEMU's loader: the image commands a force, then executes an
#            undefined instruction; the fault handler must zero the force and report.
#   crc    - a copy of the image with one header byte flipped: the boot check must refuse to run.
# usage: qemu-failsafe.sh fault|crc QEMU IMAGE.elf OBJCOPY [TIMEOUT_S]
set -u
. "$(dirname "$0")/qemu-run.sh"
what=$1 qemu=$2 elf=$3 objcopy=$4 limit=${5:-60}
dir=$(mktemp -d) || exit 2
trap 'rm -rf "$dir"' EXIT
extra=""
img=$elf
case $what in
fault)
	extra="-device loader,addr=0x2001fff0,data=0x544c4146,data-len=4"
	marker='waiting for the watchdog'
	;;
crc)
	img=$dir/bad.elf
	"$objcopy" -O binary --only-section=.image_header "$elf" "$dir/hdr.bin" || exit 2
	# Byte 12 is the low byte of the version field, covered by both CRCs: flip its bits.
	b=$(od -An -tu1 -j12 -N1 "$dir/hdr.bin" | tr -d ' ')
	printf "$(printf '\\%03o' $((b ^ 255)))" |
		dd of="$dir/hdr.bin" bs=1 seek=12 count=1 conv=notrunc 2>/dev/null
	"$objcopy" --update-section .image_header="$dir/hdr.bin" "$elf" "$img" || exit 2
	marker='waiting for the watchdog'
	;;
*) echo "qemu-failsafe: unknown case '$what' (fault or crc)"; exit 2 ;;
esac
# shellcheck disable=SC2086
qemu_run "$dir/out" "$marker" "$limit" "$qemu" "$img" $extra
case $what in
fault)
	grep -q '^FAULT: exception 6 ' "$dir/out" || { echo "qemu-failsafe: FAIL: no usage fault report"; exit 1; }
	grep -q '^FAULT: force now 0 0 0 cN' "$dir/out" || { echo "qemu-failsafe: FAIL: force not zeroed"; exit 1; }
	;;
crc)
	grep -q '^image: REFUSED' "$dir/out" || { echo "qemu-failsafe: FAIL: corrupted image not refused"; exit 1; }
	if grep -q '^selftest:' "$dir/out"; then echo "qemu-failsafe: FAIL: ran after refusing"; exit 1; fi
	;;
esac
echo "qemu-failsafe: $what: PASS"
