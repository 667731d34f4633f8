#!/usr/bin/env bash
# Cross-build pumptwin-edge for 64-bit ARM gateways (aarch64-unknown-linux-gnu) and
# 32-bit ARMv7 (armv7-unknown-linux-gnueabihf) with Debian's cross linkers, run each
# under qemu-user on the demo log with the shipped model, and require JSON output equal
# to the native build's. Prints binary size and peak RSS per target (writes
# out/arm-edge.md).
set -euo pipefail
cd "$(dirname "$0")/.."
need=""
command -v aarch64-linux-gnu-gcc >/dev/null || need="$need gcc-aarch64-linux-gnu"
command -v arm-linux-gnueabihf-gcc >/dev/null || need="$need gcc-arm-linux-gnueabihf"
command -v qemu-aarch64 >/dev/null || need="$need qemu-user"
if [ -n "$need" ]; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $need
fi
rustup target add aarch64-unknown-linux-gnu armv7-unknown-linux-gnueabihf >/dev/null
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
export CARGO_TARGET_ARMV7_UNKNOWN_LINUX_GNUEABIHF_LINKER=arm-linux-gnueabihf-gcc
args=(--replay models/demo.log --sensors models/cwru-sensors.toml --model models/dsstgat-cwru-tb.ptm)
mkdir -p out target/arm-edge
cargo build --release -p pumptwin-edge
/usr/bin/time -f "%M" -o target/arm-edge/native.rss target/release/pumptwin-edge "${args[@]}" \
    > target/arm-edge/native.jsonl 2>/dev/null
stripped() { "$1" -o target/arm-edge/stripped "$2" && stat -c %s target/arm-edge/stripped; }
rows=("| native x86_64 | $(stripped strip target/release/pumptwin-edge) | $(cat target/arm-edge/native.rss) | reference |")
for t in aarch64-unknown-linux-gnu:aarch64:/usr/aarch64-linux-gnu armv7-unknown-linux-gnueabihf:arm:/usr/arm-linux-gnueabihf; do
    IFS=: read -r triple qemu sysroot <<< "$t"
    prefix=$(basename "$sysroot")
    cargo build --release -p pumptwin-edge --target "$triple"
    bin="target/$triple/release/pumptwin-edge"
    /usr/bin/time -f "%M" -o "target/arm-edge/$triple.rss" "qemu-$qemu" -L "$sysroot" "$bin" "${args[@]}" \
        > "target/arm-edge/$triple.jsonl" 2>/dev/null
    # Equal output, line for line, but for the timestamps the gateway measures itself
    # (none are in the JSON: t_s comes from the log).
    if cmp -s target/arm-edge/native.jsonl "target/arm-edge/$triple.jsonl"; then
        verdict="identical ($(wc -l < target/arm-edge/native.jsonl) lines)"
    else
        diff <(head -c 2000 target/arm-edge/native.jsonl) <(head -c 2000 "target/arm-edge/$triple.jsonl") | head -20
        echo "$triple: output differs from the native build" >&2
        exit 1
    fi
    rows+=("| $triple (qemu-$qemu) | $(stripped "$prefix-strip" "$bin") | $(cat "target/arm-edge/$triple.rss") | $verdict |")
done
{
    echo "| build | binary bytes (release, stripped) | peak RSS KiB (demo log; ARM figures include qemu-user itself) | JSON vs native |"
    echo "|---|---|---|---|"
    printf '%s\n' "${rows[@]}"
} | tee out/arm-edge.md
