#!/usr/bin/env python3
"""The per-scene table of stages.txt's runs: instructions per ray and the canonical
traversal's stages, as Markdown. Usage: table.py OUT (run.sh's output folder)."""
import os, subprocess, sys
OUT = sys.argv[1]; HERE = os.path.dirname(os.path.abspath(__file__))
RAYS = {"grazing": 1000, "camera": 64 * 48}
COLS = [("box", "box"), ("range query", "RMIP query"), ("micro-triangles", "micro-tri."),
        ("march", "march"), ("curve pieces", "curve pieces"), ("box subdivision", "box subdiv."),
        ("prism entry", "prism entry"), ("Embree", "Embree"), ("other", "other")]
def stages(path):
    out = subprocess.run([sys.executable, os.path.join(HERE, "stages.py"), path], capture_output=True, text=True, check=True).stdout
    d = {}; tot = 0
    for l in out.splitlines():
        if l.startswith("total Ir"): tot = int(l.split()[-1].replace(",", ""))
        else:
            pct, name = l.split("%", 1); d[name.strip()] = float(pct)
    return d, tot
print("| scene | rays | canonical instr./ray | tfdm instr./ray | " + " | ".join(c[1] for c in COLS) + " |")
print("|---|---|---|---|" + "---|" * len(COLS))
for s in ["terracotta_roof", "diving_helmet", "creature", "alien_sphere", "desert_tire", "asteroid"]:
    for fam in ["camera", "grazing"]:
        c, ct = stages(f"{OUT}/{s}.canonical.{fam}.txt"); _, tt = stages(f"{OUT}/{s}.tfdm.{fam}.txt")
        row = [next((v for k, v in c.items() if k.startswith(p)), 0.0) for p, _ in COLS]
        print(f"| {s} | {fam} | {ct / RAYS[fam]:,.0f} | {tt / RAYS[fam]:,.0f} | " + " | ".join(f"{v:.0f} %" for v in row) + " |")
