#!/usr/bin/env bash
# scripts/compile-shaders.sh OUTDIR [SRCDIR [NAME...]]: compile Tandem's shaders from GLSL
# sources (default: shaders/ of this checkout) into OUTDIR/<name>.spv with the flags the build
# uses (shaders/CMakeLists.txt), for $TANDEM_SHADER_DIR: a process started with it uses them
# instead of the embedded code, and `tandem view` reads them again on F5. NAMEs (entries of
# shaders/shader_list.h, e.g. dn_atrous_f32) limit it to those shaders.
#   scripts/compile-shaders.sh /tmp/spv && TANDEM_SHADER_DIR=/tmp/spv build/tandem view
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${1:?usage: compile-shaders.sh OUTDIR [SRCDIR [NAME...]]}
SRC=${2:-$ROOT/shaders}
shift $(( $# >= 2 ? 2 : 1 ))
mkdir -p "$OUT"
n=0
# the X(name, "file", "defines") rows of the list
while IFS='|' read -r name file defines; do
    if [ $# -gt 0 ]; then
        want=0
        for w in "$@"; do [ "$w" = "$name" ] && want=1; done
        [ $want -eq 1 ] || continue
    fi
    flags=()
    for d in $defines; do flags+=("-D$d"); done
    glslangValidator --target-env vulkan1.2 -DTND_GLSL=1 "${flags[@]}" -I"$SRC" \
        -o "$OUT/$name.spv.tmp" "$SRC/$file" > "$OUT/$name.log" 2>&1 ||
        { cat "$OUT/$name.log" >&2; rm -f "$OUT/$name.spv.tmp"; exit 1; }
    mv "$OUT/$name.spv.tmp" "$OUT/$name.spv"
    rm -f "$OUT/$name.log"
    n=$((n + 1))
done < <(sed -n 's/^ *X(\([a-z0-9_]*\), *"\([^"]*\)", *"\([^"]*\)").*/\1|\2|\3/p' \
             "$ROOT/shaders/shader_list.h")
echo "compile-shaders: $n shader(s) -> $OUT"
