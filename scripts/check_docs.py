#!/usr/bin/env python3
"""Fails when the documentation points at something that is not there (CTest `docs`).

Checks, printing one line per offence and exiting 1:
  - every relative Markdown link in a tracked .md file resolves to a file or folder of the
    repository, and a `#anchor` on a .md target to one of its headings (GitHub's slugs);
  - every backticked repository path in the reference pages (README.md, docs/*.md; not
    docs/journal/, which is history) names an existing file or folder: a word in
    backticks that starts with a top-level folder of the repository and has a file
    extension or ends in '/' (so `traversal/Prisms`, a statistics counter, is not a
    path); `{h,cpp}` alternatives are expanded, `*` globs and UPPERCASE placeholders
    (experiments/NAME/) match anything, paths under build*/ and out/ are outputs;
  - the same for the repository paths cited in source files' comments;
  - nothing points outside the repository: `../shared`, `shared/papers`, `papers/…`,
    the external design notes (`DESIGN §…`, `DESIGN.md`);
  - no issue-tracker numbers ("issue 4", "issues 3–4", "issue #7") in any Markdown
    heading or anywhere in source files, and no dates in the reference pages' headings;
  - every experiments/NAME/ folder with a summary.json and a README.md has exactly one
    result block in the README, and it reads as experiments/lib/readme.py writes it from
    that summary.json (the numbers a README quotes come from its results: a stale or
    hand-edited block fails; `experiments/run_all --readmes` rewrites the blocks).

    python3 scripts/check_docs.py [--root DIR]
"""
import argparse
import glob
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

SOURCE = re.compile(r"\.(h|hpp|cpp|cc|glsl|rgen|rint|rchit|rahit|rmiss|comp|py|sh|cmake)$|(^|/)(CMakeLists\.txt|run_all|run)$")
LINK = re.compile(r"(?<!!)\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)|!\[[^\]]*\]\(([^)\s]+)\)")
BACKTICK = re.compile(r"`+([^`]+?)`+")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
ISSUE = re.compile(r"\bissues?\s*#?\s*\d|\bissue\s+#\d|\(#\d+\)", re.IGNORECASE)
DATE = re.compile(r"\b20\d\d-\d\d-\d\d\b")
OUTSIDE = re.compile(r"\.\./shared|shared/papers|(?<![\w/.-])papers/|\bDESIGN\s*§|\bDESIGN\.md\b")
OUTPUT_DIRS = ("build", "out")
PLACEHOLDER = re.compile(r"(?<![A-Za-z0-9])(NAME|FILE|DIR|SCENE|BUILD|BUILD_DIR|OUT|STORE|SESSION|TOPIC|KIND)(?![A-Za-z0-9])")
EXT = re.compile(r"\.[A-Za-z0-9]{1,6}(\{[^}]*\})?$|\.\{[^}]*\}$")


def tracked(root):
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-co", "--exclude-standard"], capture_output=True,
                             text=True, check=True).stdout.splitlines()
        files = [f for f in out if os.path.isfile(os.path.join(root, f))]
        if files:
            return sorted(set(files))
    except (OSError, subprocess.CalledProcessError):
        pass
    files = []
    for d, dirs, names in os.walk(root):
        rel = os.path.relpath(d, root)
        dirs[:] = [x for x in dirs if not x.startswith(".") and not x.startswith("build") and x != "out"
                   and os.path.join(rel, x) != "scenes/data"]
        files += [os.path.normpath(os.path.join(rel, n)) for n in names]
    return sorted(files)


def slug(text):
    text = re.sub(r"<[^>]+>", "", text)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading: its text
    text = text.lower().replace("`", "")
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen, out, fence = {}, set(), False
        with open(path, encoding="utf-8") as f:
            for line in f:
                if line.lstrip().startswith("```"):
                    fence = not fence
                m = None if fence else HEADING.match(line)
                if m:
                    s = slug(m.group(2))
                    n = seen.get(s, 0)
                    seen[s] = n + 1
                    out.add(s if n == 0 else f"{s}-{n}")
        cache[path] = out
    return cache[path]


def expand(word):
    m = re.search(r"\{([^}]*)\}", word)
    if not m:
        return [word]
    return [x for alt in m.group(1).split(",") for x in expand(word[:m.start()] + alt + word[m.end():])]


def exists(root, rel):
    if any(rel == d or rel.startswith(d + "/") or re.match(r"build[\w-]*(/|$)", rel) for d in OUTPUT_DIRS):
        return True
    if PLACEHOLDER.search(rel):  # experiments/NAME/bench_NAME.cpp
        return bool(glob.glob(os.path.join(root, PLACEHOLDER.sub("*", rel))))
    if "*" in rel:  # a pattern: its folder must exist (what it matches may be generated)
        return os.path.isdir(os.path.join(root, os.path.dirname(rel.split("*", 1)[0]) or "."))
    return os.path.exists(os.path.join(root, rel))


def path_words(text, tops):
    """Words of `text` that name repository paths (see the module's docstring)."""
    text = re.sub(r"\{[^{}\s]*\}", lambda m: m.group(0).replace(",", "\0"), text)  # {h,cpp} stays one word
    for raw in re.split(r"[\s,;()|]+", text):
        if raw.endswith(":") and not raw.endswith("::"):
            continue  # the file an error message names: `scenes/x.json: meshes[1]...`
        w = raw.strip("'\".:;,").replace("\0", ",")
        w = re.sub(r":\d+(-\d+)?$", "", w)  # file.cpp:123
        if w.startswith("./"):
            w = w[2:]
        top = w.split("/", 1)[0]
        if "/" not in w or top not in tops or "://" in w or "$" in w or "<" in w:
            continue
        if w.endswith("/") or EXT.search(w.split("/")[-1]) or "*" in w:
            yield w


def experiment_readmes(root, files):
    """Problems of the experiments' README result blocks, one line each, and how many were checked."""
    def names(leaf):
        return {f.split("/")[1] for f in files if re.fullmatch(r"experiments/[^/]+/" + re.escape(leaf), f)}

    folders = sorted(names("summary.json") & names("README.md"))
    if not folders:
        return [], 0
    lib = os.path.join(root, "experiments", "lib", "readme.py")
    if not os.path.isfile(lib):
        return [f"experiments/lib/readme.py: missing, so {len(folders)} experiments' result blocks go unchecked"], 0
    # Loaded by path: the tree under check defines the block, and no other `readme` module can stand in.
    spec = importlib.util.spec_from_file_location("oblong_experiments_readme", lib)
    readme = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(readme)
    out = []
    for name in folders:
        out += readme.check_readme(Path(root) / "experiments" / name)
    return out, len(folders)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    args = ap.parse_args()
    root = os.path.realpath(args.root)
    files = tracked(root)
    tops = {f.split("/", 1)[0] for f in files if "/" in f}
    problems = []

    def bad(where, what):
        problems.append(f"{where}: {what}")

    markdown = [f for f in files if f.endswith(".md") and not f.startswith("scenes/data/")]
    reference = [f for f in markdown if f == "README.md" or (f.startswith("docs/") and f.count("/") == 1)]
    for md in markdown:
        fence = False
        with open(os.path.join(root, md), encoding="utf-8") as f:
            lines = f.read().splitlines()
        for n, line in enumerate(lines, 1):
            where = f"{md}:{n}"
            if line.lstrip().startswith("```"):
                fence = not fence
                continue
            h = None if fence else HEADING.match(line)
            if h:
                if ISSUE.search(h.group(2)):
                    bad(where, f"an issue number in a heading: {line.strip()}")
                if md in reference and DATE.search(h.group(2)):
                    bad(where, f"a date in a reference page's heading (history goes to docs/journal/): {line.strip()}")
            if OUTSIDE.search(line):
                bad(where, f"points outside the repository: {OUTSIDE.search(line).group(0)}")
            if fence:
                continue
            for m in LINK.finditer(line):
                target = m.group(1) or m.group(2)
                if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#") and not target[1:]:
                    continue  # http:, mailto:, ...
                path, _, anchor = target.partition("#")
                if not path:
                    full = os.path.join(root, md)
                else:
                    full = os.path.normpath(os.path.join(root, os.path.dirname(md), path))
                    if not full.startswith(root + os.sep) and full != root:
                        bad(where, f"link leaves the repository: {target}")
                        continue
                    if not os.path.exists(full):
                        bad(where, f"broken link: {target}")
                        continue
                if anchor and full.endswith(".md") and os.path.isfile(full) and anchor not in anchors(full):
                    bad(where, f"no heading '#{anchor}' in {os.path.relpath(full, root)}")
            if md in reference:
                for m in BACKTICK.finditer(line):
                    for w in path_words(m.group(1), tops):
                        missing = [x for x in expand(w) if not exists(root, x)]
                        if missing:
                            bad(where, f"no such file or folder: {', '.join(missing)} (in `{w}`)")

    for src in files:
        if not SOURCE.search(src) or src.startswith("scenes/data/") or src == "scripts/check_docs.py":
            continue
        try:
            with open(os.path.join(root, src), encoding="utf-8") as f:
                lines = f.read().splitlines()
        except (UnicodeDecodeError, OSError):
            continue
        for n, line in enumerate(lines, 1):
            where = f"{src}:{n}"
            if ISSUE.search(line):
                bad(where, f"cites an issue number: {line.strip()[:100]}")
            if OUTSIDE.search(line):
                bad(where, f"points outside the repository: {OUTSIDE.search(line).group(0)}")
            c = re.search(r"//|#(?!include|define|pragma|if|endif|else|elif|undef|line|version|extension)|\*", line)
            if not c:
                continue
            for w in path_words(line[c.start():], tops):
                missing = [x for x in expand(w) if not exists(root, x)]
                if missing:
                    bad(where, f"cites a path that does not exist: {', '.join(missing)}")

    results, checked = experiment_readmes(root, files)
    problems += results

    # One version number: CMake's project(VERSION), which `oblong --version` prints, and
    # the citation's.
    cmake_v = re.search(r"project\(oblong VERSION ([0-9.]+)", open(os.path.join(root, "CMakeLists.txt")).read())
    cff_v = re.search(r"^version: *([0-9.]+)", open(os.path.join(root, "CITATION.cff")).read(), re.M)
    if not cmake_v or not cff_v or cmake_v.group(1) != cff_v.group(1):
        bad("CITATION.cff", f"version {cff_v and cff_v.group(1)} is not CMakeLists.txt's project version "
            f"{cmake_v and cmake_v.group(1)}")

    for p in problems:
        print(p)
    if problems:
        print(f"check_docs: {len(problems)} problem(s) in {len(markdown)} Markdown and the source files")
        return 1
    print(f"check_docs: {len(markdown)} Markdown files and the sources: links, paths and headings in order; "
          f"{checked} experiment READMEs' result blocks match their summary.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
