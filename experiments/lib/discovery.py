"""The experiments of the paper's evaluation, found from their folders (experiments/README.md,
"Adding an experiment").

`experiments/NAME/` is one when its `run.py` has, at module level, the interface that
common.main runs: `NAME = "NAME"` (the folder's name, a string literal), `TITLE`,
`HYPOTHESIS` and `def run(ctx)`. A `run.py` with none of the four is another kind of
script (a benchmark's, say) and is left out; one with only some of them is an error,
so that a half-made experiment is reported instead of silently skipped. The files are
parsed, not imported: finding the experiments runs none of their code and needs none
of their imports. Standard library only.
"""
from __future__ import annotations

import ast
from pathlib import Path

INTERFACE = ("NAME", "TITLE", "HYPOTHESIS", "run")


class DiscoveryError(Exception):
    pass


def _interface(run_py: Path) -> dict:
    """The module-level names of INTERFACE that run_py defines, each with its AST node."""
    try:
        tree = ast.parse(run_py.read_text(), filename=str(run_py))
    except SyntaxError as e:
        raise DiscoveryError(f"{run_py}: {e}") from e
    found = {}
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                if isinstance(t, ast.Name) and t.id in INTERFACE[:3]:
                    found[t.id] = node.value
        elif isinstance(node, ast.FunctionDef) and node.name == "run":
            found["run"] = node
    return found


def is_experiment(folder: Path) -> bool:
    """Whether `folder` holds an experiment of the evaluation; DiscoveryError when its
    run.py has only part of the interface or a NAME other than the folder's."""
    run_py = Path(folder) / "run.py"
    if not run_py.is_file():
        return False
    found = _interface(run_py)
    if not found:
        return False
    missing = [n for n in INTERFACE if n not in found]
    if missing:
        raise DiscoveryError(f"{run_py}: has {', '.join(n for n in INTERFACE if n in found)} but not "
                             f"{', '.join(missing)} (an experiment needs all of {', '.join(INTERFACE)})")
    name = found["NAME"]
    if not (isinstance(name, ast.Constant) and name.value == run_py.parent.name):
        raise DiscoveryError(f"{run_py}: NAME must be the string \"{run_py.parent.name}\", its folder's name")
    return True


def find(experiments: Path) -> list:
    """The names of the experiments under `experiments` (the folder), sorted."""
    return sorted(p.name for p in Path(experiments).iterdir() if p.is_dir() and is_experiment(p))
