#!/usr/bin/env bash
# Installs a Vulkan loader and Mesa's software Vulkan driver (lavapipe) for
# machines without a GPU, the one the tests and CI render on.
#
# Mesa older than 24 (Debian 12's own 22.3) leaks tens of megabytes of memory
# every frame and runs nimbus's passes 2-9x slower, so on Debian 12 the driver
# comes from bookworm-backports (Mesa 25): the backports suite is added to the
# system's existing Debian APT source, whichever mirror that source names.
# Elsewhere the distribution's own mesa-vulkan-drivers is installed.
#
# Idempotent: does nothing when a Mesa of version 24 or newer is installed.
# Run as root (or with sudo available).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

installed_mesa_version() {
    dpkg-query -W -f='${Status} ${Version}\n' mesa-vulkan-drivers 2>/dev/null |
        awk '$3 == "installed" { print $4 }' || true
}

mesa_major() {
    # "25.0.7-2~bpo12+1" -> 25 ; "" -> 0
    local version="${1:-}"
    version="${version#*:}"
    echo "${version%%.*}" | grep -E '^[0-9]+$' || echo 0
}

codename=""
if [ -r /etc/os-release ]; then
    codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
fi

have=$(installed_mesa_version)
if [ "$(mesa_major "$have")" -ge 24 ] && ldconfig -p | grep -q 'libvulkan\.so\.1'; then
    echo "software-vulkan: Mesa $have already installed"
    exit 0
fi

# Adds `bookworm-backports` to the system's Debian source: in a deb822
# `.sources` file, to the Suites line of the stanza that lists `bookworm`;
# in a one-line sources.list, as a copy of the `bookworm` line. The mirror
# stays the one the system already uses.
add_backports_suite() {
    local suite="$1-backports" file
    if grep -rqsE "(^|\s)$suite(\s|$)" /etc/apt/sources.list /etc/apt/sources.list.d/; then
        return 0
    fi
    for file in /etc/apt/sources.list.d/*.sources; do
        [ -f "$file" ] || continue
        if grep -qE "^Suites:.*(\s)$1(\s|$)" "$file"; then
            $SUDO sed -i -E "s/^(Suites:.*(\s)$1(\s.*)?)$/\1 $suite/" "$file"
            echo "software-vulkan: added $suite to $file"
            return 0
        fi
    done
    for file in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
        [ -f "$file" ] || continue
        local line
        line=$(grep -E "^deb\s+(\[[^]]*\]\s+)?\S+\s+$1\s" "$file" | head -n 1 || true)
        if [ -n "$line" ]; then
            echo "$line" | sed -E "s/^(deb\s+(\[[^]]*\]\s+)?\S+\s+)$1(\s)/\1$suite\3/" |
                $SUDO tee -a "$file" >/dev/null
            echo "software-vulkan: added $suite to $file"
            return 0
        fi
    done
    echo "software-vulkan: no Debian '$1' APT source found to add $suite to" >&2
    return 1
}

export DEBIAN_FRONTEND=noninteractive
target=()
if [ "$codename" = "bookworm" ]; then
    add_backports_suite bookworm
    target=(-t bookworm-backports)
fi
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${target[@]}" \
    mesa-vulkan-drivers libvulkan1 >/dev/null
echo "software-vulkan: Mesa $(installed_mesa_version) (mesa-vulkan-drivers)"
