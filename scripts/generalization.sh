#!/usr/bin/env bash
# docs/evaluation-generalization.md from nothing: the networks it scores where they
# never saw the records (a DS-STGAT and a WDCNN trained on `fault-size`'s training
# side, a WDCNN on CWRU's `time-block`; the shipped DS-STGAT for the other rigs),
# then the report. The physics' settings are the core's (chosen on `cwru-dev`) and,
# for `sim-only`, those chosen on `sim-dev` by
# `python3 scripts/diagnosis_thresholds.py WINDOWS.tsv sim-dev` (run here).
#   bash scripts/generalization.sh [DATA_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
data="${1:-../shared/data}"
cargo build --release -p pumptwin --bin pumptwin
pt=./target/release/pumptwin
gen=out/gen
mkdir -p "$gen"
[ -f "$gen/dsstgat-fs/model.bpk" ] ||
  "$pt" train --data "$data/cwru" --protocol fault-size --out "$gen/dsstgat-fs" --no-figures
[ -f "$gen/dsstgat-fs.ptm" ] ||
  "$pt" export --model "$gen/dsstgat-fs/model.bpk" --data "$data/cwru" --out "$gen/dsstgat-fs.ptm"
[ -f "$gen/wdcnn-tb/model.bpk" ] ||
  "$pt" train --arch wdcnn --data "$data/cwru" --protocol time-block --out "$gen/wdcnn-tb" --no-figures
[ -f "$gen/wdcnn-fs/model.bpk" ] ||
  "$pt" train --arch wdcnn --data "$data/cwru" --protocol fault-size --out "$gen/wdcnn-fs" --no-figures
# The sim-only settings: chosen on sim-dev's windows alone.
tmp="$(mktemp -d)"
"$pt" eval-generalization --data "$data" --sim-records 96 --sim-seed 1 \
  --out "$tmp/dev.md" --windows-tsv "$tmp/windows.tsv" 2>/dev/null
sim="$(python3 scripts/diagnosis_thresholds.py "$tmp/windows.tsv" sim-dev | sed -n 's/^--sim-thresholds //p')"
echo "sim-dev thresholds: $sim"
"$pt" eval-generalization --data "$data" --model models/dsstgat-cwru-tb.ptm \
  --fault-size-model "$gen/dsstgat-fs.ptm" --wdcnn "$gen/wdcnn-tb/model.bpk" \
  --fault-size-wdcnn "$gen/wdcnn-fs/model.bpk" --sim-records 96 --sim-seed 1 \
  --sim-thresholds "$sim" --out docs/evaluation-generalization.md
