#!/usr/bin/env bash
# Runs every fuzz target (or those named) for SECONDS each or 10 million
# executions, whichever comes first, one after the other, and prints
# executions and crashes per target.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      (default 60 s, all targets)
# Needs the nightly toolchain and cargo-fuzz (installed here when missing).
# New inputs go to fuzz/corpus/TARGET, crashes to fuzz/artifacts/TARGET; the
# committed seeds are in fuzz/seeds/TARGET. No sanitizer: the code under test
# is safe Rust (but for meshoptimizer's C++ decoders of glTF's meshopt
# compression, which are not instrumented here), and panics, hangs (10 s an input) and memory over 2 GiB are
# what is looked for; debug assertions are on, so overflows panic too.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(obj gltf ply graph mp4 request proxy pointtogo splits)

rustup toolchain list | grep -q nightly || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null || cargo +nightly install cargo-fuzz --locked
# Reuse the Embree library the main build fetched, if any.
if [ -z "${EMBREE_DIR:-}" ]; then
  lib="$(find target -name libembree4.so -path '*out/embree*' 2>/dev/null | head -1 || true)"
  [ -n "$lib" ] && export EMBREE_DIR="$(cd "$(dirname "$lib")" && pwd)"
fi
flags=(-s none -a -O)
echo "fuzz: building the targets"
cargo +nightly fuzz build "${flags[@]}"
report=()
for t in "${targets[@]}"; do
  mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
  log="fuzz/artifacts/$t/last-run.log"
  echo "fuzz: $t for ${seconds} s"
  cargo +nightly fuzz run "${flags[@]}" "$t" "fuzz/corpus/$t" "fuzz/seeds/$t" -- \
    -max_total_time="$seconds" -runs="${RUNS:-10000000}" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 >"$log" 2>&1 || true
  runs="$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)"
  crashes="$(find "fuzz/artifacts/$t" -type f \( -name 'crash-*' -o -name 'oom-*' -o -name 'timeout-*' -o -name 'slow-unit-*' \) | wc -l)"
  peak="$(grep -o 'stat::peak_rss_mb: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')"
  report+=("$(printf '%-8s %12s executions  %3s crashes  peak %s MB' "$t" "$runs" "$crashes" "$peak")")
  [ "$crashes" -eq 0 ] || grep -m3 -E "panicked|ERROR: libFuzzer" "$log" | sed 's/^/    /'
done
printf '%s\n' "${report[@]}"
