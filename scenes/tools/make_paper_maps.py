#!/usr/bin/python3
"""Generates the height maps of the paper-scale scene suite (scenes/paper/) into
scenes/data/paper/ (git-ignored; scripts/setup.sh runs this when they are missing or
older than this script). Deterministic: fixed seeds, regenerating gives bit-identical
files (checked on one machine; the arithmetic is elementwise IEEE float32/float64 with
floor and sqrt only, no exp, sin or other functions whose vectorised versions may round
differently per CPU, so other machines should agree too).

    /usr/bin/python3 scenes/tools/make_paper_maps.py [OUT_DIR [MAP.png ...]]

OUT_DIR defaults to scenes/data/paper; naming maps generates only those.

Needs only numpy (Debian python3-numpy); writes 16-bit greyscale PNGs with png16.py.
Every map is periodic in u and v (tiling shows no seam) and has the kind of
high-frequency content of the RMIP paper's maps (Thonat et al. 2023, Table 1): grooves a
few texels wide and steps between neighbouring texels. See scenes/README.md,
"Paper-scale suite".

- alien_2k.png      2048^2  ridged 7-octave value noise (finest lattice 4 texels) with
                            craters and patches of small bumps
- roof_tiles_2k.png 2048^2  16 rows of 16 rounded (barrel) tiles, alternate rows offset
                            by half a tile, each row's lower edge a sharp step onto the
                            next, gaps between tiles, fine noise
- helmet_4k.png     4096^2  riveted metal plates: 16x8 Worley plates at different levels
                            with V-grooves between them, a row of rivets inside every
                            plate border (exact distance to the border and position
                            along it, from the two nearest Worley points),
                            hammer dents (fine Worley scallops); the rows near v = 0 and
                            v = 1 are a constant level (the poles of a UV sphere, see
                            README)
- tire_4k.png       4096^2  tyre tread: chevron blocks between 6 zig-zag lateral grooves
                            and 2 circumferential ones, walls 2.5 texels wide, thin
                            (3-texel) zig-zag sipes, fine rubber noise
- creature_4k.png   4096^2  128x64 cellular scales, each tilted up towards its rear edge
                            (a sharp step onto the next), grooves between them, fine
                            meandering wrinkles
"""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png16 import write_png16  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OUT = os.path.join(HERE, "..", "data", "paper")
F = np.float32


# ----------------------------------------------------------------------------- helpers

def _axis(n, c):
    """Lattice cells and smoothstep weights of n texel centres over c periodic cells."""
    x = (np.arange(n, dtype=np.float64) + 0.5) * (c / n)
    i = np.floor(x).astype(np.int64)
    t = (x - i).astype(F)
    return i % c, (i + 1) % c, t * t * (F(3) - F(2) * t)


def value_noise(w, h, cw, ch, rng):
    """Periodic smooth value noise in [0, 1] on a cw x ch lattice (cw, ch dividing or not
    the map size), sampled at texel centres; separable (float32, h x w)."""
    lat = rng.random((ch, cw), dtype=F)
    i0, i1, sx = _axis(w, cw)
    j0, j1, sy = _axis(h, ch)
    rows = lat[:, i0] * (F(1) - sx) + lat[:, i1] * sx  # ch x w
    return rows[j0] * (F(1) - sy)[:, None] + rows[j1] * sy[:, None]


def worley(w, h, gx, gy, rng, jitter=0.8, second=False):
    """Periodic Worley noise on a gx x gy grid of cells, one jittered feature point per
    cell (searched in the 3x3 neighbouring cells). Cells are (w/gx) x (h/gy) texels and
    distances are in cell units (so a rectangular cell is a square in the metric).
    Returns F1, F2 (float32, h x w), the F1 cell's index (int32, j * gx + i) and the
    texel's offset from its F1 point (dx, dy, in cell units); with second=True also the
    offset from its F2 point (dx2, dy2)."""
    sx, sy = w // gx, h // gy
    assert sx * gx == w and sy * gy == h
    pts = rng.random((2, gy, gx), dtype=F) * F(jitter) + F((1 - jitter) / 2)
    lx = ((np.arange(sx) + 0.5) / sx).astype(F)
    ly = ((np.arange(sy) + 0.5) / sy).astype(F)
    shape = (gy, sy, gx, sx)
    f1 = np.full(shape, np.inf, F)
    f2 = np.full(shape, np.inf, F)
    idx = np.zeros(shape, np.int32)
    ox = np.zeros(shape, F)
    oy = np.zeros(shape, F)
    if second:
        ox2 = np.zeros(shape, F)
        oy2 = np.zeros(shape, F)
    jj, ii = np.arange(gy), np.arange(gx)
    for dj in (-1, 0, 1):
        for di in (-1, 0, 1):
            ny = (jj + dj) % gy
            nx = (ii + di) % gx
            py = pts[0][np.ix_(ny, nx)] + F(dj)  # point, relative to the cell's origin
            px = pts[1][np.ix_(ny, nx)] + F(di)
            dy = ly[None, :, None, None] - py[:, None, :, None]  # gy x sy x gx x 1
            dx = lx[None, None, None, :] - px[:, None, :, None]  # gy x 1 x gx x sx
            d = dy * dy + dx * dx
            cid = (ny[:, None] * gx + nx[None, :]).astype(np.int32)[:, None, :, None]
            closer = d < f1
            if second:
                dxb, dyb = np.broadcast_to(dx, shape), np.broadcast_to(dy, shape)
                mid = ~closer & (d < f2)  # the new point becomes F2 ...
                np.copyto(ox2, ox, where=closer)  # ... or the old F1 does
                np.copyto(oy2, oy, where=closer)
                np.copyto(ox2, dxb, where=mid)
                np.copyto(oy2, dyb, where=mid)
                del mid
            np.minimum(f2, np.where(closer, f1, d), out=f2)
            np.copyto(idx, np.broadcast_to(cid, shape), where=closer)
            np.copyto(ox, np.broadcast_to(dx, shape), where=closer)
            np.copyto(oy, np.broadcast_to(dy, shape), where=closer)
            np.copyto(f1, d, where=closer)
    r = lambda a: a.reshape(h, w)  # noqa: E731
    if second:
        return r(np.sqrt(f1)), r(np.sqrt(f2)), r(idx), r(ox), r(oy), r(ox2), r(oy2)
    return r(np.sqrt(f1)), r(np.sqrt(f2)), r(idx), r(ox), r(oy)


def stamp(img, cx, cy, radius, profile):
    """Adds profile(d) (d = distance / radius, float32 array) in a window of +-2.5 radii
    around (cx, cy) in texels, wrapping around the map's borders (periodic)."""
    h, w = img.shape
    k = int(np.ceil(2.5 * radius))
    ys = np.arange(int(np.floor(cy)) - k, int(np.floor(cy)) + k + 1)
    xs = np.arange(int(np.floor(cx)) - k, int(np.floor(cx)) + k + 1)
    dy = ((ys + 0.5 - cy) / radius).astype(F)
    dx = ((xs + 0.5 - cx) / radius).astype(F)
    d = np.sqrt(dy[:, None] ** 2 + dx[None, :] ** 2)
    img[np.ix_(ys % h, xs % w)] += profile(d)


def normalise(a):
    lo, hi = a.min(), a.max()
    return (a - lo) / (hi - lo)


def to16(a):
    return np.round(np.clip(a, 0.0, 1.0) * F(65535)).astype(np.uint16)


def smooth01(t):
    t = np.clip(t, F(0), F(1))
    return t * t * (F(3) - F(2) * t)


def tri(x):
    """Triangle wave of period 1 in [0, 1]: 0 at integers, 1 at half-integers."""
    return F(1) - np.abs(F(2) * (x - np.floor(x)) - F(1))


# --------------------------------------------------------------------------------- maps

def alien(rng, n=2048):
    # Ridged multi-octave value noise: sharp creases down to a 4-texel lattice.
    octaves = [(8, 0.50), (16, 0.28), (32, 0.16), (64, 0.09), (128, 0.055), (256, 0.032), (512, 0.02)]
    a = np.zeros((n, n), F)
    for c, amp in octaves:
        r = F(1) - np.abs(F(2) * value_noise(n, n, c, c, rng) - F(1))
        a += F(amp) * r * r
    a = normalise(a)
    # Craters: a bowl and a raised rim, radii 5..100 texels (many small, few large).
    def crater(d):
        rim = np.clip(F(1) - ((d - F(1)) / F(0.5)) ** 2, F(0), F(1))
        return np.where(d < 1, d * d - F(0.75), F(0.25) * rim * rim).astype(F)
    for _ in range(260):
        cx, cy = rng.random() * n, rng.random() * n
        r = 5 + 95 * rng.random() ** 3
        depth = 0.10 + 0.35 * (r / 100) ** 0.5
        stamp(a, cx, cy, r, lambda d, s=F(depth): s * crater(d))
    # Patches of small bumps (domes on a 32-texel Worley grid) where a coarse noise is high.
    f1, _, _, _, _ = worley(n, n, 64, 64, rng)
    bumps = np.clip(F(1) - f1 / F(0.42), F(0), F(1))
    bumps = np.sqrt(bumps)
    mask = smooth01((value_noise(n, n, 6, 6, rng) - F(0.5)) * F(5))
    a += F(0.18) * bumps * mask
    return normalise(a)


def roof_tiles(rng, n=2048, rows=16, per_row=16):
    x = ((np.arange(n) + 0.5) / n).astype(F)
    yr = x * F(rows)  # row coordinate (v)
    r = np.floor(yr).astype(np.int64)
    t = (yr - r).astype(F)  # 0 at the row's top (under the row above), 1 at its lower edge
    xt = x[None, :] * F(per_row) + F(0.5) * (r % 2).astype(F)[:, None]  # n x n, tile coordinate (u)
    k = np.floor(xt)
    s = xt - k  # 0..1 across the tile
    k = k.astype(np.int64) % per_row
    # Barrel profile across the tile with a gap of 3 % on each side: vertical sides.
    q = (s - F(0.5)) / F(0.47)
    barrel = np.clip(F(1) - q * q, F(0), F(1))
    barrel = barrel * np.sqrt(np.sqrt(barrel))  # (1 - q^2)^(5/4): rounded, meets the gap steeply
    tile_h = rng.random((rows, per_row), dtype=F) * F(0.06)  # each tile a little higher or lower
    tile_tilt = (rng.random((rows, per_row), dtype=F) - F(0.5)) * F(0.08)  # and tilted sideways
    rr = np.broadcast_to((r % rows)[:, None], (n, n))
    ramp = F(0.15) + F(0.55) * t[:, None]  # the tile rises towards its lower edge, then a step
    h = ramp * (F(0.5) + F(0.5) * barrel) + F(0.35) * barrel + tile_h[rr, k] + tile_tilt[rr, k] * (s - F(0.5))
    h = np.where(np.abs(q) < 1, h, F(0.1) * ramp)  # the gaps show the tiles underneath
    # The exposed lower edge is rounded over its last 4 texels (a thick, sharp step).
    lip = np.clip((F(1) - t) * F(n / rows) / F(4), F(0), F(1))
    h = h * (F(0.92) + F(0.08) * np.sqrt(lip))[:, None]
    fine = F(0.6) * value_noise(n, n, 256, 256, rng) + F(0.4) * value_noise(n, n, 512, 512, rng)
    h += F(0.035) * fine + F(0.03) * value_noise(n, n, 32, 32, rng)
    return normalise(h)


def helmet(rng, n=4096, cap_rows=200):
    # Plates: 16 x 8 Worley cells (256 x 512 texels: square on a UV sphere's equator).
    f1, f2, idx, x1, y1, x2, y2 = worley(n, n, 16, 8, rng, second=True)
    # Distance to the plate's border (the bisector of the two nearest points) and the
    # coordinate along it from the two points' midpoint, both in cell units.
    ex, ey = x1 - x2, y1 - y2  # p2 - p1
    sep = np.sqrt(ex * ex + ey * ey)
    border = (f2 * f2 - f1 * f1) / (F(2) * sep)
    along = ((x1 + x2) * ey - (y1 + y2) * ex) / (F(2) * sep)  # (x - m) . perp(p2 - p1) / |p2 - p1|
    del f1, f2, x1, y1, x2, y2, ex, ey, sep
    level = rng.random(16 * 8, dtype=F)[idx] * F(0.10)  # plates at slightly different levels
    del idx
    bevel = np.sqrt(np.clip(border / F(0.012), F(0), F(1)))  # V-groove ~ 6 x 12 texels, steep walls
    h = F(0.45) + level
    h = h * bevel + F(0.05) * (F(1) - bevel)
    # Rivets: a row 0.045 cells inside every border, spaced 0.07 cells along it (pairs
    # face each other across the seam); domes of radius 0.018 cells (~5 x 9 texels).
    pitch = F(0.07)
    t = along / pitch
    da = (t - np.floor(t + F(0.5))) * pitch
    del t, along
    db = border - F(0.045)
    d = np.sqrt(da * da + db * db) / F(0.018)
    del da, db, border
    h += F(0.2) * np.sqrt(np.clip(F(1) - d * d, F(0), F(1)))
    del d, bevel
    # Hammer dents: scallops of a fine Worley grid (16 x 32 texels) and a few broad dents.
    g1, _, _, _, _ = worley(n, n, 256, 128, rng)
    h -= F(0.05) * (F(1) - g1 * g1 / F(0.6))
    del g1
    h += F(0.08) * value_noise(n, n, 24, 12, rng) + F(0.02) * value_noise(n, n, 512, 512, rng)
    h = normalise(h)
    # Polar caps (UV sphere): the first and last cap_rows rows are a constant level, with a
    # smooth blend over the next 150 rows (constant heights close the pole; README).
    row = np.arange(n)
    dist = np.minimum(row, n - 1 - row).astype(F)
    wgt = smooth01((dist - F(cap_rows)) / F(150))
    h = F(0.5) + (h - F(0.5)) * wgt[:, None]
    h[dist < cap_rows] = F(0.5)
    return h


def tire(rng, n=4096):
    x = ((np.arange(n) + 0.5) / n).astype(F)  # u: rolling direction (around the torus)
    y = x.copy()  # v: across the tread
    X, Y = x[None, :], y[:, None]
    # Lateral grooves: 6 per tile along u, chevron-shaped (zig-zag in v), 0.16 of a pitch wide.
    pitch = F(6)
    lat = (X * pitch + F(0.35) * tri(Y * F(2))) % F(1)  # 0..1 between two lateral grooves
    dl = np.minimum(lat, F(1) - lat)  # distance to the nearest lateral groove, in pitches
    # Circumferential grooves at v = 0.25 and 0.75, 0.05 of a tile wide.
    dc = np.abs(((Y * F(2)) % F(1)) - F(0.5)) * F(0.5)  # distance to v = 0.25 + k / 2, in tiles
    wall = F(2.5 / 682.7)  # the walls' width: 2.5 texels, in pitches
    block = smooth01((dl - F(0.08)) / wall) * smooth01((dc - F(0.025)) / F(2.5 / 4096))
    # Sipes: thin (3-texel) slits across the middle of each block, zig-zag, not to the edge.
    sl = lat - F(0.5) - F(0.03) * (tri(Y * F(16)) - F(0.5))
    sipe = (np.abs(sl) < F(1.5 * 6 / n)) & (dc > F(0.06))
    h = F(0.1) + F(0.8) * block
    h = np.where(sipe & (block > F(0.99)), F(0.35), h)
    # Blocks wear: a little lower towards their trailing edge, plus rubber grain.
    h -= F(0.06) * block * lat
    h += F(0.04) * value_noise(n, n, 512, 512, rng) + F(0.03) * value_noise(n, n, 64, 64, rng)
    return normalise(h)


def creature(rng, n=4096):
    # Scales: 128 x 64 Worley cells (32 x 64 texels: square on a torus of minor radius
    # half its major one, at the tube's centre line).
    f1, f2, idx, _, oy = worley(n, n, 128, 64, rng)
    e = f2 - f1
    del f2
    dome = np.sqrt(np.clip(e / F(0.35), F(0), F(1)))  # rounded, steep sides
    tilt = np.clip(F(0.5) + oy, F(0), F(1))  # each scale rises towards its rear (+v) edge
    del oy
    size = F(0.8) + F(0.4) * rng.random(128 * 64, dtype=F)[idx]
    del idx
    h = dome * (F(0.35) + F(0.65) * tilt) * size
    groove = np.clip(F(1) - e / F(0.04), F(0), F(1))  # a fine groove on every border
    h -= F(0.12) * groove
    del e, groove, tilt, f1, dome
    # Fine wrinkles: meandering ridges every 8 texels along v, strong only in patches.
    warp = value_noise(n, n, 16, 16, rng) * F(6) + value_noise(n, n, 64, 64, rng) * F(1.5)
    y = ((np.arange(n) + 0.5) / n).astype(F)
    ph = y[:, None] * F(512) + warp  # integer frequency: periodic in v; warp periodic
    wr = tri(ph)
    del ph, warp
    wr = wr * wr
    strength = smooth01((value_noise(n, n, 8, 8, rng) - F(0.3)) * F(2.5))
    h += F(0.07) * wr * (F(0.3) + F(0.7) * strength)
    del wr, strength
    h += F(0.03) * value_noise(n, n, 256, 256, rng)
    return normalise(h)


MAPS = [
    ("alien_2k.png", alien, 101),
    ("roof_tiles_2k.png", roof_tiles, 202),
    ("helmet_4k.png", helmet, 303),
    ("tire_4k.png", tire, 404),
    ("creature_4k.png", creature, 505),
]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_OUT
    only = set(sys.argv[2:])  # map names: only those (default: all)
    unknown = only - {m[0] for m in MAPS}
    if unknown:
        sys.exit(f"make_paper_maps.py: unknown map {sorted(unknown)}; known: {[m[0] for m in MAPS]}")
    os.makedirs(out, exist_ok=True)
    t_all = time.time()
    for name, fn, seed in MAPS:
        if only and name not in only:
            continue
        t0 = time.time()
        img = to16(fn(np.random.default_rng(seed)))
        t1 = time.time()
        path = os.path.join(out, name)
        tmp = path + ".tmp"
        write_png16(tmp, img)
        os.replace(tmp, path)  # never a half-written map under the final name
        steps = max(int(np.abs(np.diff(img.astype(np.int32), axis=1)).max()),
                    int(np.abs(np.diff(img.astype(np.int32), axis=0)).max()))
        print(f"{os.path.normpath(path)}: {img.shape[1]}x{img.shape[0]}, values {img.min()}..{img.max()}, "
              f"mean {img.mean() / 65535:.3f}, largest step {steps / 65535:.3f}, {os.path.getsize(path)} bytes, "
              f"{t1 - t0:.1f} s + {time.time() - t1:.1f} s to write")
        del img
    print(f"all maps: {time.time() - t_all:.1f} s")


if __name__ == "__main__":
    main()
