#!/usr/bin/env python3
"""Extracts the ```cpp blocks of a Markdown page into one C++ translation unit.

The build compiles the result (CMake target oblong_docs_tests), so an example in
docs/extending.md that stops compiling fails the build, and tests/extending_test.cpp runs
the strategies the examples register. Every block fenced ```cpp is taken, in page order;
blocks in any other fence (```cmake, ```python, ```) or indented are prose only.
`#include` lines are hoisted to the top of the file; everything else goes into
`namespace oblong::doc_examples`, with a `#line` directive per block so that a compiler
error names the page and the line of the example.

    python3 scripts/doc_examples.py docs/extending.md OUT.cpp
"""
import os
import re
import sys

FENCE = re.compile(r"^```\s*(\S*)\s*$")


def blocks(lines):
    """(first line number, lines) of every ```cpp block."""
    out, lang, start, body = [], None, 0, []
    for n, line in enumerate(lines, 1):
        m = FENCE.match(line)
        if lang is None:
            if m:
                lang, start, body = m.group(1), n + 1, []
        elif line.strip() == "```":
            if lang == "cpp":
                out.append((start, body))
            lang = None
        else:
            body.append(line)
    if lang is not None:
        sys.exit(f"doc_examples: a ``` block opened at line {start - 1} is never closed")
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: doc_examples.py PAGE.md OUT.cpp")
    page, out = sys.argv[1], sys.argv[2]
    with open(page, encoding="utf-8") as f:
        lines = f.read().splitlines()
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
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    # Rewrite only on a change, so that an unrelated edit of the page recompiles nothing.
    try:
        with open(out, encoding="utf-8") as f:
            if f.read() == text:
                return 0
    except FileNotFoundError:
        pass
    with open(out, "w", encoding="utf-8") as f:
        f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
