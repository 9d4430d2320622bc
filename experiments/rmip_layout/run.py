#!/usr/bin/python3
"""RMIP's storage layouts side by side on the paper-scale scenes: bytes, build time, steps
per camera ray and render time (docs/range_query.md, "Layouts").

    experiments/rmip_layout/run.py [--build build] [--size 320x240] [--scenes a,b] [--out DIR] [--reps N]
    experiments/rmip_layout/run.py --quick --out DIR     # the asteroid at 32x24, one round

The options --quick, --build, --out, --reps and --scratch are every experiment's
(common.arguments); --build defaults to build/ here, since the step counts need
statistics compiled in. Each scene is rendered with camera rays only (1 spp, one thread) once per layout and
round (--reps, default 3), the layouts interleaved per scene so that the time ratios are
taken side by side; the tables give each time's minimum over the rounds. Writes
results.csv and results.md into --out (default: this folder). Step counts are
deterministic; times carry the machine's load, which the table records, with the binary
(its path in the repository, its hash and the git commit).
"""
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "lib"))
import common as C  # noqa: E402

LAYOUTS = [
    ("pairs_16", {"name": "rmip"}),  # the default
    ("pairs_32", {"name": "rmip", "bits": 32}),
    ("corners_c1_16", {"name": "rmip", "layout": "corners", "compression": 1, "bits": 16}),
    ("corners_c1_32", {"name": "rmip", "layout": "corners", "compression": 1, "bits": 32}),
]
SCENES = ["paper/alien_sphere", "paper/terracotta_roof", "paper/diving_helmet", "paper/desert_tire",
          "paper/creature", "asteroid"]


QUICK_SCENES = ["asteroid"]


def main() -> int:
    ap = C.arguments("rmip_layout", "RMIP's storage layouts on the paper-scale scenes", build=C.ROOT / "build")
    ap.add_argument("--size", default=None, help="image size (default 320x240, 32x24 with --quick)")
    ap.add_argument("--scenes", default=None, help="comma-separated scene names (default: the paper-scale suite "
                                                   "and the asteroid; the asteroid with --quick)")
    a = ap.parse_args()
    try:
        oblong, out = C.outputs("rmip_layout", a)
    except C.UsageError as e:
        print(e, file=sys.stderr)
        return 2
    size = a.size or ("32x24" if a.quick else "320x240")
    scenes = a.scenes.split(",") if a.scenes else (QUICK_SCENES if a.quick else SCENES)
    reps = a.reps or (1 if a.quick else 3)  # renders per (scene, layout); times are the minimum
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    load = os.getloadavg()
    started = time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())
    if a.scratch:
        Path(a.scratch).mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=a.scratch) as tmp:
        for name in scenes:
          doc = C.load_scene(C.scene_path(name))
          for rep in range(reps):
            for label, rq in LAYOUTS:
                variant = dict(doc, strategies={"range": rq})
                sp = Path(tmp) / f"{name.replace('/', '_')}_{label}.json"
                sp.write_text(json.dumps(variant))
                stats = Path(tmp) / "stats.json"
                t0 = time.time()
                r = subprocess.run([str(oblong), "render", str(sp), "-o", str(Path(tmp) / "img.png"), "--size", size,
                                    "--spp", "1", "--integrator", "primary", "--threads", "1", "-q",
                                    "--stats", str(stats)], capture_output=True, text=True)
                if r.returncode != 0:
                    print(f"{name} {label}: {r.stderr.strip()}", file=sys.stderr)
                    return 1
                s = json.loads(stats.read_text())
                mem = s["memory"]
                if rep > 0:  # the minimum time over the rounds; the rest is deterministic
                    r0 = next(x for x in rows if x["scene"] == name and x["layout"] == label)
                    r0["build_s"] = min(r0["build_s"], round(s["seconds"]["build"], 3))
                    r0["render_s"] = min(r0["render_s"], round(s["seconds"]["render"], 3))
                    continue
                rows.append({
                    "scene": name, "layout": label,
                    "rmip_MiB": round(mem.get("rmip/layers", 0) / 2**20, 2),
                    "build_s": round(s["seconds"]["build"], 3),
                    "render_s": round(s["seconds"]["render"], 3),
                    "steps_per_camera_ray": round(s["steps_per_camera_ray"], 3),
                    "range_queries": s["ray_counters"]["range_queries"],
                    "hit_fraction": round(s["rays"]["hits"] / max(1, s["rays"]["primary"]), 4),
                    "peak_MiB": round(s.get("peak_memory", 0) / 2**20, 1),
                })
                print(rows[-1], flush=True)
    with open(out / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    b = C.build_info(oblong)
    lines = [f"# RMIP layouts on the paper-scale scenes ({size}, camera rays, 1 thread, "
             f"minimum over {reps} interleaved rounds)", "",
             f"Run {started} to {time.strftime('%H:%M UTC', time.gmtime())}, load average at start "
             f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; {b['binary']} (sha256 {b['binary_sha256_16']}…, git "
             f"{b['git'].get('commit', '?')[:12]}).", "",
             "| scene | layout | rmip MiB | build s | render s | steps / camera ray | range queries | hits |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['layout']} | {r['rmip_MiB']} | {r['build_s']} | {r['render_s']} | "
                     f"{r['steps_per_camera_ray']} | {r['range_queries']} | {r['hit_fraction']} |")
    (out / "results.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
