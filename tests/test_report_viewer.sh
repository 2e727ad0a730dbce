#!/usr/bin/env bash
# tests/test_report_viewer.sh TANDEM: `tandem eval --report` on a small run (dynamic.gltf: a
# moving cube and a moving camera), then the report you can watch in headless Chromium
# (tests/browser/report_viewer.js, puppeteer-core from scripts/install-deps.sh).
set -u
T="$1"
SRC="$(cd "$(dirname "$0")/.." && pwd)"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ ! -d "$SRC/tests/browser/node_modules/puppeteer-core" ]; then
    echo "FAIL puppeteer-core is not installed (scripts/install-deps.sh runs npm ci in tests/browser)"
    exit 1
fi
S="$SRC/data/scenes/dynamic.gltf"
"$T" render --frontend vk --scene "$S" --frames 8 --size 96x54 --capture --out "$tmp/run" \
    --quiet || exit 1
"$T" reference --scene "$S" --frames 8 --size 96x54 --spp 16 --out "$tmp/ref" --quiet || exit 1
"$T" eval --out "$tmp/run" --reference "$tmp/ref" --report "$tmp/report" >/dev/null 2>&1 || exit 1
n=$(ls "$tmp/report/frames" | grep -c '^f[0-9]*\.js$')
[ "$n" -eq 8 ] || { echo "FAIL the report holds $n frame files, not 8"; exit 1; }
echo "ok   the report holds every frame (8) and its FLIP maps"
node "$SRC/tests/browser/report_viewer.js" "$tmp/report" "${TND_VIEWER_SHOT:-}"
