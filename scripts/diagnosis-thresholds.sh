#!/usr/bin/env bash
# The physical diagnosis' settings, chosen on the development protocol (cwru-dev) only:
# the stretch of record each window is read over, then the thresholds and the
# confidence's calibration at the chosen stretch (pumptwin_core::diagnosis::Thresholds).
#   bash scripts/diagnosis-thresholds.sh [DATA_DIR]
set -euo pipefail
data="${1:-../shared/data}"
cargo build --release -p pumptwin --bin pumptwin
tmp="$(mktemp -d)"
for segment in 2048 4096 8192 16384 32768; do
  ./target/release/pumptwin eval-generalization --data "$data" --segment "$segment" \
    --out "$tmp/report-$segment.md" --windows-tsv "$tmp/windows-$segment.tsv" 2>/dev/null
  echo "segment $segment: $(python3 scripts/diagnosis_thresholds.py "$tmp/windows-$segment.tsv" | head -1)"
done
./target/release/pumptwin eval-generalization --data "$data" --out "$tmp/report.md" \
  --windows-tsv "$tmp/windows.tsv" 2>/dev/null
echo "default (16 revolutions):"
python3 scripts/diagnosis_thresholds.py "$tmp/windows.tsv"
