#!/usr/bin/env bash
# Install what Tandem needs to build and test, from Debian packages only.
#
# Idempotent: packages already present are not touched, and apt is not called at all when nothing
# is missing. Uses sudo only when not root. On Debian 12 the distribution's Mesa (22.3) has no ray
# tracing in lavapipe, so when the installed (or installable) lavapipe lacks
# VK_KHR_ray_tracing_pipeline, bookworm-backports is added and mesa-vulkan-drivers comes from there.
set -euo pipefail

log() { printf 'install-deps: %s\n' "$*" >&2; }

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
        log "not root and no sudo: cannot install packages"; exit 1; fi
fi
export DEBIAN_FRONTEND=noninteractive
# --standard-suite: also the content `tandem rank standard` names (data/suites/standard.json's
# "package" members: real models, HDRIs and places from Debian; stellarium-data is a 246 MB
# download, so the test suite, which ranks the quick suite, does not need it).
STANDARD_SUITE=0
for a in "$@"; do
    case "$a" in
    --standard-suite) STANDARD_SUITE=1 ;;
    *) log "unknown option $a (expected --standard-suite)"; exit 2 ;;
    esac
done

# Build, Vulkan, libraries, and the independent tools the tests check our files with (blender:
# Cycles, the independent renderer tests/test_cycles.py compares the reference with;
# assimp-testmodels: real glTF and OBJ models nobody here wrote; blender-data: real HDRIs from
# HDRI Haven, CC0, in /usr/share/blender/datafiles/studiolights/world); GLFW for `tandem view`'s
# window, Xvfb for its tests on a machine without a display; clang and its runtime for
# libFuzzer, make fuzz; python3-dev, -cffi, -pytest, -torch: the Python package, its bridge
# for python: denoisers, its tests and the PyTorch example (docs/python.md); slurm-wlm and munge: a one-node Slurm cluster on localhost for
# tests/test_slurm.sh).
PKGS=(
    build-essential cmake pkg-config git
    libvulkan-dev glslang-tools vulkan-validationlayers vulkan-tools
    libembree-dev libtbb-dev libopenexr-dev libassimp-dev libcjson-dev libstb-dev
    libglfw3-dev xvfb xauth clang libclang-rt-dev
    openexr openimageio-tools python3 ffmpeg
    python3-numpy python3-openimageio chromium
    python3-dev python3-cffi python3-pytest python3-torch
    blender blender-data assimp-testmodels
    slurm-wlm munge
)

missing=()
for p in "${PKGS[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
        missing+=("$p")
    fi
done

apt_updated=0
apt_update() {
    if [ "$apt_updated" -eq 0 ]; then
        log "apt-get update"
        $SUDO apt-get update -qq
        apt_updated=1
    fi
}

if [ "${#missing[@]}" -gt 0 ]; then
    apt_update
    log "installing: ${missing[*]}"
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# lavapipe with ray tracing: Mesa >= 24.1.
mesa_ok() {
    local v
    v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
    [ -n "$v" ] && dpkg --compare-versions "$v" ge 24.1
}
if ! mesa_ok; then
    . /etc/os-release
    if [ "${ID:-}" = debian ] && [ "${VERSION_CODENAME:-}" = bookworm ]; then
        if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
            log "adding bookworm-backports (lavapipe with ray tracing)"
            echo 'deb http://deb.debian.org/debian bookworm-backports main' |
                $SUDO tee /etc/apt/sources.list.d/tandem-backports.list >/dev/null
            apt_updated=0
        fi
        apt_update
        log "installing mesa-vulkan-drivers from bookworm-backports"
        $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports mesa-vulkan-drivers
    else
        apt_update
        $SUDO apt-get install -y -qq --no-install-recommends mesa-vulkan-drivers
        mesa_ok || log "warning: mesa-vulkan-drivers < 24.1: lavapipe has no ray tracing here"
    fi
fi
# Browser tests of the HTML reports: Node.js and npm (Debian's, unless a node is already there),
# then puppeteer-core from npm at the version package-lock.json pins (it drives Debian's
# chromium; it downloads no browser).
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    apt_update
    log "installing nodejs npm"
    $SUDO apt-get install -y -qq --no-install-recommends nodejs npm
fi
here=$(cd "$(dirname "$0")/.." && pwd)
if [ ! -d "$here/tests/browser/node_modules/puppeteer-core" ]; then
    log "npm ci (tests/browser: puppeteer-core)"
    (cd "$here/tests/browser" && PUPPETEER_SKIP_DOWNLOAD=1 npm ci --no-audit --no-fund --silent)
fi
if [ "$STANDARD_SUITE" -eq 1 ]; then
    suite_pkgs=()
    for p in $(grep -o '"package": *"[^"]*"' "$here/data/suites/standard.json" | sed 's/.*"\([^"]*\)"$/\1/' | sort -u); do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || suite_pkgs+=("$p")
    done
    if [ "${#suite_pkgs[@]}" -gt 0 ]; then
        apt_update
        log "installing the standard suite's content: ${suite_pkgs[*]}"
        $SUDO apt-get install -y -qq --no-install-recommends "${suite_pkgs[@]}"
    fi
fi
log "all dependencies present"
