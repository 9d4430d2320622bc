"""`experiments/run_all --backend slurm`: Slurm does the scheduling, this only writes job
scripts, submits them (sbatch), polls (squeue) and gathers.

Per experiment, in passes (lib/runstore.py): a plan pass here names the shards (scene,
round) whose runs are missing from the store; they are submitted as one job array (one
task per shard); when the array has ended the experiment is planned again, until the
plan pass finds every run and writes the results as a local run would. All experiments
advance side by side. A task that failed, timed out or was cancelled is reported with
its log, and its experiment stops there (the runs already stored are kept: a rerun of
run_all submits only what is missing).

Everything lives under the store folder, which every node must see at the same path
(as must the repository and the build): runs/ (the stored runs, by key) and
jobs/SESSION/NAME-passN/ (job script, shards.txt, one log and one exit-status file
per task).
"""
from __future__ import annotations

import datetime
import json
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import runstore

TEMPFAIL = 75  # a plan pass found missing runs (common.main)
# Final states in which a task did not do its work (sacct / scontrol spelling).
BAD_STATES = ("FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL", "PREEMPTED", "OUT_OF_MEMORY", "BOOT_FAIL", "DEADLINE")


def _run(cmd: list, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def expand_tasks(spec: str) -> list:
    """ArrayTaskId as scontrol prints it: '3', '0-4', '1,3-5', '0-7%2'."""
    out = []
    for part in spec.split("%")[0].split(","):
        if not part:
            continue
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def task_states(job: str) -> dict:
    """{task: {"state", "exit", "node", "reason"}} for an ended array: from sacct when
    accounting is on, and from scontrol for the tasks sacct does not know (the controller
    keeps ended jobs MinJobAge seconds; a task of a larger array cancelled before it
    started may have no record at all)."""
    st = {}
    try:
        p = _run(["sacct", "-j", job, "-n", "-P", "-X", "-o", "JobID,State,ExitCode,NodeList"])
        if p.returncode == 0:
            for line in p.stdout.splitlines():
                f = line.split("|")
                m = re.match(rf"^{re.escape(job)}_(\[?)([0-9,%-]+)\]?$", f[0]) if len(f) >= 4 else None
                if m:
                    for t in expand_tasks(m.group(2)):
                        st[t] = {"state": f[1].split()[0], "exit": f[2], "node": f[3], "reason": ""}
    except (OSError, subprocess.TimeoutExpired):
        pass
    try:
        p = _run(["scontrol", "show", "job", "-o", job])
    except (OSError, subprocess.TimeoutExpired):
        return st
    for line in p.stdout.splitlines():
        kv = dict(re.findall(r"(\w+)=(\S*)", line))
        if "ArrayTaskId" not in kv:
            continue
        for t in expand_tasks(kv["ArrayTaskId"]):
            if t in st:
                continue  # sacct said it
            st[t] = {"state": kv.get("JobState", "?"), "exit": kv.get("ExitCode", "?"),
                     "node": kv.get("NodeList", ""), "reason": kv.get("Reason", "")}
    return st


def job_active(job: str) -> bool:
    try:
        p = _run(["squeue", "-h", "-r", "-j", job, "-o", "%i %T"])
    except subprocess.TimeoutExpired:
        return True  # a busy controller: ask again at the next poll
    # An unknown id (the job ended long ago and was purged) is an error: it is not active.
    return p.returncode == 0 and bool(p.stdout.strip())


class Experiment:
    def __init__(self, name: str):
        self.name = name
        self.passes = 0
        self.job = None  # (job id, pass folder, shards)
        self.last_pending = None
        self.status = None  # final: "ok", "mismatch", "failed (...)"
        self.started = time.time()
        self.submitted = 0


class SlurmBackend:
    def __init__(self, a, root: Path, here: Path, py: str, build: Path, out: Path):
        self.a, self.root, self.here, self.py, self.build, self.out = a, root, here, py, build, out
        self.store = Path(a.store).resolve() if a.store else build / "slurm-runs"
        self.session = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ") + f"-{os.getpid()}"
        self.jobs_dir = self.store / "jobs" / self.session
        self.failures: list = []
        self.job_failed: set = set()  # experiments stopped by a job that did not complete

    def log(self, s: str) -> None:
        print(f"run_all: {s}", flush=True)

    def check_tools(self) -> str | None:
        for t in ("sbatch", "squeue", "scontrol"):
            if not any((Path(d) / t).exists() for d in os.environ.get("PATH", "").split(":")):
                return f"`{t}` not found: the Slurm client commands are needed (Debian: slurm-client)"
        p = _run(["squeue", "-h", "-o", "%i", "-u", str(os.getuid())])
        if p.returncode != 0:
            return "squeue failed (is a Slurm controller reachable? SLURM_CONF?): " + p.stderr.strip()[-300:]
        return None

    def _exp_args(self, name: str) -> list:
        cmd = [self.py, str(self.here / name / "run.py"), "--build", str(self.build)]
        if self.a.quick:
            cmd.append("--quick")
        if self.a.reps:
            cmd += ["--reps", str(self.a.reps)]
        return cmd + ["--store", str(self.store), "--session", self.session]

    def plan(self, e: Experiment) -> None:
        """One plan pass: either the experiment is complete (its results written) or its
        missing shards are submitted as one array."""
        e.passes += 1
        d = self.jobs_dir / f"{e.name}-pass{e.passes}"
        d.mkdir(parents=True, exist_ok=True)
        plan_file = d / "plan.json"
        cmd = self._exp_args(e.name) + ["--out", str(self.out / e.name), "--store-pass", "plan",
                                        "--plan-file", str(plan_file), "--since", str(e.started)]
        rc = subprocess.run(cmd, cwd=self.root).returncode
        if rc != TEMPFAIL:
            e.status = {0: "ok", 3: "mismatch"}.get(rc, f"failed (exit {rc})")
            return
        plan = json.loads(plan_file.read_text())
        shards = plan["pending"]
        if shards == e.last_pending:
            e.status = "failed (its jobs ended but stored nothing of: " + ", ".join(shards) + ")"
            return
        e.last_pending = shards
        self.submit(e, d, shards)

    def submit(self, e: Experiment, d: Path, shards: list) -> None:
        (d / "shards.txt").write_text("".join(s + "\n" for s in shards))
        worker = " ".join(shlex.quote(c) for c in self._exp_args(e.name) + [
            "--out", str(d / "out"), "--store-pass", "worker", "--shard"])
        script = d / "job.sh"
        script.write_text(f"""#!/bin/bash
# experiments/run_all --backend slurm: {e.name}, pass {e.passes}; task i runs line i+1 of shards.txt.
shard=$(sed -n "$((SLURM_ARRAY_TASK_ID + 1))p" {shlex.quote(str(d / 'shards.txt'))})
echo "{e.name}: $shard on $(hostname), job ${{SLURM_ARRAY_JOB_ID}}_${{SLURM_ARRAY_TASK_ID}}"
cd {shlex.quote(str(self.root))}
{worker} "$shard"
rc=$?
echo "$rc" > {shlex.quote(str(d))}/task-${{SLURM_ARRAY_TASK_ID}}.rc
exit "$rc"
""")
        script.chmod(0o755)
        arr = f"0-{len(shards) - 1}" + (f"%{self.a.max_jobs}" if self.a.max_jobs else "")
        cmd = ["sbatch", "--parsable", f"--array={arr}", f"--job-name=oblong-{e.name}",
               f"--output={d}/task-%a.log"]
        for opt in ("partition", "time", "account"):
            v = getattr(self.a, opt)
            if v:
                cmd.append(f"--{opt}={v}")
        cmd += list(self.a.sbatch_arg or [])
        cmd.append(str(script))
        p = _run(cmd, timeout=120)
        if p.returncode != 0:
            e.status = f"failed (sbatch: {p.stderr.strip()[-300:]})"
            return
        job = p.stdout.strip().split(";")[0]
        e.job = (job, d, shards)
        e.submitted += len(shards)
        self.log(f"{e.name}: submitted job array {job} ({len(shards)} task{'s' if len(shards) > 1 else ''}: "
                 + "; ".join(runstore.describe_shard(s) for s in shards) + f"), logs in {d}")

    def collect(self, e: Experiment) -> None:
        """The array has ended: did every task do its work?"""
        job, d, shards = e.job
        e.job = None
        states = None
        bad = []
        for i, s in enumerate(shards):
            rcf = d / f"task-{i}.rc"
            rc = rcf.read_text().strip() if rcf.exists() else None
            if rc == "0":
                continue
            if states is None:
                states = task_states(job)
            st = states.get(i, {})
            state = st.get("state", "")
            if rc is None and state == "COMPLETED":
                continue  # the status file is not visible yet; the scheduler saw exit 0
            what = state or ("no record (cancelled before it started, or purged)" if rc is None else "FAILED")
            if rc not in (None, "0"):
                what += f", exit status {rc}"
            if st.get("reason") and st["reason"] not in ("None", ""):
                what += f", reason {st['reason']}"
            logf = d / f"task-{i}.log"
            bad.append(f"{e.name}: job {job}_{i} ({runstore.describe_shard(s)}) {what}; log {logf}"
                       + ("" if logf.exists() else " (not written: the task never started)"))
        if bad:
            for b in bad:
                print(f"run_all: FAILED JOB: {b}", file=sys.stderr, flush=True)
            self.failures += bad
            self.job_failed.add(e.name)
            e.status = f"failed ({len(bad)} of {len(shards)} Slurm jobs did not complete)"

    def run(self, names: list) -> dict:
        err = self.check_tools()
        if err:
            self.log(f"--backend slurm: {err}")
            return {n: "failed (no Slurm)" for n in names}
        self.log(f"slurm backend: store {self.store}, session {self.session}")
        exps = [Experiment(n) for n in names]
        poll = self.a.poll
        try:
            while True:
                for e in exps:
                    if e.status is None and e.job is None:
                        self.plan(e)
                        if e.status is not None:
                            self.log(f"{e.name}: {e.status} after {e.passes} pass{'es' if e.passes > 1 else ''}, "
                                     f"{e.submitted} Slurm task{'' if e.submitted == 1 else 's'}, "
                                     f"{time.time() - e.started:.0f} s")
                waiting = [e for e in exps if e.job is not None]
                if not waiting:
                    if all(e.status is not None for e in exps):
                        break
                    continue
                time.sleep(poll)
                for e in waiting:
                    if not job_active(e.job[0]):
                        self.collect(e)
                        if e.status is not None:
                            self.log(f"{e.name}: {e.status}")
        except KeyboardInterrupt:
            left = [e.job[0] for e in exps if e.job is not None]
            if left:
                self.log("interrupted; jobs still queued or running: " + " ".join(left) +
                         " (scancel them, or let them finish: a rerun uses what they stored)")
            raise
        return {e.name: e.status for e in exps}
