#!/usr/bin/env bash
# Build the libFuzzer targets of fuzz/ on the stable toolchain and run each in turn.
#
#   bash scripts/fuzz.sh                      # every target, 30 s each (what CI runs)
#   FUZZ_SECONDS=3600 bash scripts/fuzz.sh mat
#   FUZZ_RUNS=10000000 bash scripts/fuzz.sh candump_log model_file
#
# Stable rustc has no `-Zsanitizer`, so this passes the SanitizerCoverage flags that
# cargo-fuzz would (`--cfg fuzzing`, 8-bit counters, PC table, compare tracing) and an
# explicit `--target`, which keeps them off build scripts and proc macros. The fuzz
# crate's release profile keeps debug assertions and overflow checks on. No
# AddressSanitizer (the code under test has no `unsafe`; a panic, an abort, a
# timeout or an RSS over the limit is a finding).
#
# Corpora grow in fuzz/corpus/TARGET (seeded from fuzz/seeds/TARGET, both kept out of
# git but the seeds); a crashing input lands in fuzz/artifacts/TARGET/ and the script
# exits non-zero. Targets run FUZZ_JOBS at a time (default 2, the machine's cores),
# each a single libFuzzer process with its whole time.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"

ALL=(candump_log frame_decode sensor_map_toml dbc model_file csv mat wav tdms uff)
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=("${ALL[@]}")
SECONDS_EACH="${FUZZ_SECONDS:-30}"
RUNS="${FUZZ_RUNS:--1}"
JOBS="${FUZZ_JOBS:-2}"
HOST=x86_64-unknown-linux-gnu
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$(pwd)/target}"
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing"

bins=()
for t in "${TARGETS[@]}"; do bins+=(--bin "$t"); done
nice -n 19 cargo build --release --target "$HOST" "${bins[@]}"

# One target's run; non-zero on a finding (its log's tail printed).
fuzz_one() {
    local t=$1 corpus="corpus/$1" max_len=8192 log rc execs speed crashes
    [ "$t" = model_file ] && max_len=16384  # the shipped model is 10.5 KB
    mkdir -p "$corpus" "artifacts/$t"
    log="${FUZZ_LOG_DIR:-/tmp}/pumptwin-fuzz-$t.log"
    echo "==> fuzz $t: ${SECONDS_EACH}s or ${RUNS} runs; log $log"
    set +e
    nice -n 19 "$CARGO_TARGET_DIR/$HOST/release/$t" "$corpus" "seeds/$t" \
        -max_total_time="$SECONDS_EACH" -runs="$RUNS" -rss_limit_mb=2048 -timeout=10 \
        -max_len="$max_len" -print_final_stats=1 -artifact_prefix="artifacts/$t/" >"$log" 2>&1
    rc=$?
    set -e
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    speed=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    crashes=$(find "artifacts/$t" -type f | wc -l)
    echo "    $t: executions ${execs:-?}, ${speed:-?} exec/s, exit $rc, artifacts $crashes"
    if [ "$rc" -ne 0 ] || [ "$crashes" -ne 0 ]; then
        tail -40 "$log"
        return 1
    fi
}

# FUZZ_JOBS targets at a time (default 2, one per core: each fuzzer is one process
# on one core), each with its whole time.
status=0
for t in "${TARGETS[@]}"; do
    while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do wait -n || status=1; done
    fuzz_one "$t" &
done
while [ "$(jobs -rp | wc -l)" -gt 0 ]; do wait -n || status=1; done
exit "$status"
