#!/usr/bin/env bash
# Executed-instruction counts per phase under QEMU (no cycle model: QEMU's wall time
# means nothing for a Cortex-M4). Builds with `--features no-paint` (painting 4 MiB
# of stack would dominate the trace), runs with one instruction per translation
# block and `-d exec,nochain`, so each executed instruction is one trace line, and
# counts the lines from a phase function's entry to its return address in `main`.
# The trace goes through a FIFO (it is ~700 MB as a file).
set -euo pipefail
cd "$(dirname "$0")"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$(pwd)/../target/fw-probe}"
PROFILE_OPT="${OPT_LEVEL:+CARGO_PROFILE_RELEASE_OPT_LEVEL=$OPT_LEVEL}"
env $PROFILE_OPT nice -n 10 cargo build --release -j1 --features no-paint >&2
ELF="$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/pumptwin-firmware-probe"
NM=$(command -v arm-none-eabi-nm); OBJDUMP=$(command -v arm-none-eabi-objdump)

# Entry address and return address (the instruction after the `bl`) of each phase.
DIS=$("$OBJDUMP" -d -C --no-show-raw-insn "$ELF")
markers=""
for p in phase_decode phase_build phase_forward; do
    entry=$("$NM" -C "$ELF" | awk -v p="pumptwin_firmware_probe::$p" '$3==p {print $1}')
    ret=$(printf '%s\n' "$DIS" | grep -A1 -E "bl[[:space:]]+[0-9a-f]+ <.*::${p}>$" | tail -1 | awk -F: '{gsub(/ /,"",$1); print $1}')
    markers="$markers $p:$entry:$ret"
done
echo "markers (phase:entry:return):$markers" >&2

tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
mkfifo "$tmp/trace"
python3 - "$tmp/trace" $markers > "$tmp/counts" <<'PY' &
import re, sys
fifo, marks = sys.argv[1], sys.argv[2:]
entry, ret = {}, {}
for m in marks:
    name, e, r = m.split(":")
    entry[int(e, 16) & ~1] = name
    ret[name] = int(r, 16)
counts = {n: 0 for n in ret}
by_symbol = {n: {} for n in ret}
total, cur = 0, None
pat = re.compile(rb"^Trace \d+: \S+ \[[0-9a-f]+/([0-9a-f]+)/[^\]]*\] ?(.*)$")
with open(fifo, "rb") as f:
    for line in f:
        m = pat.match(line)
        if not m:
            continue
        total += 1
        pc = int(m.group(1), 16)
        if cur is None:
            if pc in entry:
                cur = entry[pc]
        elif pc == ret[cur]:
            cur = None
        if cur is not None:
            counts[cur] += 1
            sym = m.group(2)
            by_symbol[cur][sym] = by_symbol[cur].get(sym, 0) + 1
for n in ret:
    print(f"INSNS {n}: {counts[n]}")
    top = sorted(by_symbol[n].items(), key=lambda kv: -kv[1])[:5]
    for sym, k in top:
        print(f"    {k:9d}  {sym.decode(errors='replace')[:110]}")
print(f"INSNS total (reset to exit, incl. semihosting prints): {total}")
PY
counter=$!
status=0
timeout 600 qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
    -semihosting-config enable=on,target=native \
    -singlestep -d exec,nochain -D "$tmp/trace" -kernel "$ELF" > "$tmp/out" || status=$?
wait "$counter"
grep -E "PASS|FAIL" "$tmp/out" || true
cat "$tmp/counts"
exit "$status"
