#!/usr/bin/env python3
"""Fails when a source file includes a layer above its own (docs/architecture.md, "Layers").

Every quoted #include in C++, GLSL and shader-stage files is resolved (against the
including file's folder, then the repository root) and both ends are given their layer;
a file may include its own folder's layer and any lower one, never a higher one and never
a different folder of the same rank (peers stay independent). Within a layer, RULES
forbid particular includes (the Vulkan path may not include Embree's backend). Prints
one line per offence and exits 1; prints the layer table and the rules with --list.

    python3 scripts/check_layers.py [--root DIR] [--list]
"""
import argparse
import os
import re
import sys

# Lowest first. A path belongs to the longest prefix that names it.
LAYERS = [
    ("core/kernels", 0, "headers compiled as C++ and as GLSL: per-patch kernels, constants, GPU records"),
    ("core", 1, "infrastructure, the displaced surface, file input"),
    ("inversion", 2, "point-wise inverters (strategies)"),
    ("strategies", 2, "range queries and splitters (strategies)"),
    ("traversal", 3, "the method: driver, RayPatch, prisms, psi, bounds, micro-triangles, baselines"),
    ("render", 4, "Embree and Vulkan scenes, cameras, images, the integrators, output"),
    ("apps", 5, "the programs: oblong, oblong_vkbench"),
    ("python", 5, "the Python module oblong"),
    ("tests/fixtures", 5, "scenes, rays and stiff inputs shared by tests and experiments"),
    ("tests", 6, "unit, conformance and CLI tests"),
    ("experiments", 6, "benchmarks and the paper's experiments"),
]
# Includes forbidden whatever the ranks: (the including files' folder, the included file
# or folder, why). A path names itself and everything under it.
RULES = [
    ("render/vulkan", "render/embree_scene.h",
     "the Vulkan path takes the device-neutral render/accel_options.h, not Embree's backend"),
]
SOURCE = re.compile(r"\.(h|hpp|cpp|cc|glsl|rgen|rint|rchit|rahit|rmiss|comp)$")
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def layer_of(rel):
    best = None
    for prefix, rank, _ in LAYERS:
        if under(rel, prefix):
            if best is None or len(prefix) > len(best[0]):
                best = (prefix, rank)
    return best


def under(rel, prefix):
    return rel == prefix or rel.startswith(prefix + "/")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    ap.add_argument("--list", action="store_true")
    args = ap.parse_args()
    root = os.path.realpath(args.root)
    if args.list:
        for prefix, rank, what in LAYERS:
            print(f"{rank}  {prefix + '/':<16} {what}")
        for src, target, why in RULES:
            print(f"{src}/ may not include {target}: {why}")
        return 0
    offences, checked = [], 0
    for top, _, _ in LAYERS:
        base = os.path.join(root, top)
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = [d for d in dirnames if not d.startswith(".")]
            for name in sorted(filenames):
                if not SOURCE.search(name):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root)
                own = layer_of(rel)
                if own is None or own[0] != top:  # visited under its own, longer prefix
                    continue
                checked += 1
                with open(path, encoding="utf-8", errors="replace") as f:
                    for lineno, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        target = None
                        for cand in (os.path.join(dirpath, m.group(1)), os.path.join(root, m.group(1))):
                            if os.path.exists(cand):
                                target = os.path.relpath(os.path.realpath(cand), root)
                                break
                        if target is None:
                            continue  # generated (build folder) or a system header in quotes
                        for src, banned, why in RULES:
                            if under(rel, src) and under(target, banned):
                                offences.append(f"{rel}:{lineno}: includes {target}, which {src}/ may not: {why}")
                        to = layer_of(target)
                        if to is None:
                            offences.append(f"{rel}:{lineno}: includes {target}, which is in no layer")
                        elif to[0] != own[0] and to[1] >= own[1]:
                            how = "a layer above" if to[1] > own[1] else "a peer layer"
                            offences.append(f"{rel}:{lineno}: includes {target} ({to[0]}/, rank {to[1]}), "
                                            f"{how} {own[0]}/ (rank {own[1]})")
    for o in offences:
        print(o)
    if checked == 0:
        print(f"check_layers: no source files found under {root}")
        return 1
    if offences:
        print(f"check_layers: {len(offences)} include(s) against the layers (docs/architecture.md)")
        return 1
    print(f"check_layers: {checked} files, no include against the layers")
    return 0


if __name__ == "__main__":
    sys.exit(main())
