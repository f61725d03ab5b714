#!/bin/sh
# nimbus GPU benchmark: runs the benchmark set with the kit's prebuilt
# binaries (no network, no compiler) and writes one JSON report per run and
# a Markdown table. See README.md beside this script.
#
#   ./run.sh [OUT]        (OUT: where results go; default ./results beside run.sh)
#
# Settings (environment):
#   GPU_BENCH_ADAPTER    hardware (default), software or auto
#   GPU_BENCH_SIZES      "1920x1080 3840x2160" (default): WIDTHxHEIGHT, space-separated
#   GPU_BENCH_FRAMES     120 (default): measured frames per run, after one warm-up frame
#   GPU_BENCH_SCENES     all (default), or space-separated names: default cumulus-bench
#                        rain-bench rain-bench-5m rain-bench-10m stratus-… embed_world
#   GPU_BENCH_TIMEOUT_S  180 (default): the longest one run may take, s
#   GPU_BENCH_BUDGET_S   570 (default): the whole set's time, s; runs that would
#                        start after it are skipped (and reported as failed)
#
# Needs only a POSIX shell, coreutils (timeout, date, mv, tail) and a Vulkan
# driver; the kit carries a Vulkan loader (libvulkan.so.1) for machines
# without one. Exit status 0 when every run succeeded, 1 when any failed or
# was skipped (the others still run), 2 on a bad setting or a kit that
# cannot start.

set -u

die() {
    echo "run.sh: error: $*" >&2
    exit 2
}

case "${1:-}" in
-h | --help)
    # The header above, without the leading "# ".
    while IFS= read -r line; do
        case $line in
        '#!'*) ;;
        '#'*) line=${line#\#}; echo "${line# }" ;;
        *) break ;;
        esac
    done <"$0"
    exit 0
    ;;
esac
[ $# -le 1 ] || die "one argument at most (the output folder); --help for usage"

KIT=$(cd "$(dirname "$0")" && pwd) || die "cannot find the kit's folder"
OUT=${1:-$KIT/results}
ADAPTER=${GPU_BENCH_ADAPTER:-hardware}
SIZES=${GPU_BENCH_SIZES:-1920x1080 3840x2160}
FRAMES=${GPU_BENCH_FRAMES:-120}
SCENES=${GPU_BENCH_SCENES:-all}
RUN_TIMEOUT_S=${GPU_BENCH_TIMEOUT_S:-180}
BUDGET_S=${GPU_BENCH_BUDGET_S:-570}
NIMBUS=$KIT/bin/nimbus
EMBED=$KIT/bin/embed_world

# ---------------------------------------------------------------- settings

is_count() {
    case $1 in
    '' | *[!0-9]* | 0*) return 1 ;;
    esac
    [ ${#1} -le 6 ]
}
case $ADAPTER in
hardware | software | auto) ;;
*) die "GPU_BENCH_ADAPTER='$ADAPTER': must be hardware, software or auto" ;;
esac
is_count "$FRAMES" || die "GPU_BENCH_FRAMES='$FRAMES': must be a whole number of frames in [1, 999999]"
is_count "$RUN_TIMEOUT_S" || die "GPU_BENCH_TIMEOUT_S='$RUN_TIMEOUT_S': must be a whole number of seconds ≥ 1"
is_count "$BUDGET_S" || die "GPU_BENCH_BUDGET_S='$BUDGET_S': must be a whole number of seconds ≥ 1"
[ -n "$SIZES" ] || die "GPU_BENCH_SIZES is empty"
for size in $SIZES; do
    w=${size%%x*}
    h=${size#*x}
    case $size in
    *x*) is_count "$w" && is_count "$h" ;;
    *) false ;;
    esac || die "GPU_BENCH_SIZES: '$size' is not WIDTHxHEIGHT (e.g. 1920x1080)"
done
command -v timeout >/dev/null 2>&1 || die "'timeout' (coreutils) is not installed"
[ -x "$NIMBUS" ] && [ -x "$EMBED" ] || die "$KIT/bin/ lacks nimbus or embed_world: build the kit with tools/gpu-bench/pack.sh"

# The benchmark set, in table order.
if [ "$SCENES" = all ]; then
    SCENES="default cumulus-bench rain-bench rain-bench-5m rain-bench-10m"
    for file in "$KIT"/scenes/stratus-*.toml; do
        [ -f "$file" ] || continue
        name=${file##*/}
        SCENES="$SCENES ${name%.toml}"
    done
    SCENES="$SCENES embed_world"
fi
for name in $SCENES; do
    case $name in
    default | embed_world) ;;
    */* | .*) die "GPU_BENCH_SCENES: '$name' is a scene name, not a path" ;;
    *) [ -f "$KIT/scenes/$name.toml" ] || die "GPU_BENCH_SCENES: no scene $KIT/scenes/$name.toml" ;;
    esac
done

# ---------------------------------------------------------------- Vulkan

# The system's Vulkan loader if it has one, else the kit's.
system_loader() {
    for ldconfig in ldconfig /sbin/ldconfig /usr/sbin/ldconfig; do
        if cache=$("$ldconfig" -p 2>/dev/null); then
            case $cache in
            *"libvulkan.so.1 ("*) return 0 ;;
            esac
            break
        fi
    done
    old_ifs=$IFS
    IFS=:
    for dir in ${LD_LIBRARY_PATH:-} /lib/x86_64-linux-gnu /usr/lib/x86_64-linux-gnu /usr/lib64 /lib64 /usr/lib /usr/local/lib; do
        if [ -n "$dir" ] && [ -e "$dir/libvulkan.so.1" ]; then
            IFS=$old_ifs
            return 0
        fi
    done
    IFS=$old_ifs
    return 1
}
if system_loader; then
    echo "run.sh: Vulkan loader: the system's"
elif [ -f "$KIT/lib/libvulkan.so.1" ]; then
    export LD_LIBRARY_PATH="$KIT/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    echo "run.sh: Vulkan loader: the kit's ($KIT/lib/libvulkan.so.1; the system has none)"
else
    die "no Vulkan loader (libvulkan.so.1) on this system or in $KIT/lib"
fi
# The drivers the loader will find (their manifests), for the record.
ICDS=
for dir in /etc/vulkan/icd.d /usr/share/vulkan/icd.d /usr/local/share/vulkan/icd.d "${HOME:-/nonexistent}/.local/share/vulkan/icd.d"; do
    for file in "$dir"/*.json; do
        [ -f "$file" ] && ICDS="$ICDS ${file##*/}"
    done
done
if [ -n "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ]; then
    echo "run.sh: Vulkan drivers: ${VK_DRIVER_FILES:-$VK_ICD_FILENAMES} (VK_DRIVER_FILES / VK_ICD_FILENAMES)"
elif [ -n "$ICDS" ]; then
    echo "run.sh: Vulkan drivers:$ICDS"
else
    echo "run.sh: warning: no Vulkan driver manifest (icd.d/*.json) found; the GPU's Vulkan driver is needed (README.md)" >&2
fi

# The kit's binaries start here (a C library older than the build machine's stops them).
if ! version=$("$NIMBUS" --version 2>&1); then
    die "$NIMBUS does not start here: $version"
fi

mkdir -p "$OUT/logs" || die "cannot create $OUT/logs"
OUT=$(cd "$OUT" && pwd) || die "cannot enter $OUT"
# Cumulus shapes are generated on the first run that needs them and cached.
export NIMBUS_CACHE_DIR="${NIMBUS_CACHE_DIR:-$OUT/cache}"

# ---------------------------------------------------------------- runs

runs=0
for size in $SIZES; do
    for name in $SCENES; do
        runs=$((runs + 1))
    done
done
echo "run.sh: $version; $runs runs of $FRAMES frames on the $ADAPTER adapter, at most ${RUN_TIMEOUT_S} s each and ${BUDGET_S} s in all; results in $OUT"

START=$(date +%s)
DEADLINE=$((START + BUDGET_S))
FAILED=
NO_GPU=
run=0

# The error line of a run's log: its last "…: error: …" line, else its last line.
error_line() {
    found=
    last=
    while IFS= read -r line; do
        [ -n "$line" ] || continue
        last=$line
        case $line in
        *": error: "*) found=$line ;;
        esac
    done <"$1"
    echo "${found:-${last:-no output}}"
}

for size in $SIZES; do
    w=${size%%x*}
    h=${size#*x}
    for name in $SCENES; do
        run=$((run + 1))
        base=$name-${w}x$h
        json=$OUT/$base.json
        log=$OUT/logs/$base.log
        rm -f "$json" "$json.part"
        now=$(date +%s)
        left=$((DEADLINE - now))
        if [ "$left" -lt 5 ]; then
            echo "skipped: the set's budget of $BUDGET_S s was spent" >"$log"
            echo "[$run/$runs] $name ${w}×$h: SKIPPED (budget of $BUDGET_S s spent)"
            FAILED="$FAILED $base"
            continue
        fi
        limit=$RUN_TIMEOUT_S
        [ "$left" -lt "$limit" ] && limit=$left
        case $name in
        embed_world)
            set -- "$EMBED" "$OUT/$base.png" --width "$w" --height "$h" \
                --timings "$FRAMES" --adapter "$ADAPTER" --json -
            ;;
        default)
            set -- "$NIMBUS" bench --frames "$FRAMES" --width "$w" --height "$h" \
                --adapter "$ADAPTER" --json
            ;;
        *)
            set -- "$NIMBUS" bench "$KIT/scenes/$name.toml" --frames "$FRAMES" \
                --width "$w" --height "$h" --adapter "$ADAPTER" --json
            ;;
        esac
        printf '[%s/%s] %s %s×%s: ' "$run" "$runs" "$name" "$w" "$h"
        timeout -k 10 "$limit" "$@" >"$json.part" 2>"$log"
        status=$?
        took=$(($(date +%s) - now))
        if [ "$status" -eq 0 ] && [ -s "$json.part" ]; then
            mv "$json.part" "$json"
            echo "ok, ${took} s"
        else
            rm -f "$json.part"
            case $status in
            124 | 137) why="timed out after $limit s" ;;
            0) why="no report on standard output" ;;
            *) why="exit status $status: $(error_line "$log")" ;;
            esac
            echo "$why" >>"$log"
            echo "FAILED ($why; log: $log)"
            FAILED="$FAILED $base"
            case $why in
            *"no hardware GPU adapter found"*) NO_GPU=1 ;;
            esac
        fi
    done
done

# ---------------------------------------------------------------- table

set --
for size in $SIZES; do
    w=${size%%x*}
    h=${size#*x}
    for name in $SCENES; do
        [ -f "$OUT/$name-${w}x$h.json" ] && set -- "$@" "$OUT/$name-${w}x$h.json"
    done
done
status=0
if [ $# -gt 0 ]; then
    gpu=
    if command -v nvidia-smi >/dev/null 2>&1; then
        gpu=$(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null | tail -n 1)
    fi
    commit=unknown
    [ -f "$KIT/COMMIT" ] && commit=$(tail -n 1 "$KIT/COMMIT")
    if "$NIMBUS" bench table "$@" >"$OUT/table.md.part" 2>"$OUT/logs/table.log"; then
        {
            echo "$(date -u +%Y-%m-%d), nimbus $commit ($version), tools/gpu-bench/run.sh:" \
                "$FRAMES measured frames per run after one warm-up, adapter $ADAPTER${gpu:+, nvidia-smi: $gpu}."
            echo
            cat "$OUT/table.md.part"
        } >"$OUT/table.md"
        rm -f "$OUT/table.md.part"
        echo
        cat "$OUT/table.md"
        echo
        echo "run.sh: wrote $OUT/table.md and $# reports ($OUT/*.json)"
    else
        rm -f "$OUT/table.md.part"
        echo "run.sh: error: the table failed: $(error_line "$OUT/logs/table.log")" >&2
        status=1
    fi
else
    echo "run.sh: error: no run succeeded, no table" >&2
    status=1
fi
echo "run.sh: $(($(date +%s) - START)) s in all"
if [ -n "$FAILED" ]; then
    echo "run.sh: error: failed or skipped:$FAILED (logs in $OUT/logs/)" >&2
    status=1
fi
if [ -n "$NO_GPU" ]; then
    echo "run.sh: Vulkan sees no GPU here: install the GPU's Vulkan driver (NVIDIA: its ICD, nvidia_icd.json); in a container, NVIDIA_DRIVER_CAPABILITIES must include graphics (README.md)" >&2
fi
exit $status
