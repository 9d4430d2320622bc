#!/usr/bin/python3
"""Generates the two synthetic height maps committed in scenes/maps/ (deterministic).

    /usr/bin/python3 scenes/tools/make_maps.py   # rewrites scenes/maps/*.png

Needs only numpy (Debian python3-numpy). Both maps are periodic in u (and cobbles.png
also in v), so wrap addressing and tiling show no seam. See scenes/README.md.

- cobbles_256.png (256x256, 16-bit): cobblestones from periodic Worley noise (about
  70 stones per tile, separated by sharp grooves 2-4 texels wide) plus two octaves of
  fine periodic value noise: high-frequency detail with steep sides, for tiling.
- planet_512x256.png (512x256, 16-bit, equirectangular): ridged multi-octave periodic
  value noise with craters, multiplied by a latitude window that is exactly 0 on rows
  0..10 and 245..255, so a UV sphere with at least 25 rings has zero height on its
  polar caps (no cracks where the pole triangles' different uvs meet, see README).
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png16 import write_png16  # noqa: E402

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "maps")


def value_noise(w, h, cw, ch, rng):
    """Periodic smooth value noise on a (cw x ch) lattice, sampled at texel centres."""
    lattice = rng.random((ch, cw))
    x = (np.arange(w) + 0.5) / w * cw
    y = (np.arange(h) + 0.5) / h * ch
    i, j = np.floor(x).astype(int), np.floor(y).astype(int)
    tx, ty = x - i, y - j
    sx, sy = tx * tx * (3 - 2 * tx), ty * ty * (3 - 2 * ty)
    i0, i1, j0, j1 = i % cw, (i + 1) % cw, j % ch, (j + 1) % ch
    a = lattice[np.ix_(j0, i0)] * (1 - sx) + lattice[np.ix_(j0, i1)] * sx
    b = lattice[np.ix_(j1, i0)] * (1 - sx) + lattice[np.ix_(j1, i1)] * sx
    return a * (1 - sy)[:, None] + b * sy[:, None]


def worley_f1_f2(w, h, n, rng):
    """Distances (in texels) to the nearest and second-nearest of n random points,
    periodic in both axes."""
    pts = rng.random((n, 2)) * [w, h]
    x, y = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    d = np.full((n, h, w), np.inf)
    for k, (px, py) in enumerate(pts):
        dx = np.abs(x - px)
        dy = np.abs(y - py)
        dx = np.minimum(dx, w - dx)
        dy = np.minimum(dy, h - dy)
        d[k] = np.hypot(dx, dy)
    d.sort(axis=0)
    return d[0], d[1]


def to16(a):
    return np.round(np.clip(a, 0.0, 1.0) * 65535).astype(np.uint16)


def cobbles(rng):
    w = h = 256
    f1, f2 = worley_f1_f2(w, h, 70, rng)
    edge = f2 - f1  # 0 on the cell borders
    # Stones: rounded tops, steep sides, grooves about 3 texels wide.
    stone = np.clip((edge - 1.5) / 5.0, 0.0, 1.0)
    stone = np.sqrt(stone) * (0.85 + 0.15 * (1 - f1 / (f1.max())))
    fine = 0.6 * value_noise(w, h, 32, 32, rng) + 0.4 * value_noise(w, h, 64, 64, rng)
    return 0.1 + 0.75 * stone + 0.15 * fine


def planet(rng):
    w, h = 512, 256
    octaves = [(8, 4, 0.5), (16, 8, 0.25), (32, 16, 0.14), (64, 32, 0.07), (128, 64, 0.04)]
    n = sum(a * (1 - np.abs(2 * value_noise(w, h, cw, ch, rng) - 1)) for cw, ch, a in octaves)
    n = (n - n.min()) / (n.max() - n.min())
    # Craters (periodic in u): a raised rim and a bowl.
    x, y = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    for _ in range(40):
        cx, cy = rng.random() * w, 40 + rng.random() * (h - 80)
        r = 3 + 14 * rng.random() ** 2
        dx = np.abs(x - cx)
        dx = np.minimum(dx, w - dx)
        d = np.hypot(dx, y - cy) / r
        n += 0.25 * np.where(d < 1, d * d - 0.8, 0.2 * np.exp(-8 * (d - 1) ** 2))
    n = (n - n.min()) / (n.max() - n.min())
    # Latitude window: exactly 0 on rows 0..10 and h-11..h-1, smooth ramp to 1 by row 40.
    row = np.arange(h)
    dist = np.minimum(row, h - 1 - row).astype(float)
    t = np.clip((dist - 10) / 30.0, 0.0, 1.0)
    window = t * t * (3 - 2 * t)
    out = to16(n * window[:, None])
    out[dist <= 10] = 0
    return out


def main():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(20231)
    a = to16(cobbles(rng))
    write_png16(os.path.join(OUT, "cobbles_256.png"), a)
    b = planet(np.random.default_rng(7))
    write_png16(os.path.join(OUT, "planet_512x256.png"), b)
    for name, img in (("cobbles_256.png", a), ("planet_512x256.png", b)):
        p = os.path.join(OUT, name)
        print(f"{os.path.normpath(p)}: {img.shape[1]}x{img.shape[0]}, values {img.min()}..{img.max()}, "
              f"{os.path.getsize(p)} bytes")


if __name__ == "__main__":
    main()
