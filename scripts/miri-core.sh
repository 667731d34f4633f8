#!/usr/bin/env bash
# Miri (nightly's interpreter, checks undefined behaviour: out-of-bounds, use of
# uninitialised memory, invalid values, aliasing) on the core's unit tests that fit it.
#
#   bash scripts/miri-core.sh           # the curated list below (what CI runs)
#   bash scripts/miri-core.sh --all     # every unit test of the core (hours)
#
# The core itself has no `unsafe`; what Miri checks here is the unsafe code it builds
# on: heapless's MaybeUninit buffers and postcard's deserializer (the in-place model
# decoder), and core's slice/iterator internals under the kernels. Numeric tests
# that run thousands of RK4 steps, FFTs of 4096 points or 10^5 random draws take
# minutes to hours each under the interpreter and are left to the native runs.
# libm's x86 sqrt is inline assembly, which Miri cannot run: its soft-float
# implementation is selected (same IEEE results).
set -euo pipefail
cd "$(dirname "$0")/.."

# The components for the nightly already installed (the image has one); a nightly
# only if there is none (installing over an existing one would update it).
have() { rustup component list --toolchain nightly --installed 2>/dev/null | grep -q "^$1"; }
if ! have miri || ! have rust-src; then
    log=/tmp/pumptwin-miri-install.log
    if rustup toolchain list | grep -q '^nightly'; then
        rustup component add --toolchain nightly miri rust-src >"$log" 2>&1 || true
    else
        rustup toolchain install nightly --profile minimal --component miri,rust-src >"$log" 2>&1 || true
    fi
    if ! have miri || ! have rust-src; then
        echo "miri: SKIPPED, the nightly miri and rust-src components could not be installed:" >&2
        tail -3 "$log" >&2
        exit 0
    fi
fi
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$(pwd)/target}/miri"

TESTS=(
    bearing::tests::bpfo_plus_bpfi_is_n_times_shaft
    bearing::tests::cwru_6203_orders_match_published
    bearing::tests::cwru_6205_orders_match_published
    bearing::tests::rejects_impossible_geometry
    units::tests
    math::tests
    graph::tests::rejects_bad_config
    graph::tests::masked_node_is_isolated_and_its_garbage_ignored
    graph::tests::negative_correlation_is_no_edge_even_with_a_negative_threshold
    graph::tests::window_pearson_outside_the_window_is_zero
    model_file::tests::crc32_check_value
    model_file::tests::named_errors
    model_file::tests::postcard_level_errors
    model_file::tests::round_trip_is_exact
    model_file::tests::decode_into_overwrites_previous_contents
    model_file::tests::encode_reports_short_buffer
    model_file::tests::typed_sizes_must_match
    quant::linear::tests::integer_path_is_exact
    quant::linear::tests::rejects_bad_parts
    quant::pool::tests::masks_and_errors
    quant::softmax::tests::masks_errors_and_edge_cases
    quant::gat::tests::from_parts_checks_scales
    quant::gat::tests::adjacency_quantization_keeps_every_edge
    quant::gru::tests::from_parts_checks
    dsstgat::tests::probabilities_sum_to_one
    excitation::tests::bad_parameters
    features::tests::feature_norm_standardizes_and_checks
    features::tests::node_features_reject_bad_input
    fft::tests::rejects_bad_lengths
    fir::tests::bad_input_is_an_error
    model_file::tests::largest_model_fits_the_bounds
)
if [ "${1:-}" = "--all" ]; then TESTS=(); fi

nice -n 10 cargo +nightly miri test -p pumptwin-core --features libm/force-soft-floats --lib \
    -- --test-threads=1 "${TESTS[@]}"
