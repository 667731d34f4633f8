#!/usr/bin/env bash
# Epoch time of the DS-STGAT: burn (flex CPU backend, `pumptwin train`) vs the same
# model in PyTorch CPU (benches/torch_epoch.py), same data, shapes and epochs, REPEAT runs
# each, one after the other on the same machine. Installs torch with pip into
# .venv-torch (PyPI's Linux wheel, about 3 GB with its CUDA libraries; they are not
# used, the run is on the CPU).
#   [REPEAT=3] bash benches/torch_vs_burn.sh [DATA_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
DATA=${1:-../shared/data/cwru}
OUT=out/bench-torch
mkdir -p "$OUT"
if [ ! -x .venv-torch/bin/python ]; then
    python3 -m venv .venv-torch
fi
.venv-torch/bin/python -c "import torch, numpy" 2>/dev/null || .venv-torch/bin/pip install -q torch numpy
cargo build --release -p pumptwin-trainer --example dump_tensors && cargo build --release -p pumptwin --bin pumptwin
./target/release/examples/dump_tensors "$DATA" "$OUT/tensors"
# burn: the same DS-STGAT without the co-adaptation heads (the PyTorch script has
# none); the per-epoch seconds exclude the simulated pre-training, as for PyTorch.
# The two run REPEAT times each, alternating (burn, torch, burn, ...), and the medians
# are compared: on the shared 2-core VM one PyTorch run varied from 149 to 227 ms per
# epoch between otherwise identical runs, so one run each decides nothing.
REPEAT=${REPEAT:-3}
: >"$OUT/runs.txt"
for k in $(seq "$REPEAT"); do
    ./target/release/pumptwin train --data "$DATA" --protocol time-block --out "$OUT/burn" \
        --ablation no-coadapt --no-monitor --no-figures >"$OUT/burn.log" 2>&1
    python3 -c "
import json; h=json.load(open('$OUT/burn/history.json'))
s=[e['seconds'] for e in h]; print(json.dumps({'framework': 'burn 0.22.1 flex', 'seconds_per_epoch': sum(s)/len(s), 'final_train_accuracy': h[-1]['train_accuracy']}))" >>"$OUT/runs.txt"
    .venv-torch/bin/python benches/torch_epoch.py "$OUT/tensors" >>"$OUT/runs.txt"
done
python3 - "$OUT/runs.txt" <<'PY'
import json, statistics, sys
runs = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
burn = [r for r in runs if r["framework"].startswith("burn")]
torch = [r for r in runs if not r["framework"].startswith("burn")]
def show(name, rs):
    ms = [1e3 * r["seconds_per_epoch"] for r in rs]
    print(f"{name}: median {statistics.median(ms):7.1f} ms/epoch (runs: {', '.join(f'{m:.1f}' for m in ms)}), final train acc {100 * rs[-1]['final_train_accuracy']:.2f} %")
    return statistics.median(ms)
b = show(burn[0]["framework"], burn)
t = show(f"{torch[0]['framework']} ({torch[0]['threads']} threads)", torch)
print(f"ratio burn / torch (medians): {b / t:.2f}")
PY
