#!/usr/bin/python3
"""A small range-query ablation through the Python module, notebook style (run it as a
script, or cell by cell: each `# %%` is a cell in Jupyter or VS Code).

    PYTHONPATH=build/python /usr/bin/python3 experiments/python_ablation/ablation.py [--out DIR] [--quick]

Loads scenes/sphere.json, renders its camera rays and traces a set of rays from Python with
each range query by name (oblong.range_queries()) and the TFDM baseline, in interleaved
rounds; checks that every configuration finds the canonical hits; writes results.csv,
results.md and ablation.png into DIR (default /tmp/oblong_python_ablation). README.md beside
this file says what it shows.
"""
# %% Set-up
import argparse
import csv
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
SCENE = ROOT / "scenes" / "sphere.json"
try:
    import oblong
except ImportError:  # not on PYTHONPATH: the module of the build folder `build/`
    sys.path.insert(0, str(ROOT / "build" / "python"))
    import oblong

ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
ap.add_argument("--out", default="/tmp/oblong_python_ablation", help="output folder (created)")
ap.add_argument("--quick", action="store_true", help="tiny sizes, one round (a smoke run: seconds)")
ap.add_argument("--threads", type=int, default=1, help="worker threads (0: all cores)")
args = ap.parse_args()
out = Path(args.out)
out.mkdir(parents=True, exist_ok=True)
size = (80, 60) if args.quick else (320, 240)
n_rays = 2000 if args.quick else 100_000
rounds = 1 if args.quick else 3

# %% The configurations: every registered range query, then TFDM (a baseline).
configs = [("rmip (canonical)", {})]
configs += [(name, {"range": name}) for name in oblong.range_queries() if name != "rmip"]
configs += [("tfdm (baseline)", {"baseline": "tfdm"})]

scene = oblong.load(str(SCENE))
# Rays from all around the sphere toward points near it: grazing and head-on ones, a few
# misses.
rng = np.random.default_rng(1)
origins = rng.normal(size=(n_rays, 3))
origins = 3.0 * origins / np.linalg.norm(origins, axis=1, keepdims=True)
directions = rng.uniform(-1.1, 1.1, size=(n_rays, 3)) - origins

# %% Interleaved rounds: each round runs every configuration once, in a fresh order, so
# that a slow spell of the machine falls on all of them alike.
runs = {label: [] for label, _ in configs}
images = {}
reference = None
for r in range(rounds):
    for i in rng.permutation(len(configs)):
        label, kw = configs[i]
        img = scene.render(size=size, spp=1, integrator="primary", threads=args.threads, **kw)
        start = time.perf_counter()
        hits = scene.trace(origins, directions, threads=args.threads, **kw)
        wall = time.perf_counter() - start
        if reference is None and not kw:
            reference = hits
        images.setdefault(label, img["steps"])
        runs[label].append({"render_s": img["stats"]["seconds"]["render"], "trace_s": hits["stats"]["seconds"]["trace"],
                            "call_s": wall, "hits": hits, "render_stats": img["stats"]})

# %% Exactness: every configuration is exact, so each finds the canonical hit of every ray.
if reference is None:
    reference = runs[configs[0][0]][0]["hits"]
mismatches = {}
for label, _ in configs:
    h = runs[label][0]["hits"]
    mismatches[label] = int(np.count_nonzero((h["prim"] != reference["prim"]) | (h["t"] != reference["t"])))

# %% The table: medians over the rounds, counters per traced ray.
rows = []
for label, _ in configs:
    rs = runs[label]
    h = rs[0]["hits"]
    rows.append({
        "configuration": label,
        "render_ms": 1e3 * float(np.median([x["render_s"] for x in rs])),
        "trace_us_per_ray": 1e6 * float(np.median([x["trace_s"] for x in rs])) / n_rays,
        "steps_per_ray": float(h["steps"].mean()),
        "range_queries_per_ray": float(h["range_queries"].mean()),
        "cells_marched_per_ray": float(h["cells_marched"].mean()),
        "steps_per_camera_ray": float(rs[0]["render_stats"]["steps_per_camera_ray"]),
        "hit_fraction": float(np.mean(h["mesh"] >= 0)),
        "mismatches": mismatches[label],
    })
with open(out / "results.csv", "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
md = ["| configuration | render ms | trace µs/ray | steps/ray | range queries/ray | cells/ray | mismatches |",
      "|---|---|---|---|---|---|---|"]
for r in rows:
    md.append(f"| {r['configuration']} | {r['render_ms']:.1f} | {r['trace_us_per_ray']:.2f} | {r['steps_per_ray']:.2f} | "
              f"{r['range_queries_per_ray']:.2f} | {r['cells_marched_per_ray']:.2f} | {r['mismatches']} |")
note = (f"scenes/sphere.json; {size[0]}x{size[1]} camera rays (primary, 1 spp) and {n_rays} traced rays; "
        f"--threads {args.threads}; {rounds} round(s); median times; oblong {oblong.__version__}"
        + (" (quick mode: the times mean nothing)" if args.quick else ""))
(out / "results.md").write_text("\n".join(md) + "\n\n" + note + "\n")
print("\n".join(md))
print(note)

# %% The plot: steps per camera ray (log scale, one colour scale for all), and the
# traced rays' work and time per configuration.
labels = [label for label, _ in configs]
fig = plt.figure(figsize=(3.2 * len(labels), 6.4), constrained_layout=True)
grid = fig.add_gridspec(2, len(labels), height_ratios=[1.0, 0.9])
vmax = max(1.0, max(float(images[label].max()) for label in labels))
for k, label in enumerate(labels):
    ax = fig.add_subplot(grid[0, k])
    im = ax.imshow(np.log10(1.0 + images[label]), vmin=0, vmax=np.log10(1.0 + vmax), cmap="viridis")
    ax.set_title(f"{label}\n{rows[k]['steps_per_camera_ray']:.1f} steps / camera ray", fontsize=10)
    ax.set_xticks([]), ax.set_yticks([])
fig.colorbar(im, ax=fig.axes[: len(labels)], shrink=0.8, label="log10(1 + steps)")
ax = fig.add_subplot(grid[1, : len(labels) // 2 or 1])
x = np.arange(len(labels))
ax.bar(x - 0.2, [r["steps_per_ray"] for r in rows], 0.4, label="steps")
ax.bar(x + 0.2, [r["range_queries_per_ray"] for r in rows], 0.4, label="range queries")
ax.set_xticks(x, [label.split(" ")[0] for label in labels])
ax.set_ylabel("per traced ray")
ax.set_title(f"work of {n_rays} traced rays", fontsize=10)
ax.legend(fontsize=9)
ax = fig.add_subplot(grid[1, len(labels) // 2 or 1:])
ax.bar(x, [r["trace_us_per_ray"] for r in rows], 0.6, color="tab:gray")
ax.set_xticks(x, [label.split(" ")[0] for label in labels])
ax.set_ylabel("µs per ray (median)")
ax.set_title(f"trace time, --threads {args.threads}" + (" (quick: noise)" if args.quick else ""), fontsize=10)
fig.suptitle("Range-query ablation through the Python module (scenes/sphere.json)", fontsize=12)
fig.savefig(out / "ablation.png", dpi=110)
print(f"wrote {out / 'results.csv'}, {out / 'results.md'}, {out / 'ablation.png'}")

# %% Exit status: 3 when a configuration missed a canonical hit (as experiments/run_all).
sys.exit(3 if any(mismatches.values()) else 0)
