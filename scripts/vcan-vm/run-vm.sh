#!/usr/bin/env bash
# run-vm.sh PAYLOAD_DIR [TIMEOUT_S]
#
# Builds an initramfs with PAYLOAD_DIR as /payload (build-initramfs.sh), boots
# the cached Debian kernel under QEMU (TCG by default), where /init loads the
# CAN modules, raises vcan0 and runs /payload/run. Prints the whole serial
# console to stdout and exits with /payload/run's exit status, taken from the
# `PUMPTWIN-VM-EXIT <code>` line; 1 if that line is missing (crash, timeout).
#
# TIMEOUT_S (default 300) bounds the whole QEMU run.
#
# Environment:
#   VCAN_VM_ACCEL   QEMU accelerator (default: tcg; "kvm" works where /dev/kvm does)
#   VCAN_VM_MEM     guest memory in MiB (default: 512)
#   VCAN_VM_SMP     guest CPUs (default: 1)
#   VCAN_VM_LOG     also keep the console log in this file
#   VCAN_VM_APPEND  extra kernel command line
#   plus those of build-initramfs.sh (VCAN_VM_CACHE, VCAN_VM_MODULES, ...)
set -uo pipefail

die() { echo "run-vm.sh: $*" >&2; exit 1; }
[ $# -ge 1 ] && [ $# -le 2 ] || die "usage: run-vm.sh PAYLOAD_DIR [TIMEOUT_S]"
PAYLOAD=$1
TIMEOUT=${2:-300}
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
CACHE=${VCAN_VM_CACHE:-$REPO/target/vcan-vm}
mkdir -p "$CACHE"

WORK=$(mktemp -d "$CACHE/run.XXXXXX") || die "mktemp failed"
trap 'rm -rf "$WORK"' EXIT

KERNEL=$("$HERE/build-initramfs.sh" "$WORK/initramfs.cpio.gz" "$PAYLOAD" | tail -n1) \
    || die "build-initramfs.sh failed"
[ -f "$KERNEL" ] || die "no kernel at '$KERNEL'"

start=$(date +%s.%N)
timeout -k 5 "$TIMEOUT" qemu-system-x86_64 \
    -accel "${VCAN_VM_ACCEL:-tcg}" \
    -m "${VCAN_VM_MEM:-512}" \
    -smp "${VCAN_VM_SMP:-1}" \
    -nographic -no-reboot \
    -nic none \
    -kernel "$KERNEL" \
    -initrd "$WORK/initramfs.cpio.gz" \
    -append "console=ttyS0 panic=-1 quiet ${VCAN_VM_APPEND:-}" \
    < /dev/null 2>&1 \
    | sed -u -e 's/\x1bc//g' -e 's/\x1b\[[0-9;?]*[A-Za-z]//g' -e 's/\r$//' \
    | tee "$WORK/console.log"
qrc=${PIPESTATUS[0]}
end=$(date +%s.%N)
[ -n "${VCAN_VM_LOG:-}" ] && cp "$WORK/console.log" "$VCAN_VM_LOG"

elapsed=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
code=$(tr -d '\r' < "$WORK/console.log" | sed -n 's/^PUMPTWIN-VM-EXIT \([0-9][0-9]*\)$/\1/p' | tail -n1)
if [ -z "$code" ]; then
    if [ "$qrc" = 124 ] || [ "$qrc" = 137 ]; then
        echo "run-vm.sh: timed out after ${TIMEOUT}s (no PUMPTWIN-VM-EXIT marker)" >&2
    else
        echo "run-vm.sh: qemu exited with $qrc and no PUMPTWIN-VM-EXIT marker" >&2
    fi
    exit 1
fi
echo "run-vm.sh: payload exited with $code; VM wall time ${elapsed}s (accel ${VCAN_VM_ACCEL:-tcg})" >&2
exit "$code"
