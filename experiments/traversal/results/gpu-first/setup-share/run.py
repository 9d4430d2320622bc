#!/usr/bin/env python3
"""Per-ray time split of the canonical traversal: Embree + missesPrism, the prism set-up
(RayPatch's constructor and setupCurve), the loop. XSTOP=2 returns after missesPrism,
XSTOP=1 after setupCurve (scratch build, patch in setup-share.txt); with no hit the rays
enter more prisms, so both are scaled by prisms/ray of the full run."""
import json, os, subprocess, sys, statistics
bench, out = sys.argv[1], sys.argv[2]
scenes = ["paper/alien_sphere", "paper/desert_tire", "paper/terracotta_roof", "paper/creature", "paper/diving_helmet", "asteroid"]
rounds = 2
res = {}
for r in range(rounds):
    for s in scenes:
        for cfg in ["tfdm", "x0", "x1", "x2"]:
            env = dict(os.environ)
            method = "tfdm" if cfg == "tfdm" else "canonical"
            env["XSTOP"] = "0" if cfg == "tfdm" else cfg[1]
            f = f"{out}/{s.replace('/', '_')}.{cfg}.{r}.json"
            subprocess.run([bench, "--scene", f"scenes/{s}.json", "--size", "160x120", "--grazing", "2000",
                            f"--benchmark_filter=^(primary|secondary|grazing)/{method}/", "--benchmark_min_time=1",
                            f"--benchmark_out={f}", "--benchmark_out_format=json"], env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
            for b in json.load(open(f))["benchmarks"]:
                fam = b["name"].split("/")[0]
                res.setdefault((s, fam, cfg), []).append((b["real_time"], b["prisms/ray"], b["steps/ray"]))
    print("round", r, "done", open("/proc/loadavg").read().split()[0], file=sys.stderr, flush=True)
print("| scene | rays | canonical ms | tfdm ms | tfdm/canonical | prisms/ray | Embree + missesPrism | prism set-up | loop | set-up per entered prism, ns |")
print("|---|---|---|---|---|---|---|---|---|---|")
for s in scenes:
    for fam in ["primary", "secondary", "grazing"]:
        med = lambda c: statistics.median(x[0] for x in res[(s, fam, c)])
        p0 = res[(s, fam, "x0")][0][1]; p1 = res[(s, fam, "x1")][0][1]
        t0, t1, t2, tt = med("x0"), med("x1"), med("x2"), med("tfdm")
        k = p0 / p1
        bvh = t2 * k; setup = (t1 - t2) * k; loop = t0 - bvh - setup
        n = {"primary": 19200, "grazing": 2000}.get(fam)
        print(f"| {s.split('/')[-1]} | {fam} | {t0:.1f} | {tt:.1f} | {tt/t0:.2f} | {p0:.2f} | {100*bvh/t0:.0f} % | {100*setup/t0:.0f} % | {100*loop/t0:.0f} % | {(t1-t2)*1e6/(p1*n) if n else float('nan'):.0f} |")
