#!/usr/bin/env bash
# How much the DS-STGAT figures move with the seed alone.
#
#   bash scripts/seed-spread.sh ["SEEDS"] ["PROTOCOLS"] ["ABLATIONS"] [NODES]
#   default: seeds "42 7 1", protocols "time-block cross-load", every ablation,
#   nodes "measured" ("derived": with the derived temperature/pressure nodes)
#
# Trains each (ablation, protocol, seed) into out/seeds/ (a run whose metrics.json
# exists is reused) and prints one line per (ablation, protocol): clean accuracy,
# 0 dB and −4 dB accuracy as mean [min, max] over the seeds.
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-"42 7 1"}
protocols=${2:-"time-block cross-load"}
ablations=${3:-"none no-coadapt no-physics static-graph"}
nodes=${4:-measured}
data=${DATA:-../shared/data/cwru}
suffix=""
[ "$nodes" = measured ] || suffix="+$nodes-nodes"
cargo build --release -q -p pumptwin --bin pumptwin
mkdir -p out/seeds
for a in $ablations; do
  for p in $protocols; do
    for s in $seeds; do
      dir=out/seeds/$a$suffix-$p-$s
      [ -f "$dir/metrics.json" ] && continue
      mkdir -p "$dir"
      ./target/release/pumptwin train --data "$data" --protocol "$p" --ablation "$a" --nodes "$nodes" --seed "$s" --out "$dir" >"$dir/train.log" 2>&1
    done
    python3 - "$a$suffix" "$p" $seeds <<'PY'
import json, sys
a, p, seeds = sys.argv[1], sys.argv[2], sys.argv[3:]
rows = []
for s in seeds:
    m = json.load(open(f"out/seeds/{a}-{p}-{s}/metrics.json"))
    noise = {n["snr_db"]: n["accuracy"] for n in m["noise"]}
    rows.append((m["accuracy"], noise[0.0], noise[-4.0]))
def f(k):
    v = [100 * r[k] for r in rows]
    return f"{sum(v) / len(v):6.2f} [{min(v):6.2f}, {max(v):6.2f}]"
print(f"| {a} | {p} | {len(rows)} | {f(0)} | {f(1)} | {f(2)} |")
PY
  done
done | tee "out/seeds/summary$suffix.md"
