#!/usr/bin/env bash
# Builds the web viewer into target/web-viewer (index.html + viewer/*.js, *.wasm),
# which `exploremaps build|render|serve` copy into bundles. Needs the
# wasm32-unknown-unknown target and wasm-bindgen-cli 0.2.130 (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --quiet -p exploremaps-web --target wasm32-unknown-unknown --profile web
out=target/web-viewer
tmp="$out.tmp"
rm -rf "$tmp"
mkdir -p "$tmp/viewer"
wasm-bindgen --target web --no-typescript --remove-name-section --remove-producers-section --out-dir "$tmp/viewer" --out-name exploremaps \
  target/wasm32-unknown-unknown/web/exploremaps_web.wasm
cp web/index.html "$tmp/index.html"
# File by file, and only what changed: renders running meanwhile (the test
# suite runs this beside them) copy these into bundles, and must never find
# the folder gone. Each rename is atomic.
mkdir -p "$out/viewer"
for f in index.html viewer/exploremaps.js viewer/exploremaps_bg.wasm; do
  cmp -s "$tmp/$f" "$out/$f" || mv -f "$tmp/$f" "$out/$f"
done
rm -rf "$tmp"
echo "web viewer: $out ($(gzip -9 -c "$out/viewer/exploremaps_bg.wasm" | wc -c) bytes of wasm gzipped)"
