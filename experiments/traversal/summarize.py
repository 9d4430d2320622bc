#!/usr/bin/python3
"""Ratios from one bench_traversal run (Google Benchmark JSON, with repetitions or their
aggregates): per ray family (primary, secondary, grazing), canonical vs TFDM (`tfdm`) vs
the RMIP driver with mipmap/quad-tree vs pre-tessellation, medians of the repetitions, as
Markdown tables. A configuration the run skipped (a pre-tessellation that does not fit)
is listed with its reason.

    /usr/bin/python3 experiments/traversal/summarize.py out.json
"""
import json
import statistics
import sys


def main(path):
    data = json.load(open(path))
    runs, aggregates, skipped = {}, {}, {}
    for b in data["benchmarks"]:
        parts = b["run_name"].split("/")
        key = (parts[0], parts[1]) if len(parts) > 1 else ("primary", parts[0])
        if b.get("error_occurred"):
            skipped[key] = b.get("error_message", "skipped")
            continue
        if b.get("run_type") == "aggregate":
            if b.get("aggregate_name") == "median":
                aggregates[key] = b
            continue
        runs.setdefault(key, []).append(b)
    med = {}
    for key, bs in runs.items():
        med[key] = {
            "mrays": statistics.median(b["Mrays/s"] for b in bs),
            "range": f"{min(b['Mrays/s'] for b in bs):.3f}-{max(b['Mrays/s'] for b in bs):.3f}, n={len(bs)}",
            "steps": bs[0]["steps/ray"],
            "mb": bs[0]["MB"],
        }
    for key, b in aggregates.items():  # --benchmark_report_aggregates_only: the median only
        med.setdefault(key, {"mrays": b["Mrays/s"], "range": "median", "steps": b["steps/ray"], "mb": b["MB"]})
    ctx = data["context"]
    print(f"machine: {ctx.get('host_name', '?')}, {ctx.get('num_cpus', '?')} CPUs @ {ctx.get('mhz_per_cpu', '?')} MHz, "
          f"date {ctx.get('date', '?')}")  # (the library_build_type field is Google Benchmark's own build, not oblong's)
    families = []
    for fam, _ in list(med) + list(skipped):
        if fam not in families:
            families.append(fam)
    for fam in families:
        print()
        print(f"**{fam} rays**")
        print()
        print("| configuration | Mrays/s (median, range) | steps/ray | memory MB | time / tessellated | speed vs TFDM | "
              "memory vs tessellated |")
        print("|---|---|---|---|---|---|---|")
        t = med.get((fam, "tfdm"))
        tess = med.get((fam, "tessellated"))
        for (f, name), m in med.items():  # in the order the benchmark ran them
            if f != fam:
                continue
            ratio = f"{tess['mrays'] / m['mrays']:.2f}" if tess else "-"
            speed = f"{m['mrays'] / t['mrays']:.2f}x" if t else "-"
            mem = f"1/{tess['mb'] / m['mb']:.1f}" if tess and m["mb"] > 0 else "-"
            print(f"| {name} | {m['mrays']:.3f} ({m['range']}) | {m['steps']:.1f} | {m['mb']:.2f} | {ratio} | {speed} | "
                  f"{mem} |")
        for (f, name), why in skipped.items():
            if f == fam:
                print(f"| {name} | skipped: {why} | | | | | |")


if __name__ == "__main__":
    main(sys.argv[1])
