#!/usr/bin/env bash
# No reachable panic in the core's inference entry points (see src/main.rs):
#   bash tests/nopanic-probe/run.sh            # the proof at opt-level s, 2, 3 and z + its negative control
#   bash tests/nopanic-probe/run.sh --report   # list the remaining panic call sites instead
# Each build links a bare-metal binary whose panic handler calls an undefined symbol:
# it links only if no panic survives optimisation on a path from `_start`.
set -euo pipefail
cd "$(dirname "$0")"
rustup target list --installed 2>/dev/null | grep -qx thumbv7em-none-eabihf \
    || rustup target add thumbv7em-none-eabihf
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$(pwd)/../../target/nopanic-probe}"
TARGET=thumbv7em-none-eabihf
LEVELS="${NOPANIC_OPT_LEVELS:-s 2 3 z}"

report() {
    local level=$1
    if ! command -v arm-none-eabi-objdump >/dev/null; then
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq binutils-arm-none-eabi >&2
    fi
    CARGO_PROFILE_RELEASE_OPT_LEVEL="$level" CARGO_PROFILE_RELEASE_DEBUG=line-tables-only \
        CARGO_PROFILE_RELEASE_STRIP=none CARGO_TARGET_DIR="$CARGO_TARGET_DIR/report" \
        nice -n 10 cargo build --release --target "$TARGET" --features report -q
    python3 panic_paths.py arm-none-eabi-objdump \
        "$CARGO_TARGET_DIR/report/$TARGET/release/pumptwin-nopanic-probe"
}

if [ "${1:-}" = "--report" ]; then
    for level in $LEVELS; do echo "== opt-level $level"; report "$level"; done
    exit 0
fi

status=0
for level in $LEVELS; do
    log=$(mktemp)
    if CARGO_PROFILE_RELEASE_OPT_LEVEL="$level" nice -n 10 \
        cargo build --release --target "$TARGET" >"$log" 2>&1; then
        echo "opt-level $level: linked, no reachable panic"
    else
        if grep -q "undefined symbol: pumptwin_core_panic_is_reachable" "$log"; then
            echo "opt-level $level: a panic is reachable; its call sites:" >&2
            report "$level" >&2
        else
            cat "$log" >&2
        fi
        status=1
    fi
    rm -f "$log"
done

# Negative control: a reachable panic must fail the link, with the proof's symbol.
log=$(mktemp)
if CARGO_PROFILE_RELEASE_OPT_LEVEL=s cargo build --release --target "$TARGET" \
    --features _panic_canary >"$log" 2>&1; then
    echo "the panic canary linked: the proof cannot catch a reachable panic" >&2
    status=1
elif grep -q "undefined symbol: pumptwin_core_panic_is_reachable" "$log"; then
    echo "canary rejected as expected: undefined symbol pumptwin_core_panic_is_reachable"
else
    cat "$log" >&2
    status=1
fi
rm -f "$log"
exit "$status"
