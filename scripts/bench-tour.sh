#!/usr/bin/env bash
# The tour export's benchmark (issue 17): a rendered bundle exported for
# Pannellum, Marzipano and Photo Sphere Viewer (libraries from target/node,
# which scripts/setup.sh fills), each opened cold in headless Chromium
# (SwiftShader WebGL, 1280x720) at its first view and then zoomed in to
# FOV radians (default 0.35): bytes fetched and the time until the last tile
# the view needs has arrived, served on localhost and at 10 Mbit/s; then our
# web viewer on the bundle itself (the copy `render` put in it), at its first
# view and opened zoomed to 20°.
# Usage: scripts/bench-tour.sh BUNDLE   (render it with --quality tour for 4096 faces)
set -euo pipefail
cd "$(dirname "$0")/.."
bundle="${1:?usage: scripts/bench-tour.sh BUNDLE}"
cargo build --quiet --release
exe=target/release/exploremaps
out=target/bench-tour
rm -rf "$out" && mkdir -p "$out"
/usr/bin/time -f "export: %e s, peak memory %M KiB" "$exe" export "$bundle" "$out/tour" --library target/node/node_modules
"$exe" -q serve "$out/tour" --address 127.0.0.1:0 > "$out/serve.log" &
server=$!
trap 'kill $server 2>/dev/null' EXIT
for _ in $(seq 50); do grep -q http "$out/serve.log" && break; sleep 0.1; done
url=$(grep -o 'http://[^ ]*' "$out/serve.log")
# Our viewer on the bundle itself.
web/build.sh >/dev/null
EXPLOREMAPS_WEB_DIR="$PWD/target/web-viewer" "$exe" -q serve "$bundle" --address 127.0.0.1:0 > "$out/serve2.log" &
server2=$!
trap 'kill $server $server2 2>/dev/null' EXIT
for _ in $(seq 50); do grep -q http "$out/serve2.log" && break; sleep 0.1; done
url2=$(grep -o 'http://[^ ]*' "$out/serve2.log")
for throttle in 0 1; do
  if [ $throttle = 1 ]; then echo "== 10 Mbit/s, 20 ms latency"; else echo "== localhost"; fi
  BENCH=1 THROTTLE=$throttle PLAYWRIGHT_CORE="$PWD/target/node/node_modules/playwright-core/index.mjs" \
    node tests/browser/tour.mjs "${url%/}" "$out" pannellum marzipano psv | node -e '
    const lines = require("fs").readFileSync(0, "utf8").trim().split("\n").map(JSON.parse);
    for (const l of lines) {
      if (l.step === "sharp") console.log(`${l.viewer.padEnd(10)} ${l.view.padEnd(20)} sharp after ${String(l.ms).padStart(6)} ms, ${(l.bytes / 1e6).toFixed(2).padStart(6)} MB (${l.tiles} tiles, ${(l.tile_bytes / 1e6).toFixed(2)} MB)${l.fov ? `, fov ${l.fov.toFixed(2)}` : ""}`);
      else console.log(JSON.stringify(l));
    }'
  echo "ours (web viewer, its desktop texture budget: faces up to 2048)"
  THROTTLE=$throttle PLAYWRIGHT_CORE="$PWD/target/node/node_modules/playwright-core/index.mjs" \
    node tests/browser/viewer.mjs tiles_bench "$url2" "$out" | node -e '
    const lines = require("fs").readFileSync(0, "utf8").trim().split("\n").map(JSON.parse);
    for (const l of lines) {
      if (l.step === "sharp") console.log(`ours       ${l.view.padEnd(20)} sharp after ${String(l.ms).padStart(6)} ms, ${(l.bytes / 1e6).toFixed(2).padStart(6)} MB (${l.tiles} tiles, ${(l.tile_bytes / 1e6).toFixed(2)} MB), first panorama at ${Math.round(l.first_panorama_ms)} ms`);
      else console.log(JSON.stringify(l));
    }'
done
