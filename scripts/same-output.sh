#!/usr/bin/env bash
# Checks that two builds of `exploremaps` write the same bundles from the same
# seed: for a restructuring that must not change behaviour. Plans three
# built-in scenes and builds one at preview quality with each binary, then
# compares the folders byte for byte (apart from timings.json, which holds only
# times, and the copied web viewer). Exit 0 when every file matches.
#
#   scripts/same-output.sh OLD_BINARY NEW_BINARY [WORK_DIR]
#
# Keep a copy of the old binary before changing the code, e.g.
#   cp target/release/exploremaps /tmp/exploremaps-before
# OLD_BINARY may instead be the `old` folder of an earlier run, to compare
# against its outputs without making them again. NEW_ARGS: more arguments for
# the new binary's build, e.g. NEW_ARGS="--transitions video" against a
# binary from before glides were the default.
set -euo pipefail

if [ $# -lt 2 ]; then
  echo "usage: $0 OLD_BINARY NEW_BINARY [WORK_DIR]" >&2
  exit 2
fi
old=$1
new=$2
work=${3:-target/same-output}
sides="old new"
if [ -d "$old" ]; then
  sides=new
else
  [ -x "$old" ] || { echo "$old: not an executable or an earlier run's old folder; build it first (cargo build --release)" >&2; exit 2; }
fi
[ -x "$new" ] || { echo "$new: not an executable; build it first (cargo build --release)" >&2; exit 2; }

rm -rf "$work/new"
[ "$sides" = new ] || rm -rf "$work/old"
mkdir -p "$work"
status=0
for side in $sides; do
  bin=$old
  [ "$side" = new ] && bin=$new
  for scene in gallery pillars island; do
    "$bin" -q --seed 7 plan "$scene" -o "$work/$side/plan-$scene" >/dev/null
  done
  # Fewer threads for one side: bundles must not depend on the thread count either.
  threads=2
  extra=()
  if [ "$side" = new ]; then
    threads=1
    read -r -a extra <<< "${NEW_ARGS:-}"
  fi
  "$bin" -q --seed 7 --threads "$threads" build house --quality preview -o "$work/$side/house" "${extra[@]}" >/dev/null 2>&1
done

old_dir="$work/old"
[ -d "$old" ] && old_dir=$old
if diff -r -q --exclude=timings.json --exclude=index.html --exclude=viewer "$old_dir" "$work/new"; then
  echo "same output: $(find "$work/new" -type f ! -name timings.json ! -name index.html ! -path "*/viewer/*" | wc -l) files identical"
else
  echo "the outputs differ (above); inspect $old_dir and $work/new" >&2
  status=1
fi
exit $status
