#!/usr/bin/env bash
# Cost of one DS-STGAT window, int8 core vs burn float, same golden window, same run:
# instructions per window (callgrind: (Ir at R2 reps − Ir at R1 reps) / (R2 − R1), so
# model loading cancels out) and wall time per window. Writes out/inference_cost.md.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p pumptwin-trainer --example inference_cost
bin=target/release/examples/inference_cost
mkdir -p out
ir() { # mode reps -> total instructions
  local f; f=$(mktemp)
  valgrind --tool=callgrind --callgrind-out-file="$f" "$bin" "$1" "$2" >/dev/null 2>&1
  callgrind_annotate "$f" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",","",$1); print $1}'
  rm -f "$f"
}
declare -A per
for mode in int8 burn; do
  a=$(ir "$mode" 1); b=$(ir "$mode" 21)
  per[$mode]=$(( (b - a) / 20 ))
done
t_int8=$("$bin" int8 20000 | sed -E 's/.* ([0-9.]+) µs per window.*/\1/')
t_burn=$("$bin" burn 2000 | sed -E 's/.* ([0-9.]+) µs per window.*/\1/')
ratio=$(python3 -c "print(f'{${per[burn]}/${per[int8]}:.1f}')")
tratio=$(python3 -c "print(f'{${t_burn}/${t_int8}:.1f}')")
{
  echo "| model | instructions per window (callgrind) | time per window |"
  echo "|---|---|---|"
  echo "| int8 core (\`pumptwin_core::dsstgat\`) | ${per[int8]} | ${t_int8} µs |"
  echo "| burn 0.22.1 float (flex CPU backend, batch 1) | ${per[burn]} | ${t_burn} µs |"
  echo "| ratio burn / int8 | ${ratio}× | ${tratio}× |"
} | tee out/inference_cost.md
