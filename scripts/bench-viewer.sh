#!/usr/bin/env bash
# The viewer's benchmark (issue 7): wasm size, time to first panorama, frame
# times in a probe and along a path, natively (lavapipe under Xvfb, 1280x720)
# and in headless Chromium (SwiftShader WebGL2, 1280x720, served on localhost),
# and peak memory; the dollhouse (issue 16): times from the page's start to
# its first and its full-resolution frame, on localhost and at 10 Mbit/s with
# 60 ms latency, frame times orbiting it. Usage: scripts/bench-viewer.sh [BUNDLE]
# (default: the gallery, rendered at preview quality into target/bench-viewer).
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
cargo build --quiet --release
web/build.sh
exe=target/release/exploremaps
bundle="${1:-target/bench-viewer/gallery}"
if [ ! -e "$bundle/graph.json" ]; then
  "$exe" -q build gallery -o "$bundle" --quality preview
fi
"$exe" -q render "$bundle" --quality preview >/dev/null   # adds the web viewer if missing

echo "== wasm"
echo "wasm: $(stat -c %s target/web-viewer/viewer/exploremaps_bg.wasm) bytes, $(gzip -9 -c target/web-viewer/viewer/exploremaps_bg.wasm | wc -c) gzipped (goal: at most 1 MB gzipped)"

echo "== native (lavapipe, Xvfb)"
xvfb-run -a -s "-screen 0 1280x720x24" /usr/bin/time -f "peak memory (resident): %M KiB" "$exe" -q view "$bundle" --benchmark

mkdir -p target/bench-viewer
"$exe" -q serve "$bundle" --address 127.0.0.1:0 > target/bench-viewer/serve.log &
server=$!
trap 'kill $server 2>/dev/null' EXIT
for _ in $(seq 50); do grep -q http target/bench-viewer/serve.log && break; sleep 0.1; done
url=$(grep -o 'http://[^ ]*' target/bench-viewer/serve.log)
for webgpu in 0 1; do
  if [ $webgpu = 1 ]; then echo "== web (headless Chromium, WebGPU on SwiftShader Vulkan)"; else echo "== web (headless Chromium, WebGL2 on SwiftShader)"; fi
  WEBGPU=$webgpu PLAYWRIGHT_CORE="$PWD/target/node/node_modules/playwright-core/index.mjs" node tests/browser/viewer.mjs bench "$url" target/bench-viewer | node -e '
  const lines = require("fs").readFileSync(0, "utf8").trim().split("\n").map(JSON.parse);
  const mean = (a) => a.reduce((x, y) => x + y, 0) / a.length;
  const stats = (a) => { const s = [...a].sort((x, y) => x - y);
    return `mean ${mean(a).toFixed(1)} ms, p95 ${s[Math.floor(s.length * 0.95)].toFixed(1)} ms over ${a.length} frames`; };
  let probe = NaN;
  for (const l of lines) {
    if (l.step === "first") console.log(`first panorama: ${Math.round(l.first_panorama_ms)} ms after navigation start (${l.backend}): wasm running at ${Math.round(l.wasm_ready_ms)}, graph at ${Math.round(l.graph_ms)}, GPU device at ${Math.round(l.device_ms)}, pipelines made at ${Math.round(l.app_ms)}, first cube decoded at ${Math.round(l.faces_ms)} ms`);
    else if (l.step === "probe") { probe = mean(l.frames_ms); console.log(`frame time in a probe at 1280x720: ${stats(l.frames_ms)}`); }
    else if (l.step === "transition") console.log(`frame time during a transition at 1280x720: ${stats(l.frames_ms)} (${(mean(l.frames_ms) / probe).toFixed(2)}× that in a probe; goal for a glide 1.5×); ${l.video_frames_per_s.toFixed(1)} video frames shown a second` + (l.first_glide_ms == null ? "" : `; a glide (${l.glide_frames} frames): its first frame ${Math.round(l.first_glide_ms)} ms after the key (goal 100)`));
    else if (l.step === "backward") console.log(`frame time travelling a path backwards: ${stats(l.frames_ms)}; ${l.video_frames_per_s.toFixed(1)} video frames shown a second`);
    else if (l.step === "memory") console.log(`JS heap: ${(l.js_heap_bytes / 1048576).toFixed(1)} MiB`);
    else console.log(JSON.stringify(l));
  }'
done


echo "== dollhouse (headless Chromium, WebGL2 on SwiftShader, opened at #dollhouse=1)"
for throttle in 0 1; do
  THROTTLE=$throttle PLAYWRIGHT_CORE="$PWD/target/node/node_modules/playwright-core/index.mjs" node tests/browser/viewer.mjs dollhouse_bench "$url" target/bench-viewer | THROTTLE=$throttle node -e '
  const lines = require("fs").readFileSync(0, "utf8").trim().split("\n").map(JSON.parse);
  const net = process.env.THROTTLE === "1" ? "10 Mbit/s, 60 ms" : "localhost";
  const stats = (a) => { const s = [...a].sort((x, y) => x - y); const mean = a.reduce((x, y) => x + y, 0) / a.length;
    return `mean ${mean.toFixed(1)} ms, p95 ${s[Math.floor(s.length * 0.95)].toFixed(1)} ms over ${a.length} frames`; };
  for (const l of lines) {
    if (l.step === "dollhouse") console.log(`${net}: graph at ${Math.round(l.t_graph)} ms; first dollhouse frame at ${Math.round(l.t_dollhouse_first)} ms (${Math.round(l.t_dollhouse_first - l.t_graph)} ms after the graph; goal 300), full proxy at ${Math.round(l.t_dollhouse_full)} ms (goal 1000 at 10 Mbit/s); decoding held the main thread ${l.proxy_decode_ms_1?.toFixed(1)} ms (coarse) and ${l.proxy_decode_ms_0?.toFixed(1)} ms (full)`);
    else if (l.step === "orbit") console.log(`${net}: frame time orbiting the dollhouse at 1280x720: ${stats(l.frames_ms)}`);
    else if (l.step === "memory") console.log(`${net}: JS heap in the dollhouse: ${(l.js_heap_bytes / 1048576).toFixed(1)} MiB`);
    else console.log(JSON.stringify(l));
  }'
done
