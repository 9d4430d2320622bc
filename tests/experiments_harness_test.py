#!/usr/bin/env python3
"""The experiments' harness (experiments/README.md, "Adding an experiment" and "Shared code"):

- no import cycle among experiments/lib/'s modules and run_all (every import statement,
  those inside functions too), and in a fresh interpreter `import runner` loads neither
  common nor runstore, `import runstore` does not load common;
- the order of interleaved rounds is made in one place: only lib/runner.py shuffles;
- `run_all --list` names every experiment folder: on the repository, exactly the
  folders whose run.py calls common.main, a superset of those with committed results;
  on a tree of its own (run_all and lib/ copied into the temporary folder) it finds a
  new folder, leaves other scripts out, sorts, and refuses a half-made experiment;
- rmip_layout's quick run (the build's oblong, the build's asteroid) records no
  absolute path, and its committed results name none.

    python3 tests/experiments_harness_test.py --root SRC --build BUILD

Writes only under a temporary folder inside BUILD, removed at the end; no bytecode.
Exits 1 with one line per failure.
"""
import argparse
import ast
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

FAILURES = []


def check(ok: bool, what: str) -> None:
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        FAILURES.append(what)


def env() -> dict:
    return dict(os.environ, PYTHONDONTWRITEBYTECODE="1")


def imports(path: Path) -> set:
    """Top-level module names `path` imports, anywhere in the file."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module.split(".")[0])
    return out


def cycle(graph: dict) -> list:
    """One import cycle of `graph` (module -> modules it imports) as a path, or []."""
    state = {}

    def visit(m, path):
        state[m] = "open"
        for n in sorted(graph.get(m, ())):
            if state.get(n) == "open":
                return path[path.index(n):] + [n] if n in path else [m, n]
            if n not in state:
                found = visit(n, path + [n])
                if found:
                    return found
        state[m] = "done"
        return []

    for m in sorted(graph):
        if m not in state:
            found = visit(m, [m])
            if found:
                return found
    return []


def check_imports(experiments: Path) -> None:
    lib = experiments / "lib"
    modules = {p.stem: p for p in sorted(lib.glob("*.py"))}
    graph = {m: imports(p) & set(modules) for m, p in modules.items()}
    graph["run_all"] = imports(experiments / "run_all") & set(modules)
    for m in ("common", "runstore", "runner"):
        check(m in modules, f"experiments/lib/{m}.py exists")
    c = cycle(graph)
    check(not c, "no import cycle in experiments/lib/ and run_all" + (f": {' -> '.join(c)}" if c else ""))
    for mod, must_not in (("runner", ["common", "runstore"]), ("runstore", ["common"])):
        code = (f"import sys; sys.path.insert(0, {str(lib)!r}); import {mod}; "
                f"print(' '.join(m for m in {must_not!r} if m in sys.modules))")
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env())
        check(p.returncode == 0 and p.stdout.strip() == "",
              f"`import {mod}` loads none of {', '.join(must_not)}"
              + (f" (loaded: {p.stdout.strip()}; {p.stderr.strip()[-300:]})" if p.stdout.strip() or p.returncode else ""))
    shufflers = sorted(m for m, p in modules.items() if re.search(r"\.shuffle\(|\.sample\(|\.permutation\(",
                                                                  p.read_text()))
    check(shufflers == ["runner"], f"only runner.py orders the rounds (modules that shuffle: {shufflers})")


def run_all_list(experiments: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(experiments / "run_all"), "--list"], capture_output=True, text=True,
                          env=env(), timeout=60)


def check_discovery(experiments: Path, tmp: Path) -> None:
    p = run_all_list(experiments)
    listed = p.stdout.split()
    check(p.returncode == 0 and listed, f"run_all --list runs on the repository (exit {p.returncode}) "
                                        f"{p.stderr.strip()[-300:]}")
    entry = re.compile(r"^\s*sys\.exit\(.*\b(C|common)\.main\(", re.M)
    with_main = sorted(d.name for d in experiments.iterdir() if (d / "run.py").is_file()
                       and entry.search((d / "run.py").read_text()))
    committed = sorted(d.name for d in experiments.iterdir() if (d / "summary.json").is_file())
    check(len(with_main) >= 12, f"the repository has its experiments ({len(with_main)} run.py call common.main)")
    check(listed == with_main, f"run_all --list names every folder whose run.py calls common.main, sorted "
                               f"(listed {listed}, expected {with_main})")
    check(set(committed) <= set(listed), f"every folder with a committed summary.json is listed "
                                         f"(not listed: {sorted(set(committed) - set(listed))})")

    # A tree of its own: run_all finds what is there, not what it was told.
    root = tmp / "tree"
    exp = root / "experiments"
    shutil.copytree(experiments / "lib", exp / "lib", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy2(experiments / "run_all", exp / "run_all")

    def write(folder, text):
        (exp / folder).mkdir(parents=True, exist_ok=True)
        (exp / folder / "run.py").write_text(text)

    def experiment(name):
        return (f'NAME = "{name}"\nTITLE = "t"\nHYPOTHESIS = ("h"\n              "h")\n\n\n'
                f"def run(ctx):\n    return {{}}\n")
    for n in ("zeta", "alpha", "mid"):
        write(n, experiment(n))
    write("bench", "import argparse\n\n\ndef main():\n    return 0\n")  # another kind of script
    (exp / "notes").mkdir()
    (exp / "notes" / "README.md").write_text("no run.py\n")
    p = run_all_list(exp)
    check(p.returncode == 0 and p.stdout.split() == ["alpha", "mid", "zeta"],
          f"run_all --list on a tree of its own finds alpha, mid, zeta in order (got {p.stdout.split()}, exit "
          f"{p.returncode}) {p.stderr.strip()[-300:]}")
    write("half", 'NAME = "half"\nTITLE = "t"\n')
    p = run_all_list(exp)
    check(p.returncode == 2 and "half/run.py" in p.stderr and "HYPOTHESIS" in p.stderr,
          f"run_all refuses a run.py with part of the interface (exit {p.returncode}: {p.stderr.strip()[-300:]})")
    shutil.rmtree(exp / "half")
    write("renamed", experiment("other"))
    p = run_all_list(exp)
    check(p.returncode == 2 and "renamed/run.py" in p.stderr,
          f"run_all refuses a NAME other than the folder's (exit {p.returncode}: {p.stderr.strip()[-300:]})")


ABSOLUTE = re.compile(r"(?<![\w.~-])/(?:[\w.-]+/)+oblong\b")


def check_rmip_layout(experiments: Path, build: Path, tmp: Path) -> None:
    folder = experiments / "rmip_layout"
    for f in sorted(folder.iterdir()):
        if f.suffix in (".md", ".csv"):
            m = ABSOLUTE.search(f.read_text())
            check(m is None, f"committed {f.relative_to(experiments.parent)} names no absolute path"
                             + (f" (it names {m.group(0)})" if m else ""))
    if not (build / "oblong").exists():
        check(False, f"{build}/oblong exists (rmip_layout's quick run needs it)")
        return
    out = tmp / "rmip_layout"
    e = env()
    e["OBLONG_SCENE_OVERRIDE"] = str(build / "test_data" / "scenes")
    p = subprocess.run([sys.executable, str(folder / "run.py"), "--quick"], capture_output=True, text=True, env=e,
                       timeout=60)
    check(p.returncode == 2 and "--out" in p.stderr, "rmip_layout --quick without --out is refused (exit "
                                                     f"{p.returncode}), like every experiment's")
    p = subprocess.run([sys.executable, str(folder / "run.py"), "--quick", "--build", str(build), "--out", str(out),
                        "--scratch", str(tmp / "scratch")], capture_output=True, text=True, env=e, timeout=600)
    check(p.returncode == 0, f"rmip_layout --quick runs (exit {p.returncode}) {p.stderr.strip()[-500:]}")
    if p.returncode != 0:
        return
    md, csv = (out / "results.md").read_text(), (out / "results.csv").read_text()
    check(len(csv.strip().splitlines()) == 5, "rmip_layout --quick writes one row per layout (4)")
    for text, name in ((md, "results.md"), (csv, "results.csv")):
        bad = [s for s in (str(build.resolve()), str(experiments.parent.resolve()), str(tmp)) if s in text]
        m = ABSOLUTE.search(text)
        check(not bad and m is None, f"rmip_layout's {name} names no absolute path"
                                     + (f" ({bad or m.group(0)})" if bad or m else ""))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", default=str(Path(__file__).resolve().parents[1]))
    ap.add_argument("--build", required=True)
    a = ap.parse_args()
    sys.dont_write_bytecode = True
    experiments = Path(a.root).resolve() / "experiments"
    build = Path(a.build).resolve()
    tmp = Path(tempfile.mkdtemp(prefix="experiments_harness_", dir=build))
    try:
        check_imports(experiments)
        check_discovery(experiments, tmp)
        check_rmip_layout(experiments, build, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
