# Sourced by the qemu-arm test scripts.
# qemu_run OUT MARKER LIMIT_S QEMU IMAGE.elf [extra QEMU arguments...]
# Boots the image on netduinoplus2 with -icount shift=0, serial output (CR removed) into OUT, until a
# line matches MARKER (grep pattern), QEMU exits, or LIMIT_S seconds pass; then stops QEMU.
qemu_run() {
	_out=$1 _marker=$2 _limit=$3 _qemu=$4 _elf=$5
	shift 5
	"$_qemu" -M netduinoplus2 -nographic -icount shift=0 -monitor none -serial stdio \
		-kernel "$_elf" "$@" >"$_out.raw" 2>&1 </dev/null &
	_pid=$!
	_t=0
	while ! grep -q "$_marker" "$_out.raw"; do
		kill -0 "$_pid" 2>/dev/null || break
		if [ "$_t" -ge $((_limit * 10)) ]; then
			echo "qemu_run: no '$_marker' after $_limit s"
			break
		fi
		sleep 0.1
		_t=$((_t + 1))
	done
	kill "$_pid" 2>/dev/null
	wait "$_pid" 2>/dev/null
	tr -d '\r' <"$_out.raw" >"$_out"
	rm -f "$_out.raw"
	cat "$_out"
}
