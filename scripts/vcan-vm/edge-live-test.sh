#!/usr/bin/env bash
# Live SocketCAN end to end, in a QEMU VM with vcan0 (run-vm.sh):
#   canplayer (can-utils: a peer we did not write) plays models/demo.log onto vcan0
#   at its recorded pace, while pumptwin-edge reads vcan0 live
#   (--can vcan0 --model … --publish-id 0x7E0) and candump records the diagnosis
#   frames it publishes.
# Outside the VM the same binary replays the same log (--replay). Pass when the live
# run's windows equal the replay's (start sample, features, diagnosis), every frame
# was used, and exactly one diagnosis frame per window was published, carrying the
# window's class.
set -euo pipefail
cd "$(dirname "$0")/../.."
# The host's release build (the reference of scripts/arm-edge.sh, built once for
# both), run in the guest with its shared libraries beside it: the guest has the
# glibc loader and libc that can-utils need (build-initramfs.sh), not libgcc_s/libm.
cargo build --release -p pumptwin-edge
bin=target/release/pumptwin-edge
work=target/vcan-vm/edge-live
rm -rf "$work"
mkdir -p "$work/payload"
cp "$bin" models/demo.log models/cwru-sensors.toml models/dsstgat-cwru-tb.ptm "$work/payload/"
mkdir -p "$work/payload/lib"
ldd "$bin" | awk '/=> \// { print $3 }' | xargs -r cp -L -t "$work/payload/lib/"
cat > "$work/payload/run" <<'EOF'
#!/bin/sh
set -u
cd /payload
# Room for the backlog: under TCG emulation the gateway runs ~10x slower than the bus.
echo 16777216 > /proc/sys/net/core/rmem_max
LD_LIBRARY_PATH=/payload/lib ./pumptwin-edge --can vcan0 --sensors cwru-sensors.toml --model dsstgat-cwru-tb.ptm \
    --publish-id 0x7E0 --idle-exit 4 --out /tmp/live.jsonl 2>/tmp/edge.err &
edge=$!
candump -L vcan0,7E0:7FF > /tmp/published.log &
dump=$!
sleep 1
canplayer -I demo.log vcan0=can0
wait $edge
rc=$?
sleep 0.2
kill $dump
cat /tmp/edge.err
echo "LIVE-JSONL-BEGIN"
cat /tmp/live.jsonl
echo "LIVE-JSONL-END"
echo "PUBLISHED-BEGIN"
cat /tmp/published.log
echo "PUBLISHED-END"
exit $rc
EOF
chmod +x "$work/payload/run"
"$bin" --replay models/demo.log --sensors models/cwru-sensors.toml \
    --model models/dsstgat-cwru-tb.ptm > "$work/replay.jsonl"
t0=$(date +%s.%N)
scripts/vcan-vm/run-vm.sh "$work/payload" 300 > "$work/console.txt" || {
    tail -40 "$work/console.txt"; echo "VM run failed"; exit 1; }
t1=$(date +%s.%N)
python3 - "$work" "$t0" "$t1" <<'EOF'
import json, sys
work, t0, t1 = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
con = open(f"{work}/console.txt").read().splitlines()
def section(name):
    a = con.index(f"{name}-BEGIN"); b = con.index(f"{name}-END")
    return [l for l in con[a + 1:b] if l.strip()]
live = [json.loads(l) for l in section("LIVE-JSONL")]
published = section("PUBLISHED")
replay = [json.loads(l) for l in open(f"{work}/replay.jsonl")]
for l in con:
    if l.startswith("pumptwin-edge:"):
        print("  guest:", l)
assert len(live) == len(replay), f"{len(live)} live windows vs {len(replay)} replayed"
classes = ["normal","IR007","IR014","IR021","B007","B014","B021","OR007","OR014","OR021"]
for a, b in zip(live, replay):
    for key in ("window", "start_sample", "status", "channels", "diagnosis", "explanation"):
        assert a[key] == b[key], f"window {b['window']}: {key} differs:\n{a[key]}\n{b[key]}"
h = live[-1]["health"]
assert h["used"] == h["frames_total"], h
assert len(published) == len(live), f"{len(published)} frames published for {len(live)} windows"
for line, w in zip(published, live):
    data = bytes.fromhex(line.split()[2].split("#")[1])
    assert len(data) == 8
    cls = data[0]
    want = w["diagnosis"]["class"]
    assert (classes[cls] if cls != 0xFF else None) == want, (line, want)
    assert int.from_bytes(data[4:6], "little") == w["window"] & 0xFFFF
print(f"edge live test: {len(live)} windows from vcan0 equal the replay's; "
      f"{h['frames_total']} frames all used; {len(published)} diagnosis frames published "
      f"and decoded; VM run {t1 - t0:.1f} s")
EOF
