"""The run store behind `run_all --backend slurm`: every `oblong` run of an experiment
kept on a shared filesystem under a key that hashes its resolved configuration and
inputs, so that runs can execute in Slurm jobs on other nodes, be gathered by the
process that writes the experiment's results, and be skipped when run_all is rerun.

An experiment's `run(ctx)` is not changed for this. It is executed in passes, with
`common.run_oblong` and `common.interleaved` answered from the store (a Store is the
runner common.py hands its runs to, in place of runner.Local; the rounds and their
orders are runner.schedule's either way):

- plan (on the submitting machine): every run the experiment asks for is looked up.
  When one is missing, the pass stops (raises Pending) and names the shards that are
  missing; run_all submits one array task per shard and plans again once they ended.
  When none is missing, the experiment completes as in a local run: the same code
  writes results.csv, the plots and the summary from the stored runs.
- worker (one Slurm array task): executes the runs of its shard and stores them; it
  stops (ShardDone) at the first missing run of another shard.

A shard is (scene, round): the scene is the repository scene a run's scene file is, or
is a variant of (generated scenes form one shard), the round is the interleaved round
(0 for runs outside `interleaved`). A round of one scene therefore runs on one node, in
the order a local run would use, and every ratio an experiment takes between
configurations of a scene in a round compares runs on the same node side by side; a
round that is only partly stored is run again whole for the same reason.

The key: sha256 over the experiment's name, the binary's sha256, the subcommand, the
arguments (an input file by its content, an output file by its type), the thread count,
the scene file's text and the content of the meshes and maps it names, and the run's
occurrence (the n-th identical request: the round of a repeated timing).
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import shutil
import socket
import time
from pathlib import Path

import runner

OUTPUT_FLAGS = ("-o", "--aovs")
GENERATED = "generated"  # the shard name of scenes an experiment writes from scratch


class Pending(BaseException):
    """Plan pass: runs are missing. A BaseException so that an experiment's own
    `except Exception` (a refused scene is a result there) cannot swallow it."""

    def __init__(self, shards):
        super().__init__(", ".join(sorted(shards)))
        self.shards = set(shards)


class ShardDone(BaseException):
    """Worker pass: the next missing run belongs to another shard."""


_DIGESTS: dict = {}


def file_digest(path) -> str:
    p = Path(path)
    st = p.stat()
    k = (str(p.resolve()), st.st_size, st.st_mtime_ns)
    if k not in _DIGESTS:
        h = hashlib.sha256()
        with open(p, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        _DIGESTS[k] = h.hexdigest()
    return _DIGESTS[k]


def shard_name(group: str, rnd: int) -> str:
    return f"{group}#{rnd}"


def parse_shard(s: str) -> tuple[str, int]:
    g, _, r = s.rpartition("#")
    return g, int(r)


def describe_shard(s: str) -> str:
    g, r = parse_shard(s)
    return f"{g}, round {r + 1}"


def node_info() -> dict:
    cpu = runner.cpu_model()
    job = os.environ.get("SLURM_ARRAY_JOB_ID")
    task = os.environ.get("SLURM_ARRAY_TASK_ID")
    return {"host": socket.gethostname() or platform.node(), "cpu": cpu,
            "slurm_job": f"{job}_{task}" if job and task else os.environ.get("SLURM_JOB_ID", "")}


class Store:
    def __init__(self, root, mode: str, shard: str | None = None, session: str = ""):
        self.root = Path(root)
        self.mode = mode  # "plan" or "worker"
        self.shard = shard
        self.session = session  # run_all's invocation: a failed run is retried by the next one
        self.runs_dir = self.root / "runs"
        self.runs_dir.mkdir(parents=True, exist_ok=True)
        self.counts: dict = {}  # base key -> occurrences so far (this pass)
        self.reused = 0
        self.executed = 0
        self.missing = 0
        self.used: list = []  # per run gathered: key, label, shard, node (for run.json)
        self.node = node_info()

    # --- keys -----------------------------------------------------------------------

    def _norm(self, ctx, s: str) -> str:
        return s.replace(str(ctx.scratch), "<scratch>").replace(str(runner.ROOT), "<root>")

    def group_of(self, ctx, scene) -> str:
        p = Path(scene).resolve()
        for folder in (runner.SCENES, runner.SCENE_OVERRIDE):
            try:
                return str(p.relative_to(folder.resolve()).with_suffix(""))
            except (ValueError, AttributeError):
                pass
        return ctx.variant_base.get(str(p), GENERATED)

    def base_key(self, ctx, sub: str, scene, args: list, threads: int) -> str:
        scene = Path(scene)
        doc = runner.load_scene(scene)
        data = []
        for m in doc.get("meshes", []):
            for f in (m.get("file"), (m.get("displacement") or {}).get("map")):
                if f and os.path.isfile(f):
                    data.append(file_digest(f))
        norm, prev = [], None
        for a in (str(x) for x in args):
            if prev in OUTPUT_FLAGS:
                norm.append("<output" + Path(a).suffix + ">")
            elif os.path.isfile(a):
                norm.append("<file " + file_digest(a) + ">")
            else:
                norm.append(self._norm(ctx, a))
            prev = a
        ident = {"experiment": ctx.name, "binary": file_digest(ctx.binary), "sub": sub, "args": norm,
                 "threads": threads, "scene": self._norm(ctx, scene.read_text()), "scene_data": data}
        return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()

    def key(self, ctx, sub, scene, args, threads) -> str:
        b = self.base_key(ctx, sub, scene, args, threads)
        n = self.counts.get(b, 0)
        self.counts[b] = n + 1
        return hashlib.sha256(f"{b}:{n}".encode()).hexdigest()[:24]

    # --- stored runs ----------------------------------------------------------------

    def _dir(self, key: str) -> Path:
        return self.runs_dir / key[:2] / key

    def stored(self, key: str) -> dict | None:
        """The stored record, if complete (result.json is renamed into place last). A
        failed run counts only within the run_all invocation that recorded it."""
        p = self._dir(key) / "result.json"
        if not p.exists():
            return None
        rec = json.loads(p.read_text())
        if not rec.get("ok") and rec.get("session") != self.session:
            return None
        return rec

    def _execute(self, ctx, key, shard, sub, scene, args, label, timeout, th):
        """Runs oblong here and stores the run: result.json and the output files."""
        d = self._dir(key)
        tmp = d.parent / f".{key}.{os.getpid()}.tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        rec = {"key": key, "experiment": ctx.name, "label": label, "shard": shard, "sub": sub,
               "session": self.session, "node": self.node,
               "finished_utc": None}
        try:
            r = runner.run_here(ctx, sub, scene, args, None, timeout, th)
        except runner.ExperimentError as e:
            rec.update({"ok": False, "error": str(e)})
            r = None
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)  # cancelled: nothing half-written stays
            raise
        if r is not None:
            outs = {}
            prev = None
            for i, a in enumerate(str(x) for x in args):
                if prev in OUTPUT_FLAGS and os.path.exists(a):
                    name = f"out{i}{Path(a).suffix}"
                    shutil.copyfile(a, tmp / name)
                    outs[str(i)] = name
                prev = a
            rec.update({"ok": True, "cmd": [self._norm(ctx, c) for c in map(str, r.cmd)], "stats": r.stats,
                        "wall": r.wall, "cpu": r.cpu, "stdout": r.stdout, "outputs": outs})
        rec["finished_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        (tmp / "result.json").write_text(json.dumps(rec))
        old = d.parent / f".{key}.{os.getpid()}.old"
        if d.exists():
            d.rename(old)
        tmp.rename(d)
        shutil.rmtree(old, ignore_errors=True)
        self.executed += 1
        return rec

    def _load(self, ctx, rec, sub, scene, args, label, threads):
        """A stored run as a runner.Run, its output files copied where this call wants them."""
        if not rec.get("ok"):
            raise runner.ExperimentError(rec.get("error", "failed"))
        args = [str(a) for a in args]
        for i, name in rec.get("outputs", {}).items():
            dst = Path(args[int(i)])
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(self._dir(rec["key"]) / name, dst)
        th = ctx.threads if threads is None else threads
        cmd = [str(ctx.binary), sub, str(scene)] + args + ["--threads", str(th), "--stats", "<stored>"]
        ctx.runs += 1
        r = runner.Run(cmd, str(scene), rec["stats"], rec["wall"], rec["cpu"], rec["stdout"])
        if label:
            ctx.record_config(label, r)
        self.used.append({"label": label, "shard": rec["shard"], "key": rec["key"], **rec["node"],
                          "finished_utc": rec["finished_utc"]})
        return r

    # --- the runner's two methods (as runner.Local's) ---------------------------------

    def run(self, ctx, sub, scene, args, label, timeout, threads):
        th = ctx.threads if threads is None else threads
        key = self.key(ctx, sub, scene, args, th)
        shard = shard_name(self.group_of(ctx, scene), 0)
        rec = self.stored(key)
        if rec is not None:
            self.reused += 1
        elif self.mode == "worker" and shard == self.shard:
            rec = self._execute(ctx, key, shard, sub, scene, args, label, timeout, th)
        elif self.mode == "worker":
            raise ShardDone()
        else:
            self.missing += 1
            raise Pending({shard})
        return self._load(ctx, rec, sub, scene, args, label, threads)

    def rounds(self, ctx, rounds: list) -> list:
        """runner.schedule's rounds of (key, sub, scene, args) jobs from the store; per round
        the Runs in the round's order. A worker executes its shard's rounds that are not
        stored whole, in the round's order."""
        keyed = [[(job, self.key(ctx, job[1], job[2], job[3], ctx.threads),
                   shard_name(self.group_of(ctx, job[2]), rep)) for job in order]
                 for rep, order in enumerate(rounds)]
        recs = {k: self.stored(k) for rnd in keyed for _, k, _ in rnd}
        if self.mode == "worker":
            for rep, rnd in enumerate(keyed):
                mine = [(job, k) for job, k, s in rnd if s == self.shard]
                if mine and any(recs[k] is None for _, k in mine):
                    ctx.log(f"round {rep + 1}/{len(keyed)}: {len(mine)} runs of {describe_shard(self.shard)} on "
                            f"{self.node['host']}")
                    for (key_, sub, scene, args), k in mine:
                        recs[k] = self._execute(ctx, k, self.shard, sub, scene, args, key_, 600, ctx.threads)
            if any(r is None for r in recs.values()):
                raise ShardDone()
        else:
            missing = {s for rnd in keyed for _, k, s in rnd if recs[k] is None}
            if missing:
                self.missing += sum(1 for r in recs.values() if r is None)
                self.reused += sum(1 for r in recs.values() if r is not None)
                raise Pending(missing)
        self.reused += len(recs)
        return [[self._load(ctx, recs[k], sub, scene, args, key_, None) for (key_, sub, scene, args), k, _ in rnd]
                for rnd in keyed]
