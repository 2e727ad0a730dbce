#!/usr/bin/env bash
# Collect the built binaries and the shared libraries they need (all but glibc's) into .gpu/, so
# that they run on a machine that has a GPU driver but none of our Debian packages (the GPU
# machine of docs/performance.md). Also bundles the Khronos validation layer.
#
#   scripts/gpu-bundle.sh [--no-validation] [BUILD_DIR]  -> .gpu/bin, lib, layers, env.sh
# On the GPU machine:  . .gpu/env.sh && tandem info
# The device tool carries at most 64 MiB: Embree is 42 MiB and the validation layer 22 MiB, so
# performance runs leave the layer out (--no-validation).
set -euo pipefail
cd "$(dirname "$0")/.."
VALIDATION=1
if [ "${1:-}" = "--no-validation" ]; then VALIDATION=0; shift; fi
B=${1:-build}
rm -rf .gpu
mkdir -p .gpu/bin .gpu/lib .gpu/layers
bins=("$B/tandem")
for t in "$B"/tests/test_*; do [ -x "$t" ] && [ -f "$t" ] && bins+=("$t"); done
cp "${bins[@]}" .gpu/bin/
cp tests/*.sh .gpu/bin/ 2>/dev/null || true
mkdir -p .gpu/plugins
cp "$B"/plugins/*.so .gpu/plugins/ 2>/dev/null || true
skip='^(libc|libm|libpthread|libdl|librt|ld-linux.*|libgcc_s|libstdc\+\+)\.so'
LAYER=/usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so
[ "$VALIDATION" -eq 1 ] || LAYER=
for f in "${bins[@]}" $LAYER; do
    ldd "$f" | awk '/=> \//{print $1, $3}' | while read -r name path; do
        [[ "$name" =~ $skip ]] || cp -L "$path" .gpu/lib/
    done
done
if [ -n "$LAYER" ] && [ -f "$LAYER" ]; then
    cp /usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so .gpu/layers/
    sed 's#"library_path": *"[^"]*"#"library_path": "./libVkLayer_khronos_validation.so"#' \
        /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json \
        >.gpu/layers/VkLayer_khronos_validation.json
fi
cat >.gpu/env.sh <<'ENV'
# Source from the repository root on the GPU machine.
G=$(pwd)/.gpu
export PATH=$G/bin:$PATH LD_LIBRARY_PATH=$G/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export VK_LAYER_PATH=$G/layers
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
ENV
du -sh .gpu
