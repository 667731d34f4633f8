#!/usr/bin/env bash
# The loop's fault hypothesis on the measured records the core diagnosis may call
# normal: CWRU's ball and OR014 records, its Normal_0, HIT-SM's three normals; one
# line each: the loop's fault, the diagnosis's majority, and each family's level (dB
# over its floor) that the loop's own rule reads (`first_fit::identify_fault`).
# About 5 min. Needs ../shared/data.
#   bash scripts/loop-hypothesis-normals.sh [OUTDIR]
set -uo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/loop-normals}"; mkdir -p "$out"
cargo build --release -q -p pumptwin --bin pumptwin
pt=./target/release/pumptwin
show() { python3 -c "
import json,sys; r=json.load(open('$1/report.json')); e=r['fault_evidence']
print('%-12s %-11s diag %-18s bpfo %5.1f bpfi %5.1f bsf %5.1f' % ('$2', r['fault'], e.get('diagnosis'), e['bpfo_db'], e['bpfi_db'], e['bsf_db']))"; }
while read -r f name; do
  $pt twin loop --input ../shared/data/cwru/$f --out "$out/$name" > "$out/$name.log" 2>&1 && show "$out/$name" "$name"
done < <(awk -F'\t' 'NR>1 && ($3 ~ /^B0|^OR014|^Normal/) {print $1, $3}' ../shared/data/cwru/MANIFEST.tsv)
for r in 600 900 1200; do
  v=$(grep "Normal_$r" ../shared/data/hit_sm/MANIFEST.tsv | cut -f6 | cut -d' ' -f1)
  $pt twin loop --input ../shared/data/hit_sm/self-built/Normal_$r.mat --var "$v" --fs 51200 --rpm $r --bearing 9,7.94,39.04,0 --out "$out/N$r" > "$out/N$r.log" 2>&1 && show "$out/N$r" "hit N$r"
done
