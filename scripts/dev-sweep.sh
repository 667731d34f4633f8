#!/usr/bin/env bash
# Choose a core feature constant on the development protocols only.
#
#   [SRC=FILE] bash scripts/dev-sweep.sh CONSTANT "V1 V2 ..." [SEEDS]
#   e.g. bash scripts/dev-sweep.sh BAND_SHARE_FLOOR "1e-4 1e-3 3e-3 1e-2 3e-2" "42 7"
#
# For each value: set `pub const CONSTANT: f32 = V;` in SRC (default
# core/src/features.rs; f64 and usize constants too), build,
# train the DS-STGAT on the development protocols (default `time-block-dev` and
# `cross-load-dev`; PROTOCOLS="..." to change, e.g. add `cross-load-dev0`, the harder
# load shift) for each seed, and print
# one line per run: clean accuracy and the noise curve (10 … −4 dB). The file is put
# back as it was at the end. The test sides of `time-block` and `cross-load` are never
# read, so the value chosen here leaves their figures honest.
set -euo pipefail
cd "$(dirname "$0")/.."
const=$1
values=$2
seeds=${3:-42}
protocols=${PROTOCOLS:-"time-block-dev cross-load-dev"}
data=${DATA:-../shared/data/cwru}
src=${SRC:-core/src/features.rs}
ty=$(sed -n "s/^pub const $const: \(f32\|f64\|usize\) = .*/\1/p" "$src")
[ -n "$ty" ] || { echo "no f32/f64/usize constant $const in $src" >&2; exit 1; }
cp "$src" "$src.sweep-orig"
trap 'mv "$src.sweep-orig" "$src"' EXIT
out=out/dev-sweep/$const
mkdir -p "$out"
for v in $values; do
  sed -i "s/^pub const $const: $ty = .*;/pub const $const: $ty = $v;/" "$src"
  cargo build --release -q -p pumptwin --bin pumptwin
  for seed in $seeds; do
    for p in $protocols; do
      dir=$out/$v-$p-$seed
      ./target/release/pumptwin train --data "$data" --protocol "$p" --seed "$seed" --out "$dir" >"$dir.log" 2>&1
      python3 - "$dir/metrics.json" "$const=$v" "$p" "$seed" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
noise = " ".join(f"{n['snr_db']:g}:{100 * n['accuracy']:.1f}" for n in m["noise"])
print(f"{sys.argv[2]:<24} {sys.argv[3]:<15} seed {sys.argv[4]:<4} clean {100 * m['accuracy']:6.2f}  {noise}")
PY
    done
  done
done | tee "$out/summary.txt"
