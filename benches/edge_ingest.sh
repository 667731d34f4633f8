#!/usr/bin/env bash
# Edge gateway throughput, latency and memory over 10 minutes of bus time:
# the ten 0 HP CWRU records (10 s each, whole records) encoded six times over into one
# candump log (600 s, 3 channels × 12 kHz, CAN FD frames of 31 samples), replayed with
# --speed max through the shipped sensor map and int8 model on one core. RSS is
# sampled every 0.5 s. Writes out/edge_ingest.md. Needs ../shared/data/cwru.
set -euo pipefail
cd "$(dirname "$0")/.."
D=../shared/data/cwru
cargo build --release -p pumptwin-trainer -p pumptwin-edge
mkdir -p out target/bench
log=target/bench/ten-minutes.log
if [ ! -s "$log" ]; then
  recs=""
  for f in normal/97 12k_DE/105 12k_DE/169 12k_DE/209 12k_DE/118 12k_DE/185 12k_DE/222 12k_DE/130 12k_DE/197 12k_DE/234; do
    recs="$recs $D/$f.mat"
  done
  target/release/pumptwin can-encode --sensors models/cwru-sensors.toml --out "$log" \
    --duration-s 10 --input $recs $recs $recs $recs $recs $recs
fi
frames=$(wc -l < "$log")
rss_log=$(mktemp)
t0=$(date +%s.%N)
taskset -c 0 target/release/pumptwin-edge --replay "$log" --sensors models/cwru-sensors.toml \
  --model models/dsstgat-cwru-tb.ptm > /dev/null 2> target/bench/edge.err &
pid=$!
while kill -0 $pid 2>/dev/null; do
  awk '/VmRSS/ {print $2}' /proc/$pid/status 2>/dev/null >> "$rss_log" || true
  sleep 0.5
done
wait $pid
t1=$(date +%s.%N)
python3 - "$frames" "$t0" "$t1" "$rss_log" target/bench/edge.err <<'PY' | tee out/edge_ingest.md
import re, sys
frames, t0, t1 = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
rss = [int(x) for x in open(sys.argv[4]).read().split()]
err = open(sys.argv[5]).read()
lat = re.search(r"over (\d+) windows: p50 (\d+) us, p99 (\d+) us, max (\d+) us", err)
wall = t1 - t0
samples = frames * 31
print(f"| figure | value |\n|---|---|")
print(f"| bus time replayed | 600 s (3 channels × 12 kHz) |")
print(f"| frames (CAN FD, 31 samples each) | {frames} |")
print(f"| wall time, one core (`taskset -c 0`) | {wall:.1f} s ({600 / wall:.0f}× real time) |")
print(f"| frames per second ingested | {frames / wall:,.0f} |")
print(f"| samples per second ingested | {samples / wall:,.0f} |")
print(f"| windows | {lat.group(1)} |")
print(f"| frame → window line latency p50 / p99 / max | {lat.group(2)} / {lat.group(3)} / {lat.group(4)} µs |")
print(f"| RSS at 0.5 s / 1 s / end / max (KiB, {len(rss)} samples every 0.5 s) | {rss[1]} / {rss[2]} / {rss[-1]} / {max(rss)} |")
print(f"| RSS samples | {' '.join(map(str, rss))} |")
PY
