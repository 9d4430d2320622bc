#!/usr/bin/env bash
# experiments/run_all --backend slurm against a real Slurm: starts a single-node cluster
# of its own (munged, slurmctld, slurmd from Debian's packages, installed by
# scripts/setup.sh) with its configuration, state, logs and MUNGE key in a temporary
# folder, on 127.0.0.1 and two free ports; runs a small subset of the quick experiments
# locally and through Slurm and compares the results; cancels a job on purpose and checks
# the report and the resumed rerun. The daemons are stopped and the folder removed
# whatever happens.
#
#   bash tests/slurm_test.sh BUILD_DIR        (CTest: label `slurm`)
set -euo pipefail

BUILD="$(cd "${1:?usage: slurm_test.sh BUILD_DIR}" && pwd)"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
PY=/usr/bin/python3
ONLY=steps,ablation_splitter
CANCEL=ablation_splitter  # the experiment whose job is cancelled on purpose
SKIP=77
LIMIT=180  # seconds for the whole test; CTest's TIMEOUT is only a backstop above it
T0=$(date +%s)

say() { echo "slurm_test: $*"; }
fail() { echo "slurm_test: FAIL: $*" >&2; exit 1; }
left() { local n=$(( T0 + LIMIT - $(date +%s) )); [ "$n" -gt 0 ] && echo "$n" || echo 1; }
# Runs a command in the background and waits for it: a signal then reaches the traps at
# once instead of after the command.
bg() { "$@" & RUN_PID=$!; local rc=0; wait "$RUN_PID" || rc=$?; RUN_PID=""; return "$rc"; }

if grep -qs '^OBLONG_SANITIZE:BOOL=ON' "$BUILD/CMakeCache.txt"; then
  # This checks run_all's Slurm backend, not oblong: the Release build's run covers it,
  # and a sanitized oblong would not fit the 3-minute budget.
  say "skipped in a sanitizer build"
  exit $SKIP
fi
[ -x "$BUILD/oblong" ] || fail "$BUILD/oblong not built"
for t in munged munge slurmctld slurmd sbatch squeue scancel scontrol sinfo; do
  command -v "$t" >/dev/null || fail "'$t' not found: run scripts/setup.sh (slurmctld slurmd slurm-client munge)"
done

# 0711: munged wants every directory above its socket searchable by all; the key's own
# folder stays private.
T="$(mktemp -d "${TMPDIR:-/tmp}/oblong-slurm-test.XXXXXX")"
chmod 711 "$T"
mkdir -m 700 "$T/munge"
mkdir -m 755 "$T/sock" "$T/state" "$T/spool" "$T/log"
export SLURM_CONF="$T/slurm.conf"

# The daemons run in the foreground as this script's children: a test runner that kills
# the process group on a timeout stops them too.
stop_pid() {  # stop_pid PID: TERM, up to 10 s, then KILL
  local pid="$1"
  [ -n "$pid" ] || return 0
  kill "$pid" 2>/dev/null || return 0
  for _ in $(seq 1 100); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  kill -9 "$pid" 2>/dev/null || true
}
exec 3>&1 4>&2  # the test's own output, for the cleanup that may run inside a redirection
cleanup() {
  local rc=$?
  set +e
  exec 1>&3 2>&4
  [ -n "${RUN_PID:-}" ] && kill "$RUN_PID" 2>/dev/null
  [ -n "${WATCH_PID:-}" ] && kill "$WATCH_PID" 2>/dev/null
  if [ -n "${CTLD_PID:-}" ]; then
    scancel --quiet --user="$(id -un)" 2>/dev/null
    for _ in $(seq 1 50); do [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break; sleep 0.2; done
  fi
  if [ "$rc" != 0 ] && [ "$rc" != "$SKIP" ]; then
    for f in "$T"/log/*.log; do [ -f "$f" ] && { echo "--- $f (last lines)"; tail -n 15 "$f"; }; done
  fi
  stop_pid "${SLURMD_PID:-}"
  stop_pid "${CTLD_PID:-}"
  stop_pid "${MUNGED_PID:-}"
  rm -rf "$T"
  say "finished in $(( $(date +%s) - T0 )) s (exit $rc)"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Two free TCP ports for the controller and the node daemon.
read -r PCTLD PSLURMD < <($PY -c '
import socket
ss = [socket.socket() for _ in range(2)]
for s in ss: s.bind(("127.0.0.1", 0))
print(*[s.getsockname()[1] for s in ss])')
HOST="$(hostname -s)"
NCPU="$(nproc)"
USER_NAME="$(id -un)"

head -c 1024 /dev/urandom > "$T/munge/munge.key"
chmod 400 "$T/munge/munge.key"
munged -F --socket="$T/sock/munge.sock" --key-file="$T/munge/munge.key" --pid-file="$T/munge/munged.pid" \
  --log-file="$T/log/munged.log" --seed-file="$T/munge/munged.seed" > "$T/log/munged.out.log" 2>&1 &
MUNGED_PID=$!
for _ in $(seq 1 50); do [ -S "$T/sock/munge.sock" ] && break; sleep 0.1; done
[ -S "$T/sock/munge.sock" ] || fail "munged did not start"

cat > "$SLURM_CONF" <<EOF
# Written by tests/slurm_test.sh: one node, this machine, 127.0.0.1 only.
ClusterName=oblongtest
SlurmctldHost=$HOST(127.0.0.1)
SlurmctldPort=$PCTLD
SlurmdPort=$PSLURMD
SlurmUser=$USER_NAME
SlurmdUser=$USER_NAME
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$T/sock/munge.sock
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
# No cgroups and no accounting daemon: nothing outside this folder is needed.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
ReturnToService=2
# Ended jobs stay visible to scontrol (run_all's job states without accounting).
MinJobAge=600
NodeName=$HOST NodeAddr=127.0.0.1 CPUs=$NCPU State=UNKNOWN
PartitionName=oblongtest Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF

slurmctld -D -f "$SLURM_CONF" > "$T/log/slurmctld.out.log" 2>&1 &
CTLD_PID=$!
slurmd -D -f "$SLURM_CONF" > "$T/log/slurmd.out.log" 2>&1 &
SLURMD_PID=$!
up=""
for _ in $(seq 1 150); do
  st="$(sinfo -h -o %T 2>/dev/null || true)"
  case "$st" in idle*|mixed*|allocated*) up=1; break ;; esac
  sleep 0.2
done
[ -n "$up" ] || fail "the Slurm node did not come up within 30 s (state '${st:-none}')"
say "Slurm up on $HOST (ports $PCTLD, $PSLURMD) in $(( $(date +%s) - T0 )) s"

# The build's copies of the scenes that read the asteroid (never /usr/share: the tests read
# only what the build makes); Slurm's jobs inherit the environment.
export OBLONG_SCENE_OVERRIDE="$BUILD/test_data/scenes"
RUN_ALL=("$PY" "$ROOT/experiments/run_all" --quick --build "$BUILD" --only "$ONLY")

# 1. The reference: the same subset run locally.
t=$(date +%s)
bg timeout "$(left)" "${RUN_ALL[@]}" --out "$T/local" > "$T/local.log" 2>&1 ||
  { cat "$T/local.log"; fail "local run failed"; }
say "local run: $(( $(date +%s) - t )) s"

# 2. Through Slurm, every array submitted held: the watcher cancels the one of $CANCEL
#    and releases the others, so the cancellation never races the job's end.
t=$(date +%s)
SLURM_ARGS=(--backend slurm --out "$T/slurm" --store "$T/store" --poll 0.3)
"${RUN_ALL[@]}" "${SLURM_ARGS[@]}" --sbatch-arg=--hold > "$T/run1.log" 2>&1 &
RUN_PID=$!
(
  cancelled=""
  while kill -0 "$RUN_PID" 2>/dev/null; do
    squeue -h -t PD -o '%F %j %r' 2>/dev/null | while read -r id name reason; do
      [ "$reason" = JobHeldUser ] || continue
      if [ "$name" = "oblong-$CANCEL" ] && [ ! -e "$T/cancelled" ]; then
        scancel "$id" && echo "$id" > "$T/cancelled"
      else
        scontrol release "$id"
      fi
    done
    sleep 0.2
  done
) &
WATCH_PID=$!
rc=0
while kill -0 "$RUN_PID" 2>/dev/null && [ "$(( $(date +%s) - T0 ))" -lt "$LIMIT" ]; do sleep 0.2; done
kill -0 "$RUN_PID" 2>/dev/null && { cat "$T/run1.log"; fail "run_all --backend slurm still running at $LIMIT s"; }
wait "$RUN_PID" || rc=$?
RUN_PID=""
wait "$WATCH_PID" || true
WATCH_PID=""
say "slurm run with a cancelled job: $(( $(date +%s) - t )) s, exit $rc"
grep "^run_all: " "$T/run1.log" | sed 's/^/slurm_test:   /'
[ -s "$T/cancelled" ] || { cat "$T/run1.log"; fail "no $CANCEL job was seen to cancel"; }
[ "$rc" = 1 ] || { cat "$T/run1.log"; fail "run_all exited $rc with a cancelled job (expected 1)"; }
report="$(grep "FAILED JOB: $CANCEL: job $(cat "$T/cancelled")_" "$T/run1.log" || true)"
say "cancelled-job report: $report"
case "$report" in
  *CANCELLED*"; log $T/store/jobs/"*) ;;
  *) cat "$T/run1.log"; fail "the cancelled job is not reported as CANCELLED with its log" ;;
esac
[ -s "$T/slurm/steps/results.csv" ] || { cat "$T/run1.log"; fail "steps did not complete beside the cancelled job"; }
[ ! -e "$T/slurm/$CANCEL/results.csv" ] || fail "$CANCEL has results although its job was cancelled"
find "$T/store/runs" -name result.json -printf '%P %T@\n' | sort > "$T/stored1"

# 3. The rerun: only the cancelled work is submitted; the stored runs are used as they are.
t=$(date +%s)
bg timeout "$(left)" "${RUN_ALL[@]}" "${SLURM_ARGS[@]}" > "$T/run2.log" 2>&1 ||
  { cat "$T/run2.log"; fail "the rerun failed"; }
say "rerun: $(( $(date +%s) - t )) s"
grep "^run_all: " "$T/run2.log" | sed 's/^/slurm_test:   /'
n_sub="$(grep -c "submitted job array" "$T/run2.log" || true)"
grep -q "submitted job array [0-9]* (1 task: asteroid, round 1)" "$T/run2.log" && [ "$n_sub" = 1 ] ||
  { cat "$T/run2.log"; fail "the rerun should submit exactly the cancelled $CANCEL shard"; }
grep -q "steps: ok after 1 pass, 0 Slurm tasks," "$T/run2.log" ||
  { cat "$T/run2.log"; fail "the rerun should take every steps run from the store"; }
find "$T/store/runs" -name result.json -printf '%P %T@\n' | sort > "$T/stored2"
comm -23 "$T/stored1" "$T/stored2" | grep -q . && fail "the rerun rewrote runs that were stored"
say "stored runs: $(wc -l < "$T/stored1") after the first run, $(wc -l < "$T/stored2") after the rerun"

# 4. Same numbers as the local run: everything but the timings equal, the timings there.
$PY - "$T/local" "$T/slurm" "$ONLY" <<'EOF'
import csv, json, sys
from pathlib import Path
local, slurm, names = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3].split(",")
TIMES = {"time_vs_canonical_median", "min", "max", "render_s_median"}
bad = []
for n in names:
    a = list(csv.DictReader(open(local / n / "results.csv")))
    b = list(csv.DictReader(open(slurm / n / "results.csv")))
    if len(a) != len(b) or not a or list(a[0]) != list(b[0]):
        bad.append(f"{n}: {len(a)} vs {len(b)} rows, columns {list(a[0]) if a else []} vs {list(b[0]) if b else []}")
        continue
    for ra, rb in zip(a, b):
        for k in ra:
            if k in TIMES:
                if not float(rb[k]) > 0:
                    bad.append(f"{n}: {k} missing in the Slurm run: {rb[k]!r}")
            elif ra[k] != rb[k]:
                bad.append(f"{n} {ra.get('scene')}/{ra.get('config', ra.get('strategy'))}: {k} {ra[k]} != {rb[k]}")
    sa = json.load(open(local / n / "summary.json"))
    sb = json.load(open(slurm / n / "summary.json"))
    if sa["runs"] != sb["runs"] or sb["status"] != "ok":
        bad.append(f"{n}: {sa['runs']} runs, status {sa['status']} locally; {sb['runs']}, {sb['status']} on Slurm")
    rj = json.load(open(slurm / n / "run.json"))
    runs = rj["backend"]["runs"]
    if len(runs) != sb["runs"] or not all(r["host"] and r["cpu"] and r["slurm_job"] for r in runs):
        bad.append(f"{n}: run.json does not name the node, CPU and job of every run")
    print(f"slurm_test: {n}: {len(a)} rows equal to the local run's; {len(runs)} runs on "
          f"{sorted(set(r['host'] for r in runs))}, jobs {sorted(set(r['slurm_job'] for r in runs))}")
if bad:
    print("slurm_test: FAIL: the Slurm results differ from the local ones:\n  " + "\n  ".join(bad), file=sys.stderr)
    sys.exit(1)
EOF
grep -q "Slurm" "$T/slurm/REPORT.md" || fail "REPORT.md does not say the runs ran on Slurm"

elapsed=$(( $(date +%s) - T0 ))
[ "$elapsed" -le "$LIMIT" ] || fail "took $elapsed s (budget $LIMIT s)"
say "PASS"
