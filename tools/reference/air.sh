#!/usr/bin/env bash
# The air under the clouds against path-traced references with the air in
# them (docs/REALISM.md, "The air under a cloud layer").
#
#   tools/reference/air.sh [--spp N] [--measure-only] [SCENE.toml ...]
#
# For each scene (default: every scenes/realism-air/*.toml):
# 1. `nimbus export --mitsuba --air` into target/realism-air/NAME/ (δ-M 5°);
# 2. tools/reference/render.py --halves of the three grey air media
#    (-D air=r, g, b), combined by tools/reference/air.py into
#    scenes/realism-air/references/NAME_a.exr and NAME_b.exr (channel c of
#    render c) and NAME.json (samples, seconds);
# 3. `nimbus render` of the scene (its air on) into target/realism-air/NAME/;
# 4. tools/reference/air.py measure: terrain pixels by distance and cloud
#    pixels, into scenes/realism-air/references/NAME_error.json.
# --measure-only skips 1 and 2 (a change of nimbus's air, not the scene's).
set -euo pipefail
cd "$(dirname "$0")/../.."

spp=256
measure_only=
scenes=()
while [ $# -gt 0 ]; do
    case "$1" in
        --spp) spp="$2"; shift 2 ;;
        --measure-only) measure_only=1; shift ;;
        *) scenes+=("$1"); shift ;;
    esac
done
if [ ${#scenes[@]} -eq 0 ]; then
    scenes=(scenes/realism-air/*.toml)
fi
: "${DRJIT_LIBLLVM_PATH:=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}"
export DRJIT_LIBLLVM_PATH

cargo build -p nimbus-sky --quiet
# Where cargo put it: CARGO_TARGET_DIR (or the config's build.target-dir)
# moves the target directory away from ./target.
nimbus=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')/debug/nimbus
mkdir -p scenes/realism-air/references

for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .toml)
    work=target/realism-air/$name
    stored=scenes/realism-air/references/$name
    mkdir -p "$work"
    if [ -z "$measure_only" ]; then
        "$nimbus" export "$scene" --mitsuba "$work" --air 2> "$work/export.log"
        for channel in r g b; do
            nice -n 19 python3 tools/reference/render.py "$work/scene.xml" --spp "$spp" --halves \
                --seed 1 -D "air=$channel" -o "$work/reference_$channel.exr"
        done
        python3 tools/reference/air.py combine "$work"/reference_{r,g,b}.exr -o "$stored.exr"
        # The halves are what is kept (as the suite's references).
        rm -f "$stored.exr"
    fi
    "$nimbus" render "$scene" -o "$work/realtime.exr" 2> /dev/null
    python3 tools/reference/air.py measure "$work/realtime.exr" \
        --halves "${stored}_a.exr" "${stored}_b.exr" > "${stored}_error.json"
    echo "air: $name: ${stored}_error.json"
done
