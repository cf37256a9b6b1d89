#!/usr/bin/env python3
"""How a bundle's rendering divides over n machines, from one process's
timings (timings.json: the renderer's set-up, which every shard repeats, and
each job's time; job k goes to shard k mod n, as `render --shard` assigns).

    scripts/shard-projection.py BUNDLE [N ...]     (default n = 1 2 4 8 16 32 64)

Each machine is assumed as fast as the measuring one; start-up of the program,
scene loading and the scheduler's latency are left out."""
import json
import sys

if len(sys.argv) < 2:
    sys.exit(__doc__)
path = sys.argv[1].rstrip("/") + "/timings.json"
try:
    render = json.load(open(path))["render"]
    setup, jobs = render["seconds_setup"], render["seconds_jobs"]
except (OSError, ValueError, KeyError, TypeError) as e:
    sys.exit(f"{path}: no render timings ({e}); render the bundle in one process first")
counts = [int(n) for n in sys.argv[2:]] or [1, 2, 4, 8, 16, 32, 64]
total = sum(t for _, t in jobs)
one = setup + total
print(f"{len(jobs)} jobs, {total:.1f} s in all, the longest {max(t for _, t in jobs):.1f} s; set-up {setup:.1f} s per shard")
print("| machines | wall time s | speed-up | busiest shard's jobs s | set-up share |")
print("|---|---|---|---|---|")
for n in counts:
    shards = [0.0] * n
    for k, t in jobs:
        shards[k % n] += t
    wall = setup + max(shards)
    print(f"| {n} | {wall:.1f} | {one / wall:.1f}x | {max(shards):.1f} | {setup / wall:.0%} |")
