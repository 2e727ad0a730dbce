#!/bin/bash
# tests/test_install.sh BUILD TANDEM [SANITIZE_FLAGS]: libtandem as users get it. Installs the
# build under a temporary prefix (cmake --install, what `make install PREFIX=` runs), copies
# tests/install/ outside the source tree, builds its program twice against the installed files
# (pkg-config and the shared library; CMake's find_package and the static library), feeds both a
# capture, and checks their frames equal `tandem denoise --denoiser svgf` bit for bit (idiff
# with every threshold 0). SANITIZE_FLAGS: the build's sanitizer flags, which a program linked
# to a sanitized library needs too.
set -euo pipefail
BUILD=$1 TANDEM=$2 SAN=${3:-}
SRC=$(cd "$(dirname "$0")/.." && pwd)
TMP=$(mktemp -d /tmp/tandem_install.XXXXXX)
trap 'rm -rf "$TMP"' EXIT
pass=0 failn=0
ok() { echo "ok   $1"; pass=$((pass + 1)); }
bad() { echo "FAIL $1"; failn=$((failn + 1)); }

cmake --install "$BUILD" --prefix "$TMP/prefix" > "$TMP/install.log"
for f in include/tandem/tandem.h include/tandem/tandem_plugin.h include/tandem/run/run.h \
         include/tandem/eval/eval.h lib/libtandem.a \
         lib/libtandem.so lib/pkgconfig/tandem.pc lib/cmake/Tandem/TandemConfig.cmake bin/tandem; do
    [ -e "$TMP/prefix/$f" ] && ok "installed $f" || bad "installed $f"
done

# a capture, and what tandem denoise makes of it
"$TANDEM" render --scene "$SRC/data/scenes/dynamic.gltf" --frontend embree --denoiser off \
    --frames 4 --size 64x40 --capture --out "$TMP/run" --quiet
"$TANDEM" denoise --captures "$TMP/run" --denoiser svgf --out "$TMP/expected" --quiet

mkdir "$TMP/consumer"
cp "$SRC/tests/install/denoise_capture.c" "$SRC/tests/install/sequence.c" \
    "$SRC/tests/install/CMakeLists.txt" "$TMP/consumer/"
cd "$TMP/consumer"

# 1. pkg-config, the shared library
export PKG_CONFIG_PATH="$TMP/prefix/lib/pkgconfig"
cc -std=c11 -Wall -Werror $SAN denoise_capture.c $(pkg-config --cflags --libs tandem) \
    -o denoise_pc
LD_LIBRARY_PATH="$TMP/prefix/lib" ./denoise_pc "$TMP/run" "$TMP/out_pc"
# (ldd's list kept first: grep -q closing the pipe early fails ldd with SIGPIPE, and pipefail the
# check, now and then)
libs_pc=$(LD_LIBRARY_PATH="$TMP/prefix/lib" ldd ./denoise_pc)
if grep -q "$TMP/prefix/lib/libtandem.so" <<<"$libs_pc"
then ok "pkg-config: linked to the installed libtandem.so"
else bad "pkg-config: not linked to the installed libtandem.so"; fi

# 2. CMake's find_package, the static library
cmake -S . -B build -DCMAKE_PREFIX_PATH="$TMP/prefix" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_C_FLAGS="$SAN" -DCMAKE_EXE_LINKER_FLAGS="$SAN" > cmake.log
cmake --build build > build.log
./build/denoise_capture "$TMP/run" "$TMP/out_cmake"
[ -x ./build/sequence ] && ok "CMake: docs/library.md's program built" || bad "CMake: sequence"
libs_cmake=$(ldd ./build/denoise_capture)
if grep -q libtandem <<<"$libs_cmake"; then bad "CMake: static (no libtandem.so)"
else ok "CMake: Tandem::tandem_static linked in"; fi

for i in 0 1 2 3; do
    f=frame_000$i.exr
    for v in pc cmake; do
        if idiff -q -fail 0 -failpercent 0 -warn 0 -warnpercent 0 \
               "$TMP/expected/$f" "$TMP/out_$v/$f" > /dev/null; then
            ok "$v: $f equals tandem denoise's"
        else
            bad "$v: $f differs from tandem denoise's"
        fi
    done
done
# docs/library.md's program through the run layer (pkg-config, the shared library): a sequence,
# its matched reference and the evaluation, against what the command line makes of the same
cc -std=c11 -Wall -Werror $SAN sequence.c $(pkg-config --cflags --libs tandem) -o sequence_pc
LD_LIBRARY_PATH="$TMP/prefix/lib" ./sequence_pc "$SRC/data/scenes/dynamic.gltf" "$TMP/seq" \
    > "$TMP/seq.out"
"$TANDEM" render --scene "$SRC/data/scenes/dynamic.gltf" --frontend embree --denoiser svgf \
    --frames 4 --size 64x40 --out "$TMP/seq_cli/run" --quiet
"$TANDEM" reference --scene "$SRC/data/scenes/dynamic.gltf" --frontend embree \
    --estimator realtime --spp 32 --frames 4 --size 64x40 --out "$TMP/seq_cli/matched" --quiet
"$TANDEM" eval --out "$TMP/seq_cli/run" --matched-reference "$TMP/seq_cli/matched" \
    --metrics-on cpu --json > "$TMP/seq_cli.json"
same=1
for i in 0 1 2 3; do
    for d in run matched; do
        idiff -q -fail 0 -failpercent 0 -warn 0 -warnpercent 0 "$TMP/seq_cli/$d/frame_000$i.exr" \
            "$TMP/seq/$d/frame_000$i.exr" > /dev/null || same=0
    done
done
[ $same -eq 1 ] && ok "sequence: the run and its matched reference equal the command line's" ||
    bad "sequence: frames differ from the command line's"
if /usr/bin/python3 - "$TMP/seq.out" "$TMP/seq_cli.json" <<'PYEOF'
import json, sys
line = open(sys.argv[1]).read().split()  # "4 frames: relMSE X, FLIP Y"
d = json.load(open(sys.argv[2]))[0]
assert line[0] == "4" and float(line[3].rstrip(",")) == float("%.6g" % d["relmse"]), (line, d)
assert float(line[5]) == float("%.6g" % d["flip"]), (line, d)
PYEOF
then ok "sequence: its evaluation is tandem eval's to the digits it prints"
else bad "sequence: its evaluation differs from tandem eval's"; fi

# 3. the Python package where make install puts it (not under the sanitizers: Debian's Python
# is not built with them), and the installed command finding its Python bridge there
if [ -z "$SAN" ]; then
    PY="$TMP/prefix/lib/python3/dist-packages"
    for f in __init__.py _host.py libtandem_api.so libtandem_pybridge.so tandem_api.h; do
        [ -e "$PY/tandem/$f" ] && ok "installed python package: $f" || bad "installed $f"
    done
    if PYTHONPATH="$PY" /usr/bin/python3 - "$TMP/run/capture/frame_0000.exr" <<'PYEOF'
import sys, tandem
c = tandem.read_capture(sys.argv[1])
assert tandem.__file__.startswith(sys.argv[1].split("/run/")[0] + "/prefix/"), tandem.__file__
assert c.present("albedo") and c["depth"].shape == (40, 64, 1)
PYEOF
    then ok "python: the installed package reads a capture"; else bad "python: installed package"; fi
    if PYTHONPATH="$SRC/tests/python" "$TMP/prefix/bin/tandem" render --scene \
           "$SRC/data/scenes/dynamic.gltf" --frontend embree --denoiser python:denoisers:Ema \
           --frames 2 --size 64x40 --out "$TMP/py" --quiet && [ -e "$TMP/py/frame_0001.exr" ]
    then ok "python: the installed tandem runs python:denoisers:Ema"
    else bad "python: the installed tandem and python:denoisers:Ema"; fi
fi
echo "$pass passed, $failn failed"
[ "$failn" -eq 0 ]
