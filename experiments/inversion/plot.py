"""Joins errors.csv with the benchmark timings and plots error against time per inversion.

Usage: /usr/bin/python3 plot.py DIR   (DIR holds errors.csv and timings.json; writes
results.csv and error_vs_time.png there).
"""
import csv
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

d = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
errors = list(csv.DictReader(open(d / "errors.csv")))
bench = json.load(open(d / "timings.json"))
ns = {}
for b in bench["benchmarks"]:
    name = b.get("run_name", b["name"])
    if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "median":
        continue
    scale = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}[b.get("time_unit", "ns")]
    ns[name] = b["cpu_time"] * scale

rows = []
for e in errors:
    key = f'{e["dataset"]}/{e["variant"]}'
    if key not in ns:
        continue
    r = dict(e)
    r["ns_per_inversion"] = f"{ns[key]:.2f}"
    rows.append(r)
fields = ["dataset", "variant", "inverter", "precision", "ns_per_inversion"] + [
    k for k in errors[0].keys() if k not in ("dataset", "variant", "inverter", "precision")
]
with open(d / "results.csv", "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=fields)
    w.writeheader()
    for r in rows:
        w.writerow({k: r[k] for k in fields})

datasets = []
for r in rows:
    if r["dataset"] not in datasets:
        datasets.append(r["dataset"])
style = {
    ("newton", "float"): ("tab:blue", "o"),
    ("newton", "double"): ("tab:cyan", "s"),
    ("cubic", "float"): ("tab:red", "^"),
    ("cubic", "double"): ("tab:orange", "v"),
    ("ceres", "double"): ("black", "D"),
}
floor = 1e-17
ncol = 2
nrow = (len(datasets) + 1) // 2
fig, axes = plt.subplots(nrow, ncol, figsize=(15, 6.5 * nrow), squeeze=False)
for ax, ds in zip(axes.flat, datasets):
    pts = [r for r in rows if r["dataset"] == ds]
    pts.sort(key=lambda r: float(r["ns_per_inversion"]))
    for i, r in enumerate(pts):
        c, m = style[(r["inverter"], r["precision"])]
        t = float(r["ns_per_inversion"])
        p99 = max(float(r["p99_err"]), floor)
        mx = max(float(r["max_err"]), floor)
        ax.scatter([t], [p99], color=c, marker=m, s=40, zorder=3)
        ax.scatter([t], [mx], facecolors="none", edgecolors=c, marker=m, s=40, zorder=3)
        ax.plot([t, t], [p99, mx], color=c, lw=0.6, alpha=0.6)
        label = r["variant"].replace("newton ", "N ").replace("cubic ", "C ").replace(" no-fallback", " nofb")
        label = label.replace("ceres double", "ceres (reference, error 0 by definition)")
        dy = 10 * ((i % 4) - 1.5)
        ax.annotate(label, (t, p99), fontsize=6.5, xytext=(6, dy), textcoords="offset points",
                    arrowprops=dict(arrowstyle="-", lw=0.3, color="0.5"))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time per inversion (ns, median of 5)")
    ax.set_ylabel("error vs ceres: filled = 99th percentile, hollow = max")
    ax.set_title(f"{ds}")
    ax.grid(True, which="both", alpha=0.3)
for ax in list(axes.flat)[len(datasets):]:
    ax.axis("off")
handles = [
    plt.Line2D([], [], color=c, marker=m, ls="", label=f"{inv} ({p})") for (inv, p), (c, m) in style.items()
]
axes.flat[0].legend(handles=handles, loc="best", fontsize=8)
fig.suptitle("Inverters: error (max(|du|,|dv|,|dh|/max(L,|h|))) against run time", fontsize=11)
fig.tight_layout()
fig.savefig(d / "error_vs_time.png", dpi=130)
print(f"wrote {d / 'results.csv'} and {d / 'error_vs_time.png'} ({len(rows)} points)")
