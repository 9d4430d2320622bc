#!/usr/bin/env python3
"""Per scene and ray family, the new/old time of each round of paired.sh's output and
their median; the geometric mean over all ratios.

    summarize.py OUTDIR > summary.txt
"""
import glob
import json
import math
import os
import statistics
import sys

out = sys.argv[1]
times = {}  # (scene, family, build, round) -> cpu time per iteration
for path in glob.glob(os.path.join(out, "*.json")):
    scene, build, rnd, _ = os.path.basename(path).split(".")
    for b in json.load(open(path))["benchmarks"]:
        family = b["name"].split("/")[0]
        times[(scene, family, build, int(rnd))] = b["cpu_time"]
ratios = []
for scene in sorted({k[0] for k in times}, key=["asteroid", "terracotta_roof", "creature"].index):
    for family in ("primary", "secondary", "grazing"):
        rs = [times[(scene, family, "new", r)] / times[(scene, family, "old", r)]
              for r in sorted({k[3] for k in times}) if (scene, family, "new", r) in times]
        ratios += rs
        print(f"{scene:16} {family:9} new/old per round: {' '.join(f'{x:.3f}' for x in rs)}  "
              f"median {statistics.median(rs):.3f}")
print(f"geomean of all {len(ratios)} ratios: {math.exp(sum(map(math.log, ratios)) / len(ratios)):.3f}")
