#!/usr/bin/env python3
"""The README's first render, run as the README writes it: its printed lines and its two
images are this script's output, so they cannot drift from what the program prints.

    python3 scripts/readme_sample.py --write [--build build] [--scenes scenes]
        runs the README's command and writes what it printed into README.md (the block
        after the command) and docs/render.md (the summary line), and its images into
        docs/images/;
    python3 scripts/readme_sample.py --check --build build --scenes build/test_data/scenes
        (CTest `readme_sample`) runs it again and fails, with a diff, when the README's
        block, docs/render.md's line or the images differ from what it prints now.

What depends on the machine is left out of the comparison: times, Mrays/s and the peak
resident memory. The rest (configuration, memory per structure, ray counts, hit rate,
steps, prisms, the heat map's scale) is deterministic. The images are compared with
`oblong compare` (path tracing with per-pixel seeds; a differing pixel beyond 8-bit
rounding fails).
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
RENDER_MD = ROOT / "docs" / "render.md"
IMAGES = ROOT / "docs" / "images"
COMMAND = re.compile(r"^    (\./build/oblong render scenes/asteroid\.json .*--heatmap .*)$", re.M)
# The block of printed lines in the README: indented, from `oblong render:` to the heat map line.
BLOCK = re.compile(r"^    oblong render: scenes/asteroid\.json.*?\n(?:    .*\n)*", re.M)
SUMMARY = re.compile(r"^    summary  : 640x480 16 spp path.*\n", re.M)
# Machine-dependent numbers, masked before comparing.
MASKS = [
    (re.compile(r"built in [0-9.]+ s"), "built in * s"),
    (re.compile(r"path, [0-9.]+ s,"), "path, * s,"),
    (re.compile(r"[0-9.]+ Mrays/s"), "* Mrays/s"),
    (re.compile(r"peak [0-9.]+ [KMGT]?i?B"), "peak *"),
]


def fail(msg):
    print(f"readme_sample: {msg}", file=sys.stderr)
    sys.exit(1)


def masked(text):
    for pat, rep in MASKS:
        text = pat.sub(rep, text)
    return text


def run(build, scenes, work):
    """Runs the README's command in `work` (with `scenes` as ./scenes); returns its stdout."""
    m = COMMAND.search(README.read_text())
    if not m:
        fail("README.md: no `./build/oblong render scenes/asteroid.json ... --heatmap ...` command line")
    args = m.group(1).split()
    oblong = Path(build).resolve() / "oblong"
    if not oblong.is_file():
        fail(f"{oblong}: not built (cmake --build {build})")
    os.symlink(Path(scenes).resolve(), work / "scenes")
    (work / "out").mkdir()  # scripts/demo.sh made it before the README's first render
    p = subprocess.run([str(oblong)] + args[1:], cwd=work, capture_output=True, text=True)
    if p.returncode != 0:
        fail(f"`{m.group(1)}` exited {p.returncode}: {p.stderr.strip()}")
    return "".join("    " + line + "\n" for line in p.stdout.splitlines()), oblong


def images_differ(oblong, fresh, kept, work):
    """The largest pixel difference between two PNGs, via `oblong compare`."""
    p = subprocess.run([str(oblong), "compare", str(fresh), str(kept), "--json"], capture_output=True, text=True)
    if p.returncode != 0:
        return p.stderr.strip()
    r = json.loads(p.stdout)
    err, mse = r["max_pixel_error"], r["mse"]
    # 8-bit sRGB images: one code of rounding is up to about 2.5/255 in linear values.
    # Beyond that, a few pixels may differ between machines (a silhouette's grazing camera
    # rays on the step heat map: 230 of 640x559 pixels, mean squared error 9e-7, between
    # two of this project's machines with the same code); a change in what the code does
    # moves far more of the image than a mean squared error of 1e-5 (PSNR 50 dB) allows.
    if err <= 3 / 255 or mse <= 1e-5:
        return None
    return f"largest pixel difference {err:.4f}, mean squared error {mse:.2e}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", action="store_true")
    mode.add_argument("--check", action="store_true")
    ap.add_argument("--build", default=str(ROOT / "build"))
    ap.add_argument("--scenes", default=str(ROOT / "scenes"))
    a = ap.parse_args()

    readme, render_md = README.read_text(), RENDER_MD.read_text()
    with tempfile.TemporaryDirectory(prefix="oblong_readme_") as tmp:
        work = Path(tmp)
        block, oblong = run(a.build, a.scenes, work)
        # docs/render.md shows the summary line alone, without the block's indent.
        summary = next(("    " + l.strip() + "\n" for l in block.splitlines() if l.strip().startswith("summary  :")),
                       None)
        if summary is None:
            fail("the render printed no summary line")
        if not BLOCK.search(readme):
            fail("README.md: no printed block starting `    oblong render: scenes/asteroid.json`")
        if not SUMMARY.search(render_md):
            fail("docs/render.md: no `    summary  : 640x480 16 spp path` line")
        pngs = ["asteroid.png", "asteroid_steps.png"]
        if a.write:
            README.write_text(BLOCK.sub(lambda _: block, readme, count=1))
            RENDER_MD.write_text(SUMMARY.sub(lambda _: summary, render_md, count=1))
            for name in pngs:
                shutil.copyfile(work / "out" / name, IMAGES / name)
            print("readme_sample: README.md, docs/render.md and docs/images/ rewritten")
            return
        bad = []
        kept = BLOCK.search(readme).group(0)
        if masked(kept) != masked(block):
            import difflib
            bad.append("README.md's printed block differs from what the command prints now "
                       "(python3 scripts/readme_sample.py --write rewrites it):\n" +
                       "".join(difflib.unified_diff(masked(kept).splitlines(True), masked(block).splitlines(True),
                                                    "README.md", "now")))
        if masked(SUMMARY.search(render_md).group(0)) != masked(summary):
            bad.append("docs/render.md's summary line differs from the README command's:\n  "
                       + SUMMARY.search(render_md).group(0) + "  now:\n  " + summary)
        for name in pngs:
            why = images_differ(oblong, work / "out" / name, IMAGES / name, work)
            if why:
                bad.append(f"docs/images/{name} differs from out/{name} rendered now: {why}")
        if bad:
            fail("\n".join(bad))
        print("readme_sample: README.md, docs/render.md and docs/images/ match the command's output")


if __name__ == "__main__":
    main()
