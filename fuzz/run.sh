#!/usr/bin/env bash
# Runs built fuzz targets (`cargo +nightly fuzz build --codegen-units 16` first, and
# `bash fuzz/seed_corpora.sh`) with the limits docs/fuzzing.md gives, at the lowest priority,
# each for SECONDS, all at once in the background of this script; it waits for them. Logs go to
# fuzz/logs/TARGET.log, new inputs to fuzz/corpus/TARGET/, reproducers to fuzz/artifacts/TARGET/.
#
#     bash fuzz/run.sh SECONDS TARGET...
set -euo pipefail
cd "$(dirname "$0")"
seconds=$1; shift
bin=target/x86_64-unknown-linux-gnu/release
mkdir -p logs
# OpenJPEG's C sources (the dicom target) have function-local statics of the same name, which
# AddressSanitizer's one-definition-rule check mistakes for duplicate globals; cargo-fuzz sets
# the same option when it runs a target.
export ASAN_OPTIONS=detect_odr_violation=0
for target in "$@"; do
    mkdir -p "artifacts/$target" "corpus/$target"
    nice -n 19 "$bin/$target" "corpus/$target" -artifact_prefix="artifacts/$target/" \
        -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 -max_total_time="$seconds" \
        -print_final_stats=1 > "logs/$target.log" 2>&1 &
done
wait
for target in "$@"; do
    echo "== $target"
    grep -E "^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)|cov: .* ft:|ERROR|SUMMARY|Test unit written" "logs/$target.log" | tail -n 6
done
