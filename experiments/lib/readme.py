"""The result block of an experiment's README, written from its summary.json.

Every number an experiment's README quotes about its results comes from the run that
produced them: `experiments/run_all` rewrites the block after a full run (and alone with
`--readmes`), and scripts/check_docs.py (CTest `docs`) fails when a block differs from
what the committed summary.json gives. The block sits between the marker lines BEGIN
and END below (HTML comments, invisible when rendered):

    <!-- result: written from summary.json by ... -->
    **Result** (full run 2026-12-04 00:27 UTC, the build, the machine, the load; 706 s, 198 runs):
    ...the summary's tables, plots and verdict...
    <!-- end of result -->

Anything outside the markers is hand-written and kept as it is. Standard library only:
check_docs.py imports this with whatever `python3` is on PATH.
"""
from __future__ import annotations

import datetime
import json
from pathlib import Path

BEGIN = ("<!-- result: written from summary.json by experiments/run_all (experiments/lib/readme.py); "
         "edits here are overwritten -->")
END = "<!-- end of result -->"
FIX = "run experiments/run_all --readmes"


class ReadmeError(Exception):
    """A README whose result block cannot be rewritten; the message is one line naming the file."""


def _plural(n, word: str) -> str:
    return f"{n} {word}" + ("" if n == 1 else "s")


def _when(started: str) -> str:
    try:
        t = datetime.datetime.fromisoformat(started)
    except (TypeError, ValueError):
        return str(started)
    if t.tzinfo is not None:
        t = t.astimezone(datetime.timezone.utc)
    return t.strftime("%Y-%m-%d %H:%M UTC")


def _build(b: dict) -> str:
    parts = []
    cm = b.get("cmake") or {}
    if cm.get("CMAKE_BUILD_TYPE"):
        parts.append(cm["CMAKE_BUILD_TYPE"])
    stats = str(cm.get("OBLONG_STATS", "")).upper()
    if stats:
        parts.append("statistics " + ("on" if stats in ("ON", "1", "TRUE", "YES") else "off"))
    git = b.get("git") or {}
    if git.get("commit"):
        g = f"git {git['commit'][:7]}"
        m = git.get("modified_tracked_files")
        if isinstance(m, int):
            g += " (no tracked file modified)" if m == 0 else f" ({_plural(m, 'tracked file')} modified)"
        parts.append(g)
    text = ", ".join(parts)
    if b.get("binary"):
        text = f"{b['binary']}: {text}" if text else str(b["binary"])
    return text


def _machine(m: dict) -> str:
    cpu, cores = m.get("cpu"), m.get("cores")
    if cpu and cores:
        return f"{cores}-core {cpu}"
    return str(cpu or (f"{cores} cores" if cores else ""))


def _load(pairs) -> str:
    try:
        start, end = float(pairs[0][0]), float(pairs[1][0])
    except (TypeError, ValueError, IndexError, KeyError):
        return ""
    return f"1-minute load {start:.1f} at the start and {end:.1f} at the end"


def _one_line(text) -> str:
    return " ".join(str(text).split())


def render_result(summary: dict) -> str:
    """The Markdown of the result block (without the marker lines), from a summary.json's contents.

    Only facts the summary holds; the same summary gives the same text, byte for byte."""
    s = summary
    head = []
    run = f"{s['mode']} run" if s.get("mode") else "run"
    if s.get("started_utc"):
        run += " " + _when(s["started_utc"])
    head.append(run)
    if s.get("status", "ok") != "ok":
        head.append(f"status {s['status']}")
    for part in (_build(s.get("build") or {}), _machine(s.get("machine") or {}), _load(s.get("load_average"))):
        if part:
            head.append(part)
    nodes = s.get("nodes") or {}
    if nodes:
        # The machine above submitted the runs; these ran them.
        head.append("runs on Slurm " + ("node " if len(nodes) == 1 else "nodes ")
                    + ", ".join(f"{h} ({c})" for h, c in sorted(nodes.items())))
    tail = []
    if isinstance(s.get("seconds"), (int, float)):
        tail.append(f"{s['seconds']:.0f} s")
    if isinstance(s.get("runs"), int):
        tail.append(_plural(s["runs"], "run"))
    text = ", ".join(head) + ("; " + ", ".join(tail) if tail else "")
    L = [f"**Result** ({text}):", ""]
    for t in s.get("tables") or []:
        L += [line.rstrip() for line in str(t).strip("\n").splitlines()]
        L.append("")
    title = str(s.get("title") or s.get("name") or "plot").replace("[", "(").replace("]", ")")
    for p in s.get("plots") or []:
        L.append(f"![{_one_line(title)}]({p})")
        L.append("")
    L.append(f"- The experiment's verdict: {_one_line(s.get('verdict') or 'none recorded')}")
    return "\n".join(L) + "\n"


def _label(path: Path) -> str:
    """experiments/NAME/README.md for an experiment's folder, else the path as given."""
    if path.parent.parent.name == "experiments":
        return f"experiments/{path.parent.name}/{path.name}"
    return str(path)


def _spans(lines: list, label: str) -> list:
    """(begin, end) line indexes of every result block; a ReadmeError for unpaired markers."""
    spans, begin = [], None
    for i, line in enumerate(lines):
        if line.strip() == BEGIN:
            if begin is not None:
                raise ReadmeError(f"{label}:{i + 1}: a result block begins inside the one begun at line {begin + 1}")
            begin = i
        elif line.strip() == END:
            if begin is None:
                raise ReadmeError(f"{label}:{i + 1}: '{END}' without its begin line")
            spans.append((begin, i))
            begin = None
    if begin is not None:
        raise ReadmeError(f"{label}:{begin + 1}: the result block has no end line '{END}'")
    return spans


def _block(lines: list, label: str) -> tuple:
    spans = _spans(lines, label)
    if not spans:
        raise ReadmeError(f"{label}: no result block (add the lines '{BEGIN}' and '{END}' where the result "
                          f"goes, then {FIX})")
    if len(spans) > 1:
        raise ReadmeError(f"{label}: {len(spans)} result blocks (lines "
                          + ", ".join(str(b + 1) for b, _ in spans) + "), expected one")
    return spans[0]


def _summary(folder: Path, label: str) -> dict:
    p = folder / "summary.json"
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except OSError as e:
        raise ReadmeError(f"{label}: cannot read {_label(p)}: {e.strerror or e}") from None
    except ValueError as e:
        raise ReadmeError(f"{label}: {_label(p)} is not valid JSON: {e}") from None


def _expected(folder: Path) -> tuple:
    """The README's lines, the block's span, and the block's lines as summary.json gives them."""
    path = folder / "README.md"
    label = _label(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as e:
        raise ReadmeError(f"{label}: cannot read it: {e.strerror or e}") from None
    begin, end = _block(lines, label)
    body = render_result(_summary(folder, label)).splitlines()
    return lines, (begin, end), [BEGIN] + body + ["", END]


def update_readme(folder: Path) -> bool:
    """Rewrites the result block of folder/README.md from folder/summary.json; True when it changed."""
    folder = Path(folder)
    lines, (begin, end), block = _expected(folder)
    if lines[begin:end + 1] == block:
        return False
    text = "\n".join(lines[:begin] + block + lines[end + 1:]) + "\n"
    (folder / "README.md").write_text(text, encoding="utf-8")
    return True


def check_readme(folder: Path) -> list:
    """Problems of folder/README.md's result block against folder/summary.json, one line each."""
    folder = Path(folder)
    label = _label(folder / "README.md")
    try:
        lines, (begin, end), block = _expected(folder)
    except ReadmeError as e:
        return [str(e)]
    if lines[begin:end + 1] == block:
        return []
    have = lines[begin:end + 1]
    first = next((i for i, (a, b) in enumerate(zip(have, block)) if a != b), min(len(have), len(block)))
    return [f"{label}:{begin + first + 1}: the result block differs from summary.json ({FIX})"]
