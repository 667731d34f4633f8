#!/usr/bin/env bash
# The figures BENCHMARKS.md keeps, measured on two trees one after the other on the
# same machine: RK4 steps/s and features per window (core_bench), int8 and burn
# instructions per window (callgrind), the firmware probe's flash and RAM, and the
# edge's ingest over 10 minutes of bus.
#
#   bash scripts/bench-before-after.sh BEFORE_TREE [AFTER_TREE]   # AFTER_TREE: this one
#
# BEFORE_TREE is a checkout of the commit to compare with (e.g. `git worktree add
# /tmp/before <commit>`). Each tree builds into its own target/ (their workspace crates
# differ). Writes out/before-after/<tree>/… and prints both tables.
set -euo pipefail
after="${2:-$(cd "$(dirname "$0")/.." && pwd)}"
before="$(cd "$1" && pwd)"
for tree in "$before" "$after"; do
    name=$(basename "$tree")
    out="$after/out/before-after/$name"
    mkdir -p "$out"
    echo "==> $tree" >&2
    (cd "$tree" && cargo bench -q -p pumptwin-core --bench core_bench 2>/dev/null) >"$out/core_bench.md"
    (cd "$tree" && bash benches/inference_cost.sh >/dev/null 2>&1 && cp out/inference_cost.md "$out/")
    (cd "$tree" && FW_PROBE_RAM_KIB=32 bash firmware-probe/run.sh 2>&1 | tail -8) >"$out/firmware.txt"
    (cd "$tree" && bash benches/edge_ingest.sh >/dev/null 2>&1 && cp out/edge_ingest.md "$out/")
done
for tree in "$before" "$after"; do
    name=$(basename "$tree")
    echo "## $name ($(git -C "$tree" rev-parse --short HEAD))"
    cat "$after/out/before-after/$name"/{core_bench.md,inference_cost.md,firmware.txt,edge_ingest.md}
done
