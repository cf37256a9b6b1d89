#!/usr/bin/env bash
# Renders a planned bundle on a Slurm cluster: a job array with one task per
# shard, then `render --finalize` once every task succeeded (afterok). The
# bundle folder must be on storage every node sees; logs go beside it
# (BUNDLE.logs/). Prints the two job ids.
#   deploy/slurm/render.sh BUNDLE SHARDS [render options...]
#   deploy/slurm/render.sh BUNDLE SHARDS --tasks 2,5 [render options...]   redo some shards
# EXPLOREMAPS names the program (default: exploremaps on PATH); SBATCH_* variables
# and SLURM options (partition, time limit) pass through to sbatch as usual.
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 BUNDLE SHARDS [--tasks LIST] [render options...]" >&2; exit 2; }
bundle="$(realpath "$1")"
shards="$2"
shift 2
tasks="0-$((shards - 1))"
if [ "${1:-}" = "--tasks" ]; then tasks="$2"; shift 2; fi
exe="$(realpath "${EXPLOREMAPS:-$(command -v exploremaps)}")"
[ -f "$bundle/graph.json" ] || { echo "$bundle has no graph.json; run \`exploremaps plan\` first" >&2; exit 2; }
logs="$bundle.logs"
mkdir -p "$logs"
# The task id is the shard (auto/N), so `--tasks 2` redoes shard 2 alone.
# `exec`: the task's process is exploremaps itself, so a cancel's signal reaches
# it directly and cannot leave it running orphaned behind an ended shell.
render="exec $(printf '%q ' "$exe" render "$bundle" --shard "auto/$shards" "$@")"
array=$(sbatch --parsable --array="$tasks" --job-name=exploremaps-render --output="$logs/render-%A_%a.log" --wrap "$render")
final=$(sbatch --parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes --job-name=exploremaps-finalize \
  --output="$logs/finalize-%j.log" --wrap "$(printf '%q ' "$exe" render "$bundle" --finalize)")
echo "render array $array (tasks $tasks of $shards shards), finalize $final; logs in $logs"
