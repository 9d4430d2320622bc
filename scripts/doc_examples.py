#!/usr/bin/env python3
"""Extracts the ```cpp blocks of a Markdown page into one C++ translation unit, and its
```kernel blocks into the headers they name.

The build compiles the result (CMake target oblong_docs_tests), so an example in
docs/extending.md that stops compiling fails the build, and tests/extending_test.cpp runs
the strategies the examples register. Every block fenced ```cpp is taken, in page order;
blocks in any other fence (```cmake, ```python, ```) or indented are prose only.
`#include` lines are hoisted to the top of the file; everything else goes into
`namespace oblong::doc_examples`, with a `#line` directive per block so that a compiler
error names the page and the line of the example.

A ```kernel block is a whole header in the kernels' dialect (core/kernels/lang.h) whose
first line names its path, `// core/kernels/NAME.h`: it is written to KERNEL_ROOT/that
path (the C++ examples include it by that path, KERNEL_ROOT being on their include
path), and KERNEL_ROOT/doc_kernels.comp includes every such header, so that glslc checks
them as GLSL (CTest docs_gpu_kernels).

    python3 scripts/doc_examples.py docs/extending.md OUT.cpp [KERNEL_ROOT]
"""
import os
import re
import sys

FENCE = re.compile(r"^```\s*(\S*)\s*$")
KERNEL_PATH = re.compile(r"^//\s*([A-Za-z0-9_/]+\.h)\s*$")


def blocks(lines, want="cpp"):
    """(first line number, lines) of every block fenced ```WANT."""
    out, lang, start, body = [], None, 0, []
    for n, line in enumerate(lines, 1):
        m = FENCE.match(line)
        if lang is None:
            if m:
                lang, start, body = m.group(1), n + 1, []
        elif line.strip() == "```":
            if lang == want:
                out.append((start, body))
            lang = None
        else:
            body.append(line)
    if lang is not None:
        sys.exit(f"doc_examples: a ``` block opened at line {start - 1} is never closed")
    return out


def write_if_changed(path, text):
    """Rewrites only on a change, so that an unrelated edit of the page recompiles nothing."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    try:
        with open(path, encoding="utf-8") as f:
            if f.read() == text:
                return
    except FileNotFoundError:
        pass
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def write_kernels(page, lines, root):
    """Writes the ```kernel blocks to ROOT/their paths and ROOT/doc_kernels.comp."""
    paths = []
    for start, block in blocks(lines, "kernel"):
        m = KERNEL_PATH.match(block[0]) if block else None
        if not m or os.path.dirname(m.group(1)) != "core/kernels":
            sys.exit(f"doc_examples: {page}:{start}: a ```kernel block starts with its path, "
                     "'// core/kernels/NAME.h'")
        if m.group(1) in paths:
            sys.exit(f"doc_examples: {page}:{start}: {m.group(1)} is written twice")
        if root is None:
            sys.exit(f"doc_examples: {page} has ```kernel blocks: give a KERNEL_ROOT")
        paths.append(m.group(1))
        write_if_changed(os.path.join(root, m.group(1)), "\n".join(block) + "\n")
    if root is not None:
        write_if_changed(os.path.join(root, "doc_kernels.comp"), "\n".join(
            ["#version 460", f"// Generated from {os.path.basename(page)} by scripts/doc_examples.py: "
             "its kernels, checked as GLSL.", "#extension GL_GOOGLE_include_directive : require"]
            + [f'#include "{p}"' for p in paths]
            + ["layout(local_size_x = 1) in;", "void main() {}", ""]))


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit("usage: doc_examples.py PAGE.md OUT.cpp [KERNEL_ROOT]")
    page, out = sys.argv[1], sys.argv[2]
    with open(page, encoding="utf-8") as f:
        lines = f.read().splitlines()
    write_kernels(page, lines, sys.argv[3] if len(sys.argv) == 4 else None)
    found = blocks(lines)
    if not found:
        sys.exit(f"doc_examples: {page} has no ```cpp block")
    includes, body = [], []
    for start, block in found:
        body.append(f'#line {start} "{page}"')
        for line in block:
            if line.lstrip().startswith("#include"):
                if line.strip() not in includes:
                    includes.append(line.strip())
                body.append("")  # keeps the #line numbering
            else:
                body.append(line)
    text = "\n".join(
        [f"// Generated from {os.path.basename(page)} by scripts/doc_examples.py: do not edit.", ""]
        + includes
        + ["", "namespace oblong::doc_examples {", ""]
        + body
        + ["", "}  // namespace oblong::doc_examples", ""])
    write_if_changed(out, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
