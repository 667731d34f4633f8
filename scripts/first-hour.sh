#!/usr/bin/env bash
# A new user's first hour, timed on a fresh clone: install both binaries with the
# README's commands (one shared target directory), the first diagnosis (the README's
# main job with the installed pumptwin-edge), then the README's test command.
#
#   bash scripts/first-hour.sh [DIR]      # DIR: where to clone (default: a sibling
#                                          # of this checkout, so ../shared resolves)
#
# Crate downloads are not timed apart: on a machine whose cargo registry is empty
# they add to the first step.
set -euo pipefail
SRC="$(cd "$(dirname "$0")/.." && pwd)"
DIR="${1:-$SRC/../pumptwin-first-hour}"
rm -rf "$DIR"
git clone -q "$SRC" "$DIR"
cd "$DIR"
ROOT="$DIR/.cargo-root"
export PATH="$ROOT/bin:$PATH"
declare -a rows
timed() {
    local name="$1"
    shift
    local t0=$SECONDS
    "$@" >"/tmp/first-hour-$name.log" 2>&1
    rows+=("| $name | \`$*\` | $(( (SECONDS - t0) / 60 )) min $(( (SECONDS - t0) % 60 )) s |")
}
timed install-pumptwin cargo install --locked --path cli --target-dir target --root "$ROOT"
timed install-edge cargo install --locked --path edge-app --target-dir target --root "$ROOT"
timed first-diagnosis pumptwin-edge --replay models/demo.log --sensors models/cwru-sensors.toml \
    --model models/dsstgat-cwru-tb.ptm --out /tmp/first-hour-demo.jsonl
timed tests cargo test --workspace --release
echo "| step | command | wall time |"
echo "|---|---|---|"
printf '%s\n' "${rows[@]}"
echo "total: $(( SECONDS / 60 )) min $(( SECONDS % 60 )) s on $(nproc) cores ($(git rev-parse --short HEAD))"
