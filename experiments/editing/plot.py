#!/usr/bin/python3
"""Plot of experiments/editing/results.csv (bench_editing): per stroke, (a) the rmip
scene's update broken down against its full rebuild, (b) the structure update of every
range query against the 5 ms target.

    /usr/bin/python3 experiments/editing/plot.py [results.csv] [editing.png]
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = os.path.dirname(os.path.abspath(__file__))
src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "results.csv")
dst = sys.argv[2] if len(sys.argv) > 2 else os.path.join(here, "editing.png")

rows = list(csv.DictReader(open(src)))
configs = list(dict.fromkeys(r["config"] for r in rows))
by = {c: [r for r in rows if r["config"] == c] for c in configs}


def col(c, f):
    return [float(r[f]) if r[f] not in ("", "nan") else math.nan for r in by[c]]


fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.6))
rm = by["rmip"]
k = [int(r["stroke"]) for r in rm]
for f, label, style in [("texture_ms", "texture update (texels)", "o-"),
                        ("structure_ms", "rmip structure update", "s-"),
                        ("prism_ms", "prism update", "^-"),
                        ("bvh_ms", "BVH refit", "v-"),
                        ("render_ms", "render 128² primary", "d-"),
                        ("rebuild_ms", "full rebuild (rmip + prisms + BVH)", "X")]:
    y = col("rmip", f)
    if f == "rebuild_ms":
        a.plot([x for x, v in zip(k, y) if not math.isnan(v)], [v for v in y if not math.isnan(v)], style,
               ms=9, color="k", label=label)
    else:
        a.plot(k, [v if v > 0.01 else math.nan for v in y], style, ms=4, label=label)  # ~0: nothing to refit
fs = col("fixedstep", "prism_ms")
a.plot(k, fs, ":", color="gray", label="fixedstep: prism update (no structure)")
a.set_yscale("log")
a.set_xlabel("stroke")
a.set_ylabel("ms")
a.set_title("(a) rmip scene: per-stroke update vs full rebuild")
a.set_ylim(0.05, 1e4)
a.legend(fontsize=7, loc="lower center", ncol=2)
a.grid(True, which="both", alpha=0.3)

for c in configs:
    if c == "fixedstep":
        continue
    b.plot(k, col(c, "structure_ms"), "o-", ms=4, label=f"{c} (first)")
b.plot(k, col("rmip", "structure_rep_min_ms"), "k--", lw=1, label="rmip, repeated: best of 3")
b.axhline(5.0, color="r", lw=1)
b.text(0, 5.3, "target 5 ms", color="r", fontsize=8)
b.set_yscale("log")
b.set_xlabel("stroke")
b.set_ylabel("structure update [ms]")
b.set_title("(b) range-query update of a 256² stroke, 8192² map")
b.legend(fontsize=7)
b.grid(True, which="both", alpha=0.3)
fig.tight_layout()
fig.savefig(dst, dpi=110)
print("wrote", dst)
