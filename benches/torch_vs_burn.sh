#!/usr/bin/env bash
# Epoch time of the DS-STGAT: burn (flex CPU backend, `pumptwin train`) vs the same
# model in PyTorch CPU (benches/torch_epoch.py), same data, shapes and epochs, one run
# each, one after the other on the same machine. Installs torch with pip into
# .venv-torch (PyPI's Linux wheel, about 3 GB with its CUDA libraries; they are not
# used, the run is on the CPU).
#   bash benches/torch_vs_burn.sh [DATA_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
DATA=${1:-../shared/data/cwru}
OUT=out/bench-torch
mkdir -p "$OUT"
if [ ! -x .venv-torch/bin/python ]; then
    python3 -m venv .venv-torch
fi
.venv-torch/bin/python -c "import torch, numpy" 2>/dev/null || .venv-torch/bin/pip install -q torch numpy
cargo build --release -p pumptwin-trainer --example dump_tensors --bin pumptwin
./target/release/examples/dump_tensors "$DATA" "$OUT/tensors"
# burn: the same DS-STGAT without the co-adaptation heads (the PyTorch script has
# none); the per-epoch seconds exclude the simulated pre-training, as for PyTorch.
./target/release/pumptwin train --data "$DATA" --protocol time-block --out "$OUT/burn" \
    --ablation no-coadapt --no-monitor --no-figures >"$OUT/burn.log" 2>&1
BURN=$(python3 -c "
import json; h=json.load(open('$OUT/burn/history.json'))
s=[e['seconds'] for e in h]; print(sum(s)/len(s), sum(s[1:])/max(len(s)-1,1), h[-1]['train_accuracy'])")
TORCH=$(.venv-torch/bin/python benches/torch_epoch.py "$OUT/tensors")
python3 - "$BURN" "$TORCH" <<'PY'
import json, sys
b = [float(v) for v in sys.argv[1].split()]
t = json.loads(sys.argv[2])
print(f"burn 0.22.1 flex:   {b[0]*1e3:8.1f} ms/epoch (after the first {b[1]*1e3:8.1f}), final train acc {100*b[2]:.2f} %")
print(f"{t['framework']} ({t['threads']} threads): {t['seconds_per_epoch']*1e3:8.1f} ms/epoch (after the first {t['seconds_per_epoch_after_first']*1e3:8.1f}), final train acc {100*t['final_train_accuracy']:.2f} %")
print(f"ratio burn / torch: {b[0]/t['seconds_per_epoch']:.2f} (after the first epoch {b[1]/t['seconds_per_epoch_after_first']:.2f})")
PY
