"""Shared machinery of the RMIP-paper experiments (experiments/README.md): runs the `oblong` binary
(`render` / `trace` with `--stats`), repeats and interleaves the runs, records the
machine, the build and every resolved configuration, writes CSVs, plots and the
summary that `experiments/run_all` turns into experiments/REPORT.md.

Run with Debian's interpreter (/usr/bin/python3): its python3-matplotlib and
python3-numpy are what the plots use; `python3` on PATH may be another interpreter.

Each experiment is `experiments/<name>/run.py`, a module with

    NAME, TITLE, HYPOTHESIS       strings
    def run(ctx) -> dict           the summary (see Summary below)

and `common.main(module)` gives it the command line

    run.py [--quick] [--build DIR] [--out DIR] [--reps N] [--scratch DIR]

(arguments(): other scripts under experiments/ share it). That interface is also how
`run_all` finds the experiments (lib/discovery.py).

Outputs go to --out (default: the experiment's own folder in a full run; run_all
passes a scratch folder in quick mode, so the committed full results are never
overwritten by a quick run).
"""
from __future__ import annotations

import argparse
import csv
import datetime
import hashlib
import json
import math
import os
import platform
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import runner
import runstore
# What experiments reach through this module (C.load_scene, C.ExperimentError, ...) lives
# in runner.py, below both this module and runstore.py.
from runner import (EXPERIMENTS, ROOT, SCENE_OVERRIDE, SCENES, Context, ExperimentError, Run,  # noqa: F401
                    load_scene, scene_path, strip_json_comments)

# The two configurations every experiment is about (docs/traversal.md).
CANONICAL = []  # the defaults: rmip (full resolution) + newton + midpoint2d, marching 4, inversion on
# TFDM (Thonat et al. 2021) as it traverses: the `tfdm` baseline (docs/tfdm.md).
TFDM = ["--baseline", "tfdm"]
# The RMIP driver with TFDM's min-max mipmap and node-aligned quad-tree splits, no
# inversion, marching one texel: an ablation of RMIP (prism clip, curve rectangles,
# front-to-back order, early exit), not TFDM.
DRIVER_MIPMAP = ["--range", "minmax_mipmap", "--splitter", "quadtree", "--inversion-in-traversal", "false",
                 "--marching-scale", "1"]
DRIVER_MIPMAP_LABEL = "RMIP driver + mipmap/quad-tree"
# `tfdm` with world-space node boxes (the canonical traversal's box construction) instead
# of its default texture-frame boxes: separates the box frame from the traversal order.
TFDM_WORLD_STRATEGIES = {"baseline": {"name": "tfdm", "boxes": "world"}}
TFDM_WORLD_LABEL = "TFDM, world boxes"
RANGE_PREFIXES = ("rmip/", "minmax_mipmap/", "safety_zones/", "tfdm/mipmap", "tfdm/upper_levels")

# RMIP resolutions of the paper's Table 1 columns, as divisors of the map's longer side
# (strategies.range.resolution = max(W, H) / divisor; divisor 1 = full resolution, the
# canonical default). Chosen so that "normal" has about the minmax mipmap's memory
# (the paper's "RMIP" column: x1.3-1.6 of TFDM), "low" a tenth of it or less and "high"
# the full-resolution structure (the paper's x7.6-30). table1 picks its "normal" by
# measured bytes instead (rmip_nearest_resolution).
RMIP_LEVELS = {"low": 16, "normal": 2, "high": 1}

# The paper-scale suite (scenes/paper/, scenes/README.md): Table 1's regimes.
PAPER_SCENES = ["paper/alien_sphere", "paper/terracotta_roof", "paper/diving_helmet", "paper/desert_tire",
                "paper/creature"]


def short(scene: str) -> str:
    """'paper/alien_sphere' -> 'alien_sphere' (labels, file names)."""
    return scene.split("/")[-1]


def geomean(xs) -> float:
    import math
    xs = [x for x in xs if x == x and x > 0]
    return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else float("nan")


_TESS: dict = {}


def tessellation_fit(ctx, scene) -> dict:
    """Whether the pre-tessellation of `scene` fits this machine, without building it:
    oblong's own estimate (printed when it refuses: OBLONG_MEMORY_LIMIT=1 forces the
    refusal) against 80% of MemAvailable, the share oblong allows one structure.
    {"fits", "micro_triangles", "needs" (text), "needs_bytes"}."""
    key = (str(ctx.binary), str(scene))
    if key in _TESS:
        return _TESS[key]
    env = dict(os.environ, OBLONG_MEMORY_LIMIT="1M")
    p = subprocess.run([str(ctx.binary), "render", str(scene), "--baseline", "tessellated", "--size", "2x2", "-q",
                        "-o", str(ctx.tmp("probe.png"))], capture_output=True, text=True, env=env, timeout=300)
    m = re.search(r"needs ([0-9.]+ [KMGT]?i?B) \((\d+) micro-triangles", p.stderr)
    if not m:
        raise ExperimentError(f"{scene}: no pre-tessellation estimate in: {p.stderr.strip()[-500:]}")
    needs = m.group(1)
    num, unit = needs.split()
    mult = {"B": 1, "KiB": 1 << 10, "MiB": 1 << 20, "GiB": 1 << 30, "TiB": 1 << 40}[unit]
    nbytes = int(float(num) * mult)
    avail = 0
    for line in open("/proc/meminfo"):
        if line.startswith("MemAvailable:"):
            avail = int(line.split()[1]) * 1024
    r = {"fits": nbytes <= 0.8 * avail, "micro_triangles": int(m.group(2)), "needs": needs, "needs_bytes": nbytes}
    _TESS[key] = r
    return r


def map_size(scene: dict) -> tuple[int, int]:
    """Width and height of the first displaced mesh's map (PNG header)."""
    for m in scene["meshes"]:
        if "displacement" in m:
            return png_size(Path(m["displacement"]["map"]))
    raise ExperimentError("scene has no displaced mesh")


def png_size(path: Path) -> tuple[int, int]:
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        raise ExperimentError(f"{path}: not a PNG")
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def rmip_resolution(scene: dict, level: str) -> int:
    w, h = map_size(scene)
    return max(1, max(w, h) // RMIP_LEVELS[level])


_BYTES: dict = {}


def structure_bytes(ctx, scene: str, strategies: dict) -> int:
    """range_bytes() of what `scene` (a repository scene name) builds with `strategies`:
    a 2x2 camera-ray render with --stats, run here and now (a probe of the structure's
    size, not a measurement: not in the run store, not in run.json)."""
    key = (str(ctx.binary), scene, json.dumps(strategies, sort_keys=True))
    if key in _BYTES:
        return _BYTES[key]
    doc = load_scene(scene_path(scene))
    doc["strategies"] = strategies
    path, stats = ctx.tmp("probe", "scene.json"), ctx.tmp("probe", "stats.json")
    path.write_text(json.dumps(doc))
    p = subprocess.run([str(ctx.binary), "render", str(path), "--integrator", "primary", "--size", "2x2", "--threads",
                        "1", "-q", "-o", str(ctx.tmp("probe", "probe.png")), "--stats", str(stats)],
                       capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        raise ExperimentError(f"{scene}: probe with {strategies} failed: {p.stderr.strip()[-500:]}")
    _BYTES[key] = range_bytes(json.loads(stats.read_text()))
    return _BYTES[key]


def rmip_nearest_resolution(ctx, scene: str, target: int) -> tuple[int, int, int]:
    """The RMIP resolution max(W, H) / 2^k whose structure's bytes are nearest `target`
    (ratio nearest 1, in log scale): bytes fall with the divisor, so the walk starts at
    / 2 and stops once it has bracketed the target. (resolution, divisor, bytes)."""
    w, h = map_size(load_scene(scene_path(scene)))
    side = max(w, h)

    def at(d):
        return structure_bytes(ctx, scene, {"range": {"name": "rmip", "resolution": max(1, side // d)}})
    d = 2
    if at(d) > target:
        while at(d) > target and 2 * d <= side:
            d *= 2
        cands = [d // 2, d]
    else:
        while at(d) < target and d > 1:
            d //= 2
        cands = [d, 2 * d]
    best = min(cands, key=lambda c: abs(math.log(max(1, at(c)) / max(1, target))))
    return max(1, side // best), best, at(best)


_STRATEGIES: dict = {}


def strategies(ctx: Context) -> dict:
    """The binary's registered strategies (`oblong info --strategies --json`): per kind
    ("range", "inverter", "splitter") a list of {name, summary, slow_reference, devices,
    vulkan_kernel}, the baselines, what runs on Vulkan ("vulkan") and the default
    configuration. Experiments list strategies from here, never by hand."""
    key = str(ctx.binary)
    if key not in _STRATEGIES:
        out = subprocess.run([key, "info", "--strategies", "--json"], capture_output=True, text=True, check=True,
                             timeout=60).stdout
        _STRATEGIES[key] = json.loads(out)
    return _STRATEGIES[key]


def strategy_names(ctx: Context, kind: str) -> list:
    """Registered names of one kind, the default configuration's first."""
    s = strategies(ctx)
    names = [e["name"] for e in s[kind]]
    default = s["default"][kind]
    return [default] + [n for n in names if n != default]


# Who executes the runs: runner.Local() here and now, or lib/runstore.py's Store when
# `run_all --backend slurm` runs this experiment in passes (set by main).
RUNNER = runner.Local()


def run_oblong(ctx: Context, sub: str, scene, args: list, label: str | None = None, timeout: float = 600,
               threads: int | None = None) -> Run:
    """Runs `oblong SUB SCENE ARGS --threads 1 --stats TMP.json`; returns the parsed stats,
    the process's wall time and CPU time (user + system, from wait4)."""
    return RUNNER.run(ctx, sub, scene, args, label, timeout, threads)


def interleaved(ctx: Context, jobs: list, reps: int, seed: int = 1) -> dict:
    """jobs: (key, sub, scene, args) tuples. Runs `reps` rounds; each round runs every job
    once, in a fresh random order (runner.schedule), so that slow drifts of the machine's
    load hit all configurations alike. Returns {key: [Run per round]} (rounds in order)."""
    rounds = runner.schedule(jobs, reps, seed)
    out = {j[0]: [] for j in jobs}
    for order, runs in zip(rounds, RUNNER.rounds(ctx, rounds)):
        for job, r in zip(order, runs):
            out[job[0]].append(r)
    return out


# ---------------------------------------------------------------------------------------
# Numbers


def med(xs):
    xs = [x for x in xs if x == x]
    return statistics.median(xs) if xs else float("nan")


def spread(xs):
    xs = [x for x in xs if x == x]
    return (min(xs), max(xs)) if xs else (float("nan"), float("nan"))


def paired_ratios(base: list, other: list) -> list:
    """base[i] / other[i] per round: > 1 means `other` is faster (a speed-up)."""
    return [b.seconds / o.seconds for b, o in zip(base, other) if o.seconds > 0]


def range_bytes(stats: dict) -> int:
    """Bytes of the range-query structure (the paper's "data structure" for TFDM and RMIP);
    for the pre-tessellated baseline, everything it built (BVH and micro-mesh)."""
    mem = stats.get("memory", {})
    if stats.get("config", {}).get("baseline") == "tessellated":
        return int(stats.get("memory_total", 0))
    return int(sum(v for k, v in mem.items() if k.startswith(RANGE_PREFIXES)))


def total_bytes(stats: dict) -> int:
    return int(stats.get("memory_total", 0))


def fmt_ratio(x: float, lo: float | None = None, hi: float | None = None, digits: int = 2) -> str:
    if x != x:
        return "–"
    s = f"×{x:.{digits}f}"
    if lo is not None and hi is not None and lo == lo:
        s += f" ({lo:.{digits}f}–{hi:.{digits}f})"
    return s


def fmt_bytes(b: float) -> str:
    if b >= 1 << 30:
        return f"{b / (1 << 30):.2f} GiB"
    if b >= 1 << 20:
        return f"{b / (1 << 20):.2f} MiB"
    if b >= 1 << 10:
        return f"{b / (1 << 10):.1f} KiB"
    return f"{int(b)} B"


def fmt_g(x: float, digits: int = 3) -> str:
    if x != x:
        return "–"
    return f"{x:.{digits}g}"


def md_table(header: list, rows: list) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(str(c) for c in r) + " |")
    return "\n".join(lines)


def write_csv(path: Path, rows: list, fields: list | None = None) -> None:
    if not rows:
        raise ExperimentError(f"no rows for {path}")
    fields = fields or list(rows[0].keys())
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items() if k in fields})


def read_pfm(path):
    """An RGB (PF) or grey (Pf) PFM as a float64 array h x w x channels, row 0 at the top
    (PFM stores the bottom row first)."""
    import numpy as np
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        ch = 3 if kind == b"PF" else 1
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4", count=w * h * ch)
    return np.flipud(data.reshape(h, w, ch)).astype(np.float64)


def read_csv(path: Path) -> list:
    """The rows write_csv wrote, with numbers and booleans as such ('' is None)."""
    def value(v: str):
        if v == "":
            return None
        if v in ("True", "False"):
            return v == "True"
        for t in (int, float):
            try:
                return t(v)
            except ValueError:
                pass
        return v
    with open(path, newline="") as f:
        return [{k: value(v) for k, v in r.items()} for r in csv.DictReader(f)]


def replot(module) -> int:
    """`run.py --replot [--out DIR]`: the experiment's plot again from DIR/results.csv (default:
    the committed results), without running anything: for a change of the plot alone."""
    ap = argparse.ArgumentParser(description=f"{module.NAME}: redraw the plot from results.csv")
    ap.add_argument("--replot", action="store_true")
    ap.add_argument("--out", default=str(EXPERIMENTS / module.NAME))
    a = ap.parse_args()
    out = Path(a.out)
    module.plot(read_csv(out / "results.csv"), out)
    print(f"{module.NAME}: redrew the plot in {out} from results.csv")
    return 0


def plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot

    pyplot.rcParams.update({"font.size": 8, "axes.titlesize": 9, "figure.dpi": 100})
    return pyplot


# ---------------------------------------------------------------------------------------
# Machine, build and run record


def _cmake_cache(build_dir: Path) -> dict:
    keys = ("CMAKE_BUILD_TYPE", "OBLONG_STATS", "OBLONG_SANITIZE", "CMAKE_CXX_COMPILER", "CMAKE_CXX_FLAGS",
            "CMAKE_CXX_FLAGS_RELEASE")
    out = {}
    p = build_dir / "CMakeCache.txt"
    if p.exists():
        for line in p.read_text(errors="replace").splitlines():
            m = re.match(r"^([A-Za-z_]+):[A-Z]+=(.*)$", line)
            if m and m.group(1) in keys:
                out[m.group(1)] = m.group(2)
    return out


def _first_line(cmd: list) -> str:
    try:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=20).stdout.strip().splitlines()[0]
    except Exception:  # noqa: BLE001 - informational only
        return "?"


def machine_info() -> dict:
    cpu = runner.cpu_model()
    mem = "?"
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal"):
                mem = f"{int(line.split()[1]) / (1 << 20):.1f} GiB"
    except OSError:
        pass
    import matplotlib
    import numpy

    return {
        "host": platform.node(),
        "os": platform.platform(),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "memory": mem,
        "python": sys.version.split()[0] + " (" + sys.executable + ")",
        "numpy": numpy.__version__,
        "matplotlib": matplotlib.__version__,
        "note": "2-core VM shared with other engineers' builds and tests: wall-clock timings are noisy; "
                "every timing is --threads 1, repeated in interleaved rounds, reported as median and range",
    }


def repo_path(p: Path) -> str:
    """`p` as results record it: relative to the repository's root, or, outside the
    repository, its folder's name and its own (a machine's absolute paths stay out of
    committed results)."""
    p = Path(p).resolve()
    try:
        return str(p.relative_to(ROOT))
    except ValueError:
        return f"{p.parent.name}/{p.name} (outside the repository)"


def build_info(binary: Path) -> dict:
    b = Path(binary).resolve()
    h = hashlib.sha256(b.read_bytes()).hexdigest()[:16]
    cache = _cmake_cache(b.parent)
    git = {}
    try:
        git["commit"] = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True,
                                       timeout=20).stdout.strip()
        st = subprocess.run(["git", "--no-optional-locks", "-C", str(ROOT), "status", "--porcelain",
                             "--untracked-files=no"], capture_output=True, text=True, timeout=20).stdout
        git["modified_tracked_files"] = len([x for x in st.splitlines() if x.strip()])
    except Exception:  # noqa: BLE001
        pass
    return {
        "binary": repo_path(b),
        "binary_sha256_16": h,
        "binary_mtime": datetime.datetime.fromtimestamp(b.stat().st_mtime, datetime.timezone.utc).isoformat(
            timespec="seconds"),
        "cmake": cache,
        "compiler": _first_line([cache.get("CMAKE_CXX_COMPILER", "c++"), "--version"]),
        "git": git,
    }


def stats_enabled(binary: Path) -> bool:
    return _cmake_cache(Path(binary).resolve().parent).get("OBLONG_STATS", "ON").upper() in ("ON", "1", "TRUE")


# ---------------------------------------------------------------------------------------
# Entry point shared by every experiment


def default_build() -> Path:
    return ROOT / "build-exp"


def arguments(name: str, title: str, build: Path | None = None) -> argparse.ArgumentParser:
    """The command line every script under experiments/ shares,

        run.py [--quick] [--build DIR] [--out DIR] [--reps N] [--scratch DIR]

    (`build`: the default --build, build-exp/ unless given); a script adds its own options
    to the parser and resolves the shared ones with outputs()."""
    ap = argparse.ArgumentParser(description=f"{name}: {title}")
    ap.add_argument("--quick", action="store_true", help="tiny sizes and ray counts (CI)")
    ap.add_argument("--build", default=str(build or default_build()), help="build folder holding `oblong`")
    ap.add_argument("--out", default=None, help=f"output folder (default: experiments/{name} in a full run)")
    ap.add_argument("--scratch", default=None, help="folder for temporary files (default: a temporary folder)")
    ap.add_argument("--reps", type=int, default=None, help="override the number of rounds")
    return ap


class UsageError(Exception):
    pass


def outputs(name: str, a: argparse.Namespace) -> tuple[Path, Path]:
    """The `oblong` binary and the output folder that arguments()' options name: --out, or
    experiments/NAME in a full run (a quick run needs --out, so that it never overwrites
    the committed results). UsageError when either is missing."""
    binary = Path(a.build) / "oblong"
    if not binary.exists():
        raise UsageError(f"{name}: {binary} not found (build it, or run experiments/run_all)")
    if a.out is None:
        if a.quick:
            raise UsageError(f"{name}: --quick needs --out (quick results never overwrite the committed ones)")
        return binary, EXPERIMENTS / name
    return binary, Path(a.out)


def main(module) -> int:
    ap = arguments(module.NAME, module.TITLE)
    # Used by `run_all --backend slurm` (lib/runstore.py, lib/slurm.py), not by hand.
    ap.add_argument("--store", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--store-pass", choices=["plan", "worker"], default="plan", help=argparse.SUPPRESS)
    ap.add_argument("--shard", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--session", default="", help=argparse.SUPPRESS)
    ap.add_argument("--plan-file", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--since", type=float, default=None, help=argparse.SUPPRESS)
    a = ap.parse_args()
    # A SIGTERM (a killed run_all, a cancelled Slurm job) unwinds like an error: the scratch
    # folder is removed.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(128 + signal.SIGTERM))
    global RUNNER
    store = None
    if a.store:
        store = RUNNER = runstore.Store(a.store, a.store_pass, a.shard, a.session)
    try:
        binary, out = outputs(module.NAME, a)
    except UsageError as e:
        print(e, file=sys.stderr)
        return 2
    scratch = Path(a.scratch) if a.scratch else Path(tempfile.mkdtemp(prefix=f"oblong-{module.NAME}-"))
    keep = a.scratch is not None
    ctx = Context(module.NAME, binary, out, scratch, a.quick, a.reps)
    started = datetime.datetime.now(datetime.timezone.utc)
    if store is not None and a.since:
        # Across passes and Slurm jobs: from the first pass on.
        ctx.start = a.since
        started = datetime.datetime.fromtimestamp(a.since, datetime.timezone.utc)
    status, summary = "ok", None
    try:
        summary = module.run(ctx)
        status = summary.get("status", "ok")
    except runstore.Pending as p:
        if a.plan_file:
            Path(a.plan_file).write_text(json.dumps({"pending": sorted(p.shards), "stored": store.reused,
                                                     "missing": store.missing}))
        print(f"[{module.NAME}] plan: {store.reused} runs stored, {store.missing} missing so far; to run: "
              + "; ".join(runstore.describe_shard(x) for x in sorted(p.shards)), flush=True)
        return 75
    except runstore.ShardDone:
        print(f"[{module.NAME}] {runstore.describe_shard(a.shard)}: {store.executed} run(s) executed and stored on "
              f"{store.node['host']}", flush=True)
        return 0
    except Exception as e:  # noqa: BLE001 - reported in the summary and the exit status
        traceback.print_exc()
        status = "failed"
        summary = {"status": "failed", "verdict": f"the experiment failed: {type(e).__name__}: {str(e)[:500]}",
                   "tables": [], "plots": []}
    finally:
        if not keep:
            shutil.rmtree(scratch, ignore_errors=True)
    elapsed = time.time() - ctx.start
    summary.update({
        "name": module.NAME,
        "title": module.TITLE,
        "hypothesis": module.HYPOTHESIS,
        "mode": "quick" if a.quick else "full",
        "status": status,
        "seconds": round(elapsed, 1),
        "runs": ctx.runs,
    })
    record = {
        "experiment": module.NAME,
        "mode": summary["mode"],
        "command": " ".join(["/usr/bin/python3", f"experiments/{module.NAME}/run.py"] + sys.argv[1:]),
        "started_utc": started.isoformat(timespec="seconds"),
        "seconds": round(elapsed, 1),
        "oblong_runs": ctx.runs,
        "status": status,
        "load_average_start": [round(x, 2) for x in ctx.load_start],
        "load_average_end": [round(x, 2) for x in os.getloadavg()],
        "machine": machine_info(),
        "build": build_info(binary),
        "statistics_compiled_in": stats_enabled(binary),
        "threads": ctx.threads,
        "rmip_levels": {k: f"resolution = max(map W, H) / {v}" for k, v in RMIP_LEVELS.items()},
        "configurations": ctx.configs,
        "scene_variants": ctx.scenes,
    }
    summary["machine"] = record["machine"]
    summary["build"] = record["build"]
    summary["load_average"] = [record["load_average_start"], record["load_average_end"]]
    summary["started_utc"] = record["started_utc"]
    if store is not None:
        if store.mode == "worker":
            print(f"[{module.NAME}] {runstore.describe_shard(a.shard)}: {store.executed} run(s) executed and stored "
                  f"on {store.node['host']}; {status}", flush=True)
            # A run that failed here fails the job, so that run_all reports it with this log.
            return 1 if status == "failed" else 0
        # Every run came from the store: where and in which Slurm job each ran.
        nodes = {u["host"]: u["cpu"] for u in store.used}
        record["backend"] = {"name": "slurm", "store": str(store.root), "nodes": nodes, "runs": store.used}
        summary["nodes"] = nodes
    # Paths inside the repository are written relative to its root.
    def dump(x):
        return json.dumps(x, indent=1, default=str, ensure_ascii=False).replace(str(ROOT) + "/", "") + "\n"

    (out / "run.json").write_text(dump(record))
    (out / "summary.json").write_text(dump(summary))
    print(f"[{module.NAME}] {status}: {summary.get('verdict', '')} ({elapsed:.0f} s, {ctx.runs} runs)", flush=True)
    return {"ok": 0, "mismatch": 3}.get(status, 1)
