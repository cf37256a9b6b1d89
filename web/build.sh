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
rm -rf "$out"
mv "$tmp" "$out"
echo "web viewer: $out ($(gzip -9 -c "$out/viewer/exploremaps_bg.wasm" | wc -c) bytes of wasm gzipped)"
