#!/usr/bin/python3
"""Ratios from one bench_traversal run (Google Benchmark JSON with repetitions):
canonical vs TFDM (`tfdm`) vs the RMIP driver with mipmap/quad-tree vs pre-tessellation, medians of the repetitions, as a Markdown table.

    /usr/bin/python3 experiments/traversal/summarize.py out.json
"""
import json
import statistics
import sys


def main(path):
    data = json.load(open(path))
    runs = {}
    for b in data["benchmarks"]:
        if b.get("run_type") == "aggregate":
            continue
        name = b["run_name"].split("/")[1] if "/" in b["run_name"] else b["run_name"]
        runs.setdefault(name, []).append(b)
    med = {}
    for name, bs in runs.items():
        med[name] = {
            "mrays": statistics.median(b["Mrays/s"] for b in bs),
            "mrays_min": min(b["Mrays/s"] for b in bs),
            "mrays_max": max(b["Mrays/s"] for b in bs),
            "steps": bs[0]["steps/ray"],
            "mb": bs[0]["MB"],
            "reps": len(bs),
        }
    ctx = data["context"]
    print(f"machine: {ctx.get('host_name', '?')}, {ctx.get('num_cpus', '?')} CPUs @ {ctx.get('mhz_per_cpu', '?')} MHz, "
          f"date {ctx.get('date', '?')}")  # (the library_build_type field is Google Benchmark's own build, not oblong's)
    print()
    print("| configuration | Mrays/s (median, min-max) | steps/ray | memory MB | speed vs TFDM | steps vs TFDM | memory vs tessellated |")
    print("|---|---|---|---|---|---|---|")
    t = med.get("tfdm")
    tess = med.get("tessellated")
    for name in med:  # in the order the benchmark ran them
        m = med[name]
        speed = f"{m['mrays'] / t['mrays']:.2f}x" if t else "-"
        steps = f"{t['steps'] / m['steps']:.1f}x fewer" if t and m["steps"] > 0 else "-"
        mem = f"1/{tess['mb'] / m['mb']:.1f}" if tess and m["mb"] > 0 else "-"
        print(f"| {name} | {m['mrays']:.3f} ({m['mrays_min']:.3f}-{m['mrays_max']:.3f}, n={m['reps']}) | "
              f"{m['steps']:.1f} | {m['mb']:.2f} | {speed} | {steps} | {mem} |")


if __name__ == "__main__":
    main(sys.argv[1])
