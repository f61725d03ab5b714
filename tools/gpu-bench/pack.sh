#!/bin/sh
# Builds the GPU benchmark kit on this machine (see README.md beside this
# script): the release `nimbus` binary and the embedding example, the
# benchmark scenes, this machine's Vulkan loader and run.sh, in one folder
# (tools/gpu-bench/kit/ by default, ignored by git) and a tarball of it.
#
#   tools/gpu-bench/pack.sh [KIT_DIR]
#
# Needs what building nimbus needs (Rust, cargo; crates already fetched or
# the network) and a Vulkan loader installed here (libvulkan1), which the
# kit carries for GPU machines without one.

set -eu

HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
KIT=${1:-$HERE/kit}
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
case $TARGET in
/*) ;;
*) TARGET=$ROOT/$TARGET ;;
esac

die() {
    echo "pack.sh: error: $*" >&2
    exit 1
}

# The scenes the set runs (the default scene is embedded in the binary).
SCENES="cumulus-bench rain-bench rain-bench-5m rain-bench-10m"
for file in "$ROOT"/scenes/stratus-*.toml; do
    name=${file##*/}
    SCENES="$SCENES ${name%.toml}"
done

# This machine's Vulkan loader (the x86-64 one), before the long build.
LOADER=$(ldconfig -p 2>/dev/null | while read -r lib arch _ path; do
    if [ "$lib" = libvulkan.so.1 ]; then
        case $arch in *x86-64*) echo "$path" && break ;; esac
    fi
done)
[ -n "$LOADER" ] || LOADER=$(/sbin/ldconfig -p 2>/dev/null | while read -r lib arch _ path; do
    if [ "$lib" = libvulkan.so.1 ]; then
        case $arch in *x86-64*) echo "$path" && break ;; esac
    fi
done)
[ -n "$LOADER" ] && [ -f "$LOADER" ] ||
    die "no Vulkan loader here (ldconfig -p lists no libvulkan.so.1); install it (Debian/Ubuntu: apt-get install libvulkan1)"

echo "pack.sh: building (release; this takes a while)"
# By target, not package: the `nimbus` binary and nimbus-render's example.
(cd "$ROOT" && cargo build --release --locked --bin nimbus --example embed_world)

rm -rf "$KIT"
mkdir -p "$KIT/bin" "$KIT/lib" "$KIT/scenes"
cp "$TARGET/release/nimbus" "$TARGET/release/examples/embed_world" "$KIT/bin/"
# Symbols are not needed to run: a smaller kit.
if command -v strip >/dev/null 2>&1; then
    strip "$KIT/bin/nimbus" "$KIT/bin/embed_world"
fi
cp -L "$LOADER" "$KIT/lib/libvulkan.so.1"
for name in $SCENES; do
    cp "$ROOT/scenes/$name.toml" "$KIT/scenes/"
done
cp "$HERE/run.sh" "$HERE/README.md" "$KIT/"
chmod +x "$KIT/run.sh"

# What was built, for the table's caption.
commit=$(cd "$ROOT" && git rev-parse --short=12 HEAD 2>/dev/null) || commit=unknown
if [ "$commit" != unknown ] && [ -n "$(cd "$ROOT" && git status --porcelain --untracked-files=no 2>/dev/null)" ]; then
    commit="$commit-modified"
fi
echo "$commit" >"$KIT/COMMIT"
{
    echo "commit: $commit"
    echo "built: $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(uname -m)"
    echo "C library: $(ldd --version 2>/dev/null | head -n 1)"
    echo "Vulkan loader: $LOADER"
} >"$KIT/BUILD-INFO"

# The binaries' checks that need no GPU: they start, and every scene is valid.
"$KIT/bin/nimbus" --version >/dev/null
check=$("$KIT/bin/nimbus" scene --check "$KIT"/scenes/*.toml 2>&1) ||
    die "a scene of the kit is not valid: $check"

TARBALL=$(dirname "$KIT")/$(basename "$KIT").tar.gz
tar czf "$TARBALL" -C "$(dirname "$KIT")" "$(basename "$KIT")"
echo "pack.sh: kit in $KIT ($(du -sh "$KIT" | cut -f1)), tarball $TARBALL ($(du -h "$TARBALL" | cut -f1))"
echo "pack.sh: on the GPU machine: tar xzf $(basename "$TARBALL") && $(basename "$KIT")/run.sh"
