#!/usr/bin/python3
"""Texels per base triangle and the pre-tessellation size of scenes with procedural
shapes (scenes/README.md, "Paper-scale suite").

    /usr/bin/python3 scenes/tools/paper_stats.py                       # scenes/paper/*.json
    /usr/bin/python3 scenes/tools/paper_stats.py SCENE.json ...
    /usr/bin/python3 scenes/tools/paper_stats.py --exact build/oblong  # also oblong's own count

For every displaced mesh with a `shape` (plane, sphere, torus) it builds the shape's uv
triangles as the loader does (docs/scene_format.md, "Shapes"; a sphere's pole triangles
have their pole vertex at the middle of their segment), and multiplies each triangle's
uv area by the tiled sample count (tiling_u * W) * (tiling_v * H), W x H read from the
map's PNG header. It prints the mean and the largest number of samples per base
triangle, and the pre-tessellation estimate: micro-triangles ~ 2 x covered samples
(two per sample cell), bytes at oblong's constants (render/tessellation.h,
TessellationEstimate): per micro-triangle about 28 B of geometry (half a vertex of
16 + 8 B, 12 B of indices, 4 B of base-triangle index) plus 64 B of Embree BVH after the
build, 100 B of BVH at the build's peak: 92 B kept, 128 B at the peak (what `oblong
render --baseline tessellated` checks before it builds anything).

--exact BIN runs `OBLONG_MEMORY_LIMIT=1M BIN render SCENE --baseline tessellated`, which
refuses with oblong's exact micro-triangle count and peak (summing every triangle's
clipped cells; slow for desert_tire.json, about a minute). Meshes loaded from files are
not handled (use `oblong info`). Needs only numpy.
"""
import glob
import json
import os
import re
import struct
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
GEOMETRY_BYTES, BVH_BYTES, BVH_BUILD_BYTES = 28, 64, 100


def strip_comments(text):
    """JSON with // and /* */ comments (outside strings) -> JSON."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if c == '"':
            j = i + 1
            while text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(text[i:j + 1])
            i = j + 1
        elif text.startswith("//", i):
            i = text.find("\n", i)
            i = n if i < 0 else i
        elif text.startswith("/*", i):
            i = text.index("*/", i) + 2
        else:
            out.append(c)
            i += 1
    return "".join(out)


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG (only PNG maps are read here)")
    return struct.unpack(">II", head[16:24])  # width, height


def pair(v, default):
    if v is None:
        v = default
    return (v, v) if isinstance(v, (int, float)) else tuple(v)


def uv_triangles(shape):
    """uv triangles (T x 3 x 2) of a procedural shape, as core's generator makes them."""
    kind = shape["type"]
    nu, nv = pair(shape.get("segments"), {"plane": 1, "sphere": [64, 32], "torus": [48, 24]}[kind])
    if kind == "plane":
        u0, v0, u1, v1 = shape.get("uv", [0, 0, 1, 1])
        us, vs = np.linspace(u0, u1, nu + 1), np.linspace(v0, v1, nv + 1)
    else:
        us, vs = np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1)
    U, V = np.meshgrid(us, vs)  # (nv+1) x (nu+1)
    a = np.stack([U[:-1, :-1], V[:-1, :-1]], -1)
    b = np.stack([U[:-1, 1:], V[:-1, 1:]], -1)
    c = np.stack([U[1:, 1:], V[1:, 1:]], -1)
    d = np.stack([U[1:, :-1], V[1:, :-1]], -1)
    quads = np.stack([np.stack([a, b, c], -2), np.stack([a, c, d], -2)], 2)  # nv x nu x 2 x 3 x 2
    if kind != "sphere":
        return quads.reshape(-1, 3, 2)
    # Sphere: rows 1 .. nv-2 are quads; rows 0 and nv-1 one triangle per segment, the
    # pole vertex at the segment's middle u.
    mid = quads[1:-1].reshape(-1, 3, 2)
    um = (us[:-1] + us[1:]) / 2
    north = np.stack([np.stack([um, np.zeros(nu)], -1), np.stack([us[:-1], np.full(nu, vs[1])], -1),
                      np.stack([us[1:], np.full(nu, vs[1])], -1)], 1)
    south = np.stack([np.stack([us[:-1], np.full(nu, vs[-2])], -1), np.stack([us[1:], np.full(nu, vs[-2])], -1),
                      np.stack([um, np.ones(nu)], -1)], 1)
    return np.concatenate([north, mid, south])


def exact(binary, scene):
    env = dict(os.environ, OBLONG_MEMORY_LIMIT="1M")
    with tempfile.TemporaryDirectory() as tmp:  # never written: the render is refused first
        r = subprocess.run([binary, "render", scene, "--baseline", "tessellated", "--size", "1x1", "-q", "-o",
                            os.path.join(tmp, "unused.png")], env=env, capture_output=True, text=True)
    m = re.search(r"needs ([\d.]+ \w+) \((\d+) micro-triangles", r.stderr)
    return (int(m.group(2)), m.group(1)) if m else r.stderr.strip()


def human(n):
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}"
        n /= 1024


def main():
    args = sys.argv[1:]
    binary = None
    if args[:1] == ["--exact"]:
        binary, args = args[1], args[2:]
    scenes = args or sorted(glob.glob(os.path.join(HERE, "..", "paper", "*.json")))
    for path in scenes:
        with open(path) as f:
            scene = json.loads(strip_comments(f.read()))
        for mi, m in enumerate(scene["meshes"]):
            disp = m.get("displacement")
            name = f"{os.path.relpath(path)} meshes[{mi}]"
            if not disp:
                continue
            if "shape" not in m:
                print(f"{name}: mesh file {m['file']}: not handled (use oblong info)")
                continue
            mp = os.path.normpath(os.path.join(os.path.dirname(path), disp["map"]))
            w, h = png_size(mp)
            tu, tv = pair(disp.get("tiling"), 1)
            t = uv_triangles(m["shape"])
            e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
            area = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / 2
            samples = area * (tu * w) * (tv * h)
            micro = 2 * samples.sum()
            print(f"{name}: {len(t)} triangles ({m['shape']['type']}), map {os.path.basename(mp)} {w}x{h} "
                  f"tiled {tu:g}x{tv:g} = {tu * w:g} x {tv * h:g} samples; samples per base triangle mean "
                  f"{samples.mean():.6g}, max {samples.max():.6g}; pre-tessellation ~ {micro:.4g} micro-triangles "
                  f"(2 x {samples.sum():.4g} covered samples), {human(micro * (GEOMETRY_BYTES + BVH_BYTES))} kept, "
                  f"{human(micro * (GEOMETRY_BYTES + BVH_BUILD_BYTES))} at the build's peak")
        if binary:
            e = exact(binary, path)
            print(f"    oblong: {e[0]} micro-triangles, needs {e[1]}" if isinstance(e, tuple)
                  else f"    oblong: no estimate in its output: {e}")


if __name__ == "__main__":
    main()
