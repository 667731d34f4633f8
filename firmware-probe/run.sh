#!/usr/bin/env bash
# Build the firmware probe for thumbv7em-none-eabihf, print its section sizes, run it
# under QEMU (mps2-an386, Cortex-M4F) with semihosting, and exit non-zero unless the
# int8 logits equal the golden codes. Extra cargo arguments are passed on, e.g.
#   ./run.sh --features net-on-stack
#   OPT_LEVEL=z ./run.sh
set -euo pipefail
cd "$(dirname "$0")"

if ! command -v qemu-system-arm >/dev/null || ! command -v arm-none-eabi-size >/dev/null; then
    echo "installing qemu-system-arm and binutils-arm-none-eabi" >&2
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-system-arm binutils-arm-none-eabi >&2
fi
rustup target list --installed 2>/dev/null | grep -qx thumbv7em-none-eabihf \
    || rustup target add thumbv7em-none-eabihf

# Own target dir (not the workspace's), low priority, one job: another build may run.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$(pwd)/../target/fw-probe}"
if [ -n "${OPT_LEVEL:-}" ]; then export CARGO_PROFILE_RELEASE_OPT_LEVEL="$OPT_LEVEL"; fi
nice -n 10 cargo build --release -j1 "$@"
ELF="$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/pumptwin-firmware-probe"
echo "opt-level: ${CARGO_PROFILE_RELEASE_OPT_LEVEL:-s (Cargo.toml)}; lto = true, codegen-units = 1, panic = abort"

arm-none-eabi-size -A "$ELF" | grep -vE '^\.(debug|comment|ARM)'
read -r text data bss _ < <(arm-none-eabi-size "$ELF" | tail -1)

out=$(mktemp); trap 'rm -f "$out"' EXIT
status=0
timeout 120 qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
    -semihosting-config enable=on,target=native -kernel "$ELF" | tee "$out" || status=$?

peak=$(sed -n 's/^STACK .* max=\([0-9]*\).*/\1/p' "$out")
echo
echo "text $text  data $data  bss $bss"
echo "flash = text + data = $((text + data)) B ($(( (text + data + 1023) / 1024 )) KiB; target 128 KiB)"
echo "static RAM = data + bss = $((data + bss)) B"
if [ -n "$peak" ]; then
    echo "peak stack (max of phases) = $peak B"
    echo "RAM total = static + peak stack = $((data + bss + peak)) B ($(( (data + bss + peak + 1023) / 1024 )) KiB; target 32 KiB)"
fi
if [ "$status" -ne 0 ] || ! grep -q '^PASS' "$out"; then
    echo "FAIL (qemu exit status $status)" >&2
    exit 1
fi
