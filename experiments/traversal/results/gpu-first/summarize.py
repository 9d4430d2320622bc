#!/usr/bin/env python3
"""Per scene, ray family and method: the new/old time of each round of paired.sh's output
and their median, the per-ray counters that differ between the builds (new vs old, first
round), and the geometric mean of each method's ratios.

    summarize.py OUTDIR > summary.txt
"""
import glob
import json
import math
import os
import statistics
import sys

out = sys.argv[1]
runs = {}  # (scene, family, method, build, round) -> benchmark entry
for path in glob.glob(os.path.join(out, "*.json")):
    scene, build, rnd, _ = os.path.basename(path).split(".")
    for b in json.load(open(path))["benchmarks"]:
        family, method = b["name"].split("/")[:2]
        runs[(scene, family, method, build, int(rnd))] = b
rounds = sorted({k[4] for k in runs})
scenes = sorted({k[0] for k in runs})
SKIP = {"name", "run_name", "run_type", "repetitions", "repetition_index", "threads", "iterations", "real_time",
        "cpu_time", "time_unit", "family_index", "per_family_instance_index"}
for method in ("canonical", "tfdm"):
    ratios = []
    for scene in scenes:
        for family in ("primary", "secondary", "grazing"):
            keys = [r for r in rounds if (scene, family, method, "new", r) in runs and (scene, family, method, "old", r) in runs]
            if not keys:
                continue
            rs = [runs[(scene, family, method, "new", r)]["cpu_time"] / runs[(scene, family, method, "old", r)]["cpu_time"]
                  for r in keys]
            ratios += rs
            print(f"{method:9} {scene:16} {family:9} new/old per round: {' '.join(f'{x:.3f}' for x in rs)}  "
                  f"median {statistics.median(rs):.3f}")
            n, o = runs[(scene, family, method, "new", keys[0])], runs[(scene, family, method, "old", keys[0])]
            diffs = [f"{k} {o[k]:.4g} -> {n[k]:.4g}" for k in sorted(n) if k not in SKIP and isinstance(n[k], (int, float))
                     and k in o and n[k] != o[k]]
            print(f"{'':9} counters: {'; '.join(diffs) if diffs else 'identical'}")
    if ratios:
        print(f"{method}: geomean of all {len(ratios)} ratios: {math.exp(sum(map(math.log, ratios)) / len(ratios)):.3f}")

# tfdm's time over the canonical's within each build and round (the speed-up), median of
# the rounds, and its geometric mean over scenes and families.
for build in ("old", "new"):
    meds = []
    for scene in scenes:
        for family in ("primary", "secondary", "grazing"):
            v = [runs[(scene, family, "tfdm", build, r)]["cpu_time"] / runs[(scene, family, "canonical", build, r)]["cpu_time"]
                 for r in rounds if (scene, family, "tfdm", build, r) in runs and (scene, family, "canonical", build, r) in runs]
            if not v:
                continue
            meds.append(statistics.median(v))
            print(f"{build} {scene:16} {family:9} tfdm/canonical median {statistics.median(v):.2f} ({min(v):.2f}-{max(v):.2f})")
    if meds:
        print(f"{build}: geomean of the median speed-ups {math.exp(sum(map(math.log, meds)) / len(meds)):.2f}")
