#!/usr/bin/env bash
# Renders the realism suite's path-traced references and measures nimbus
# against them (docs/REALISM.md).
#
#   tools/reference/suite.sh [--spp N] [--max-depth D] [SCENE.toml ...]
#
# For each scene (default: every scenes/realism/*.toml): `nimbus export`
# into target/realism/NAME/, tools/reference/render.py with two independent
# halves, `nimbus render` of the same frame to an EXR with its layers, and
# `nimbus compare` of the real-time image with the reference and of one half
# with the other (the reference's own noise). Writes
# scenes/realism/references/NAME.exr (the reference, half floats)
# and scenes/realism/references/NAME.json (the metrics, the noise, the
# command lines), and target/realism/NAME/report.png.
#
# Needs the Python setup of tools/reference/README.md.
set -euo pipefail
cd "$(dirname "$0")/../.."

spp=256
max_depth=-1
scenes=()
while [ $# -gt 0 ]; do
    case "$1" in
        --spp) spp="$2"; shift 2 ;;
        --max-depth) max_depth="$2"; shift 2 ;;
        *) scenes+=("$1"); shift ;;
    esac
done
if [ ${#scenes[@]} -eq 0 ]; then
    scenes=(scenes/realism/*.toml)
fi
: "${DRJIT_LIBLLVM_PATH:=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}"
export DRJIT_LIBLLVM_PATH

cargo build -p nimbus-sky --quiet
nimbus=target/debug/nimbus
mkdir -p scenes/realism/references

for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .toml)
    work=target/realism/$name
    mkdir -p "$work"
    echo "suite: $name" >&2
    export_cmd="nimbus export $scene --mitsuba $work"
    render_cmd="python3 tools/reference/render.py $work/scene.xml --spp $spp --halves --seed 1 -D max_depth=$max_depth -o $work/reference.exr"
    # An export newer than the scene is reused (delete target/realism/NAME
    # after changing what nimbus exports).
    if [ ! "$work/scene.xml" -nt "$scene" ]; then
        "$nimbus" export "$scene" --mitsuba "$work" 2> "$work/export.log"
    fi
    python3 tools/reference/render.py "$work/scene.xml" --spp "$spp" --halves --seed 1 \
        -D "max_depth=$max_depth" -o "$work/reference.exr"
    "$nimbus" render "$scene" -o "$work/realtime.exr" 2> /dev/null
    "$nimbus" compare "$work/realtime.exr" "$work/reference.exr" --json --out "$work/report.png" > "$work/error.json"
    "$nimbus" compare "$work/realtime.exr" "$work/reference_a.exr" --json > "$work/error_a.json"
    # The reference's noise: one half against the other, over the same mask.
    python3 - "$work" "$scene" "$spp" "$export_cmd" "$render_cmd" <<'EOF'
import json, sys, shutil, subprocess
work, scene, spp, export_cmd, render_cmd = sys.argv[1:6]
name = scene.split('/')[-1][:-5]
import mitsuba as mi
mi.set_variant('scalar_rgb')
# The halves compared over the real-time image's cloud mask.
import numpy as np
noise = json.loads(subprocess.run(['target/debug/nimbus', 'compare', f'{work}/reference_b.exr',
                                   f'{work}/reference_a.exr', '--mask-from', f'{work}/realtime.exr',
                                   '--json'], check=True, capture_output=True).stdout)
error = json.load(open(f'{work}/error.json'))
# The baseline of the realism work (the first measured error) is kept across
# re-runs, so that improvements can be read against it.
record_path = f'scenes/realism/references/{name}.json'
try:
    baseline = json.load(open(record_path)).get('baseline_error')
except (OSError, ValueError):
    baseline = None
record = {
    'scene': scene,
    'spp': int(spp),
    'error': error,
    'reference_noise_hdr_flip_mean': noise['hdr_flip_mean'],
    'reference_noise_luminance_relative_rmse': noise['luminance_relative_rmse'],
    'commands': [export_cmd, render_cmd, f'nimbus render {scene} -o realtime.exr',
                 'nimbus compare realtime.exr reference.exr --json'],
    'mitsuba': mi.__version__,
}
if baseline is not None:
    record['baseline_error'] = baseline
json.dump(record, open(record_path, 'w'), indent=2)
# Stored as half floats (ZIP): a 1e-3 relative rounding, far below the noise.
ref = mi.Bitmap(f'{work}/reference.exr').convert(component_format=mi.Struct.Type.Float16)
ref.write(f'scenes/realism/references/{name}.exr')
print(f"suite: {name}: HDR-FLIP {error['hdr_flip_mean']:.4f} (reference noise {noise['hdr_flip_mean']:.4f}), "
      f"luminance ratio {error['mean_luminance_ratio']:.3f}", file=sys.stderr)
EOF
done
