#!/usr/bin/env bash
# How the DS-STGAT's three parts are weighed, studied on what each says about every
# test window: the network (W_o Z + b_o), the sensor head's spectral expert (band
# shares) and its kinematic expert (envelope lines), `logits = network + γ·spectral +
# γ_k·kinematic` (trainer/src/model.rs). The parts train on cross-entropies of their
# own, so the weights act only at inference: one training per protocol and seed serves
# every weighting.
#
#   bash scripts/expert-fusion.sh [DATA_DIR]
#
# Trains (where missing) the DS-STGAT on the development protocols (seeds 42 7 1 3) and
# on `fault-size` (seeds 42 7 1) under out/expert-fusion/, writes each test side's parts
# with `pumptwin eval --experts`, and runs scripts/expert_fusion.py on them (numpy from
# .venv-probe, made by scripts/linear-probe.sh's recipe). The weights are chosen on
# the development protocols only; the fault-size rows say what the test side would
# have given, the last one the best weighting chosen on the test side itself (an
# oracle, not a result).
set -euo pipefail
cd "$(dirname "$0")/.."
data=${1:-../shared/data/cwru}
venv=.venv-probe
if ! "$venv/bin/python" -c "import numpy" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q numpy scikit-learn
fi
cargo build --release -q -p pumptwin --bin pumptwin
out=out/expert-fusion
mkdir -p "$out"
run() { # protocol seed
  local dir=$out/$1-$2
  if [ ! -f "$dir/model.bpk" ]; then
    ./target/release/pumptwin train --data "$data" --protocol "$1" --seed "$2" --out "$dir" >"$dir.log" 2>&1
  fi
  if [ ! -f "$dir/experts.json" ]; then
    ./target/release/pumptwin eval --model "$dir/model.bpk" --data "$data" --protocol "$1" \
      --out "$dir/eval" --no-figures --experts "$dir/experts.json" >>"$dir.log" 2>&1
  fi
}
for s in 42 7 1 3; do
  for p in fault-size-dev7 fault-size-dev21 time-block-dev cross-load-dev0; do run "$p" "$s"; done
done
for s in 42 7 1; do run fault-size "$s"; done
exec "$venv/bin/python" scripts/expert_fusion.py "$out"
