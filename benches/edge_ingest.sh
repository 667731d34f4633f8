#!/usr/bin/env bash
# Edge gateway throughput, latency, memory and CPU over 10 minutes of bus time:
# the ten 0 HP CWRU records (10 s each, whole records) encoded six times over into one
# candump log (600 s, 3 channels × 12 kHz, CAN FD frames of 31 samples), replayed with
# --speed max through the shipped sensor map and int8 model on one core. RSS and the
# process's CPU time are sampled every 0.5 s. Writes out/edge_ingest.md. Needs
# ../shared/data/cwru and the trainer (`pumptwin can-encode`).
#
#   EDGE_INGEST_SOURCE=demo bash benches/edge_ingest.sh   # the soak of RELIABILITY.md
#
# builds the log instead from models/demo.log (1 s of each record, 10 s of bus)
# repeated with continued time stamps and sequence counters: no trainer build, no
# shared data; EDGE_INGEST_MINUTES sets the bus time (default 10). Binaries and the
# log go under $CARGO_TARGET_DIR (default target/).
set -euo pipefail
cd "$(dirname "$0")/.."
D=../shared/data/cwru
T="${CARGO_TARGET_DIR:-target}"
SOURCE="${EDGE_INGEST_SOURCE:-cwru}"
MINUTES="${EDGE_INGEST_MINUTES:-10}"
mkdir -p out "$T/bench"
if [ "$SOURCE" = demo ]; then
  cargo build --release -p pumptwin-edge
  log="$T/bench/demo-x$((MINUTES * 6)).log"
  if [ ! -s "$log" ]; then
    python3 - models/demo.log "$((MINUTES * 6))" > "$log" <<'PY'
import sys
# models/demo.log is 10 s of bus; repeat it, shifting time by 10 s a pass and
# continuing each channel's sequence counter (the first data byte of an FD frame).
lines = [l for l in open(sys.argv[1]).read().splitlines() if l.startswith("(")]
per_pass = {}
for l in lines:
    cid = l.split()[2].split("#")[0]
    per_pass[cid] = per_pass.get(cid, 0) + 1
out = sys.stdout
for r in range(int(sys.argv[2])):
    for l in lines:
        ts, iface, frame = l.split()
        sec, usec = ts[1:-1].split(".")
        cid, body = frame.split("##")
        seq = (int(body[1:3], 16) + r * per_pass[cid]) & 0xFF
        out.write(f"({int(sec) + 10 * r}.{usec}) {iface} {cid}##{body[0]}{seq:02X}{body[3:]}\n")
PY
  fi
  BUS_S=$((MINUTES * 60))
else
  cargo build --release -p pumptwin -p pumptwin-edge
  log="$T/bench/ten-minutes.log"
  if [ ! -s "$log" ]; then
    recs=""
    for f in normal/97 12k_DE/105 12k_DE/169 12k_DE/209 12k_DE/118 12k_DE/185 12k_DE/222 12k_DE/130 12k_DE/197 12k_DE/234; do
      recs="$recs $D/$f.mat"
    done
    "$T/release/pumptwin" can-encode --sensors models/cwru-sensors.toml --out "$log" \
      --duration-s 10 --input $recs $recs $recs $recs $recs $recs
  fi
  BUS_S=600
fi
frames=$(wc -l < "$log")
rss_log=$(mktemp)
tick=$(getconf CLK_TCK)
t0=$(date +%s.%N)
taskset -c 0 "$T/release/pumptwin-edge" --replay "$log" --sensors models/cwru-sensors.toml \
  --model models/dsstgat-cwru-tb.ptm > /dev/null 2> "$T/bench/edge.err" &
pid=$!
# Every 0.5 s: wall time, RSS (KiB), CPU time (utime + stime, clock ticks).
while kill -0 $pid 2>/dev/null; do
  rss=$(awk '/VmRSS/ {print $2}' /proc/$pid/status 2>/dev/null || true)
  cpu=$(awk '{print $14 + $15}' /proc/$pid/stat 2>/dev/null || true)
  [ -n "$rss" ] && [ -n "$cpu" ] && echo "$(date +%s.%N) $rss $cpu" >> "$rss_log"
  sleep 0.5
done
wait $pid
t1=$(date +%s.%N)
python3 - "$frames" "$t0" "$t1" "$rss_log" "$T/bench/edge.err" "$BUS_S" "$tick" "$SOURCE" <<'PY' | tee out/edge_ingest.md
import re, sys
frames, t0, t1 = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
rows = [l.split() for l in open(sys.argv[4]).read().splitlines()]
bus_s, tick, source = int(sys.argv[6]), int(sys.argv[7]), sys.argv[8]
ts = [float(r[0]) - t0 for r in rows]
rss = [int(r[1]) for r in rows]
cpu = [int(r[2]) / tick for r in rows]
err = open(sys.argv[5]).read()
health = re.search(r"pumptwin-edge: (\d+ frames: .*)", err)
lat = re.search(r"over (\d+) windows: p50 (\d+) us, p99 (\d+) us, max (\d+) us", err)
wall = t1 - t0
samples = frames * 31
print(f"| figure | value |\n|---|---|")
print(f"| bus time replayed | {bus_s} s (3 channels × 12 kHz; log: {source}) |")
print(f"| frames (CAN FD, 31 samples each) | {frames} |")
print(f"| wall time, one core (`taskset -c 0`) | {wall:.1f} s ({bus_s / wall:.0f}× real time) |")
print(f"| frames per second ingested | {frames / wall:,.0f} |")
print(f"| samples per second ingested | {samples / wall:,.0f} |")
print(f"| windows | {lat.group(1)} |")
print(f"| frame → window line latency p50 / p99 / max | {lat.group(2)} / {lat.group(3)} / {lat.group(4)} µs |")
print(f"| RSS at 0.5 s / 1 s / end / max (KiB, {len(rss)} samples every 0.5 s) | {rss[1]} / {rss[2]} / {rss[-1]} / {max(rss)} |")
def util(a, b):  # CPU share of one core between samples a and b
    return 100 * (cpu[b] - cpu[a]) / (ts[b] - ts[a]) if ts[b] > ts[a] else float("nan")
s0 = next((i for i, t in enumerate(ts) if t >= 0.5), 0)  # the process is up
print(f"| start / end: RSS (KiB) | {rss[s0]} at {ts[s0]:.1f} s / {rss[-1]} at {ts[-1]:.1f} s |")
print(f"| start / end: CPU time used | {cpu[s0]:.2f} s / {cpu[-1]:.2f} s |")
print(f"| start / end: CPU share of one core over 2 s | {util(0, min(4, len(cpu) - 1)):.0f} % / {util(max(0, len(cpu) - 5), len(cpu) - 1):.0f} % |")
print(f"| final counters | {health.group(1) if health else '?'} |")
print(f"| RSS samples | {' '.join(map(str, rss))} |")
PY
