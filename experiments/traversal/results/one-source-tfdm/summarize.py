#!/usr/bin/env python3
"""Per scene, ray family and method, the new/old time of each round of paired.sh's
output and their median; the geometric mean over all ratios of each method.

    summarize.py OUTDIR > summary.txt
"""
import glob
import json
import math
import os
import statistics
import sys

out = sys.argv[1]
times = {}  # (scene, family, method, build, round) -> cpu time per iteration
for path in glob.glob(os.path.join(out, "*.json")):
    scene, build, rnd, _ = os.path.basename(path).split(".")
    for b in json.load(open(path))["benchmarks"]:
        family, method = b["name"].split("/")[:2]
        times[(scene, family, method, build, int(rnd))] = b["cpu_time"]
rounds = sorted({k[4] for k in times})
for method in ("canonical", "tfdm"):
    ratios = []
    for scene in sorted({k[0] for k in times}, key=["asteroid", "terracotta_roof", "creature"].index):
        for family in ("primary", "secondary", "grazing"):
            rs = [times[(scene, family, method, "new", r)] / times[(scene, family, method, "old", r)]
                  for r in rounds if (scene, family, method, "new", r) in times]
            if not rs:
                continue
            ratios += rs
            print(f"{method:9} {scene:16} {family:9} new/old per round: {' '.join(f'{x:.3f}' for x in rs)}  "
                  f"median {statistics.median(rs):.3f}")
    if ratios:
        print(f"{method}: geomean of all {len(ratios)} ratios: {math.exp(sum(map(math.log, ratios)) / len(ratios)):.3f}")
