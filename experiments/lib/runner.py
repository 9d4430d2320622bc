"""Running `oblong` here, the layer under both lib/common.py (what an experiment calls) and
lib/runstore.py (the store behind `run_all --backend slurm`): the repository's paths,
scene files, an experiment's Context, one run of `oblong` with its statistics, and the
schedule of interleaved rounds. It imports neither of them; standard library only.
"""
from __future__ import annotations

import json
import os
import random
import subprocess
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXPERIMENTS = ROOT / "experiments"
SCENES = ROOT / "scenes"
# A folder whose NAME.json replaces scenes/NAME.json where it exists: the tests point it at
# the build's copies (build/test_data/scenes/), which read the asteroid from the build
# instead of /usr/share.
SCENE_OVERRIDE = Path(os.environ["OBLONG_SCENE_OVERRIDE"]) if os.environ.get("OBLONG_SCENE_OVERRIDE") else None


class ExperimentError(RuntimeError):
    pass


def strip_json_comments(text: str) -> str:
    """Removes // and /* */ comments outside strings (the scene format allows them)."""
    out, i, n, in_str = [], 0, len(text), False
    while i < n:
        c = text[i]
        if in_str:
            out.append(c)
            if c == "\\" and i + 1 < n:
                out.append(text[i + 1])
                i += 2
                continue
            if c == '"':
                in_str = False
            i += 1
        elif c == '"':
            in_str = True
            out.append(c)
            i += 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            i = n if j < 0 else j + 2
        else:
            out.append(c)
            i += 1
    return "".join(out)


def load_scene(path: Path) -> dict:
    """A scene file as a dict, with relative mesh and map paths made absolute (so that a
    variant written elsewhere still finds them)."""
    path = Path(path)
    doc = json.loads(strip_json_comments(path.read_text()))
    for m in doc.get("meshes", []):
        if "file" in m and not os.path.isabs(m["file"]):
            m["file"] = str((path.parent / m["file"]).resolve())
        d = m.get("displacement")
        if d and not os.path.isabs(d["map"]):
            d["map"] = str((path.parent / d["map"]).resolve())
    return doc


def scene_path(name: str) -> Path:
    if SCENE_OVERRIDE is not None and (SCENE_OVERRIDE / f"{name}.json").is_file():
        return SCENE_OVERRIDE / f"{name}.json"
    return SCENES / f"{name}.json"



class Context:
    def __init__(self, name: str, binary: Path, out: Path, scratch: Path, quick: bool, reps: int | None,
                 threads: int = 1, log=None):
        self.name = name
        self.binary = Path(binary).resolve()
        self.out = Path(out)
        self.scratch = Path(scratch)
        self.quick = quick
        self.reps_override = reps
        self.threads = threads
        self.runs = 0
        self.scenes: dict[str, dict] = {}  # variant name -> the JSON written (recorded in run.json)
        self.variant_base: dict[str, str] = {}  # variant file -> the scene it varies (Slurm shards)
        self.configs: dict[str, dict] = {}  # label -> flags and the resolved config from the stats
        self.start = time.time()
        self.load_start = os.getloadavg()
        self._log = log or (lambda s: print(f"[{name}] {s}", flush=True))
        self.out.mkdir(parents=True, exist_ok=True)
        self.scratch.mkdir(parents=True, exist_ok=True)

    def log(self, s: str) -> None:
        self._log(s)

    def reps(self, full: int, quick: int = 1) -> int:
        if self.reps_override:
            return self.reps_override
        return quick if self.quick else full

    def pick(self, full, quick):
        return quick if self.quick else full

    def tmp(self, *parts) -> Path:
        p = self.scratch.joinpath(*parts)
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def write_scene(self, name: str, doc: dict) -> Path:
        """Writes a scene variant into the scratch folder and records it."""
        p = self.tmp("scenes", f"{name}.json")
        p.write_text(json.dumps(doc, indent=1))
        self.scenes[name] = doc
        return p

    def scene_variant(self, base: str, name: str, strategies: dict | None = None, displacement: dict | None = None,
                      image: dict | None = None) -> Path:
        doc = load_scene(scene_path(base))
        if strategies is not None:
            doc["strategies"] = strategies
        if displacement:
            for m in doc["meshes"]:
                if "displacement" in m:
                    m["displacement"].update(displacement)
        if image:
            doc["image"] = image
        p = self.write_scene(name, doc)
        self.variant_base[str(p.resolve())] = base
        return p

    def record_config(self, label: str, run: "Run") -> None:
        c = self.configs.setdefault(label, {"command": run.cmd_str(), "scene": run.scene,
                                            "resolved": run.stats.get("config"),
                                            "geometry": run.stats.get("geometry")})
        c.setdefault("memory", run.stats.get("memory"))


class Run:
    def __init__(self, cmd, scene, stats, wall, cpu, stdout):
        self.cmd, self.scene, self.stats, self.wall, self.cpu, self.stdout = cmd, scene, stats, wall, cpu, stdout

    def cmd_str(self) -> str:
        return " ".join(str(Path(c).relative_to(ROOT)) if str(c).startswith(str(ROOT) + "/") else str(c)
                        for c in self.cmd)

    @property
    def seconds(self) -> float:
        s = self.stats["seconds"]
        return s["render"] if "render" in s else s["trace"]

    @property
    def build_seconds(self) -> float:
        return self.stats["seconds"]["build"]


def run_here(ctx: Context, sub: str, scene, args: list, label: str | None = None, timeout: float = 600,
             threads: int | None = None) -> Run:
    """Runs `oblong SUB SCENE ARGS --threads N --stats TMP.json` here and now; the parsed
    stats, the process's wall time and CPU time (user + system, from wait4). Raises
    ExperimentError when oblong fails."""
    fd, stats_path = tempfile.mkstemp(suffix=".json", dir=ctx.scratch)
    os.close(fd)
    th = ctx.threads if threads is None else threads
    cmd = [str(ctx.binary), sub, str(scene)] + [str(a) for a in args] + ["--threads", str(th), "--stats", stats_path]
    if sub == "render":
        cmd.append("-q")
        if "-o" not in cmd:
            cmd += ["-o", str(ctx.tmp("render.png"))]
    t0 = time.time()
    with tempfile.TemporaryFile(dir=ctx.scratch) as fout, tempfile.TemporaryFile(dir=ctx.scratch) as ferr:
        p = subprocess.Popen(cmd, stdout=fout, stderr=ferr, cwd=ROOT)
        timer = threading.Timer(timeout, p.kill)
        timer.start()
        try:
            # wait4: the CPU time (user + system) of this child alone.
            _, status, ru = os.wait4(p.pid, 0)
        finally:
            timer.cancel()
        p.returncode = os.waitstatus_to_exitcode(status)
        wall = time.time() - t0
        cpu = ru.ru_utime + ru.ru_stime
        fout.seek(0)
        ferr.seek(0)
        out, err = fout.read(), ferr.read()
    if p.returncode != 0:
        if os.path.exists(stats_path):
            os.unlink(stats_path)
        raise ExperimentError(f"exit status {p.returncode}: {' '.join(cmd)}\n{err.decode(errors='replace')[-2000:]}")
    try:
        stats = json.load(open(stats_path))
    finally:
        os.unlink(stats_path)
    ctx.runs += 1
    r = Run(cmd, str(scene), stats, wall, cpu, out.decode(errors="replace"))
    if label:
        ctx.record_config(label, r)
    return r


def schedule(jobs: list, reps: int, seed: int = 1) -> list:
    """The interleaved rounds of `jobs`: `reps` lists, each every job once in a fresh random
    order (seeded), so that slow drifts of the machine's load hit all configurations
    alike. Every runner executes this schedule: a run's round and its place in the round
    are the same locally and through the run store."""
    rng = random.Random(seed)
    rounds = []
    for _ in range(reps):
        order = list(jobs)
        rng.shuffle(order)
        rounds.append(order)
    return rounds


class Local:
    """The default runner: every `oblong` run here and now, in the order asked for.
    lib/runstore.py's Store is the other one, with the same two methods."""

    def run(self, ctx: Context, sub: str, scene, args: list, label: str | None, timeout: float,
            threads: int | None) -> Run:
        return run_here(ctx, sub, scene, args, label, timeout, threads)

    def rounds(self, ctx: Context, rounds: list) -> list:
        """Runs schedule()'s rounds of (key, sub, scene, args) jobs in order; per round the
        Runs in the round's order."""
        out = []
        for i, order in enumerate(rounds):
            out.append([run_here(ctx, sub, scene, args, label=key) for key, sub, scene, args in order])
            ctx.log(f"round {i + 1}/{len(rounds)} done ({len(order)} runs, load {os.getloadavg()[0]:.1f})")
        return out


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo ("?" where it cannot be read)."""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "?"
