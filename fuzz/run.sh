#!/usr/bin/env bash
# Fuzzes every target (or the ones named) for RUNS executions each (default
# one million), under the memory bounds of docs/RELIABILITY.md, then merges
# what added coverage into corpus/TARGET (committed; replayed on stable by
# crates/nimbus-fuzz/tests/corpora.rs). Needs nightly and cargo-fuzz:
#   cargo install cargo-fuzz && fuzz/run.sh [TARGET...]
# A crash stops the script; its input is in artifacts/TARGET/: fix the
# reader, then keep the input in regressions/TARGET/.
set -euo pipefail
cd "$(dirname "$0")"
runs=${RUNS:-1000000}
all=(scene_toml scene_structured gltf npy roots_json optics_cache cumulus_cache fit_table)
targets=("${@:-${all[@]}}")
mkdir -p logs
[ -n "${NO_BUILD:-}" ] || cargo +nightly fuzz build -O
bin=target/x86_64-unknown-linux-gnu/release
for target in "${targets[@]}"; do
    mkdir -p "corpus/$target" "corpus-work/$target" "artifacts/$target"
    # RSS: the release binary's 512 MiB bound plus AddressSanitizer's
    # shadow memory and quarantine; no single allocation above 512 MiB.
    "$bin/$target" "corpus-work/$target" "corpus/$target" "seeds/$target" \
        -runs="$runs" -rss_limit_mb=1024 -malloc_limit_mb=512 -max_len=16384 \
        -timeout=10 -print_final_stats=1 -artifact_prefix="artifacts/$target/" >"logs/$target.log" 2>&1 || {
        tail -40 "logs/$target.log"
        exit 1
    }
    grep -E '^(stat::number_of_executed_units|stat::peak_rss_mb)|^Done' "logs/$target.log" |
        sed "s/^/$target: /"
    "$bin/$target" "corpus/$target" "corpus-work/$target" \
        -merge=1 -rss_limit_mb=1024 -max_len=16384 -timeout=10 >>"logs/$target.log" 2>&1
    echo "$target: corpus $(ls "corpus/$target" | wc -l) inputs, $(du -sh "corpus/$target" | cut -f1)"
done
