#!/usr/bin/python3
"""The stiff and extreme catalogue through whole traversals: every case of the inversion
catalogue (tests/fixtures/stiff_cases.cpp, rebuilt here in float32 with the same
construction) and the stiff scenarios of tests/traversal_test.cpp, written as scenes
(OBJ mesh + 16-bit height map + scene JSON), traced by `oblong trace` with every exact
configuration and compared ray by ray with the brute-force oracle.

Ray families (as in tests/traversal_test.cpp): camera, grazing (0.6–6° off the
tangent plane), along ±N (from above, below, inside), inside the shell, non-unit and
axis-aligned directions, from very far away, rays aimed at the prism's corners, edges
and side walls, and — from the oracle's hits of the camera rays — spawned rays (at the
hit with tmin = ε, or moved off it) and shadow rays with a finite tmax.

A mismatch (hit/miss differs, or |Δt| > 1e-5·max(|t|, 1e-3)) in an exact configuration
fails the experiment. Pre-tessellation (Embree's own triangle test) and fixed-step
marching are reported, not required to match.

The translated strip: one strip traced at the origin and at three other placements (two
authored there, one through the scene transform) with the same grazing rays moved with
it, canonical and brute force; more than 1e-4 of the rays whose hit differs between two
placements (hit/miss, t, uv, bit for bit) fails the experiment (translated_strip.csv).

    /usr/bin/python3 experiments/stability/run.py [--quick] [--build DIR] [--out DIR]
"""
import math
import sys
import zlib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scenes" / "tools"))
import common as C  # noqa: E402
import rays as R  # noqa: E402

NAME = "stability"
TITLE = "Stability: the stiff catalogue through whole traversals, mismatches against the oracle"
HYPOTHESIS = ("docs/design.md invariants 1 and 3: every exact configuration returns the brute-force oracle's first "
              "hit on every ray, also on stiff geometry (slivers, near-tangent, diverging and converging normals, "
              "100× displacement, far from the origin, high tiling, rotated and mirrored uvs).")

# Exact configurations: (label, scene variant, flags). "lowres" = the scene with
# rmip resolution 8, layout corners, compression 0 (as in the tests); the others use the default scene.
# Besides these, every registered strategy swapped into the canonical configuration
# (configs(): read from the binary's registry).
SHAPES = [
    ("canonical", "", []),
    ("rmip_lowres8_c0", "lowres", []),
    ("tfdm", "", C.TFDM),
    ("inversion_off", "", ["--inversion-in-traversal", "false"]),
    ("marching_0.5", "", ["--marching-scale", "0.5"]),
    ("marching_16", "", ["--marching-scale", "16"]),
]


def configs(ctx) -> list:
    out = SHAPES[:3]
    for kind, flag in (("range", "--range"), ("splitter", "--splitter"), ("inverter", "--inverter")):
        out += [(n, "", [flag, n]) for n in C.strategy_names(ctx, kind)[1:]]
    return out + SHAPES[3:]
REPORTED = [("tessellated", "", ["--baseline", "tessellated"]), ("fixedstep", "", ["--baseline", "fixedstep"])]
QUICK = ["canonical", "rmip_lowres8_c0", "tfdm"]  # quick mode (CI): the reported baselines are left out too


# ---------------------------------------------------------------------------------------
# Geometry (float32 like the C++ catalogue: double construction, float storage)


def f32(v):
    import numpy as np

    return np.asarray(v, dtype=np.float32)


def normalize(v):
    import numpy as np

    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def tilt(d, deg):
    a = math.radians(deg)
    d = normalize(d)
    return f32([math.sin(a) * d[0], math.sin(a) * d[1], math.cos(a)])


P0, P1, P2 = f32([0, 0, 0]), f32([1, 0, 0]), f32([0.3, 0.9, 0])
CENTROID = f32([(0 + 1 + 0.3) / 3, 0.3])


def radial(deg, offset=(0, 0, 0)):
    ps = [P0, P1, P2]
    ns = [tilt(p[:2].astype("f8") - CENTROID.astype("f8"), deg) for p in ps]
    off = f32(offset)
    return [p + off for p in ps], ns


def sphere_cap(R_):
    import numpy as np

    c = np.array([0.0, 0.0, -R_])
    ds = [normalize(np.asarray(q, "f8") - c) for q in (P0, P1, P2)]
    return [f32(c + R_ * d) for d in ds], [f32(d) for d in ds]


def catalogue():
    """(name, what, positions, normals, uvs or None, hmin, hmax), tests/fixtures/stiff_cases.cpp's order."""
    cases = []

    def add(name, what, pn, hmin, hmax, uvs=None):
        cases.append((name, what, pn[0], [f32(normalize(n)) for n in pn[1]], uvs, hmin, hmax))

    add("regular", "normals 15° from the face, h ±0.2", radial(15), -0.2, 0.2)
    add("prism_corners_edges", "as regular; every ray aimed at the prism's corners, edges and side walls",
        radial(15), -0.2, 0.2)
    add("h_extremes", "as regular, heights -0.5..1", radial(15), -0.5, 1.0)
    p2 = f32([0.5, 1e-4, 0])
    add("sliver_1e4", "aspect 1e4, normals spread 20° along the long edge",
        ([P0, P1, p2], [tilt([-1, 0], 10), tilt([1, 0], 10), tilt([0, 1], 0)]), -0.01, 0.01)
    add("sliver_1e4_twisted", "the sliver with normals also tilting 5° across it",
        ([P0, P1, p2], [tilt([-1, -0.5], 10), tilt([1, -0.5], 10), tilt([0, 1], 5)]), -0.01, 0.01)
    add("uv_near_degenerate", "uv triangle of doubled area 1e-6", radial(15), -0.2, 0.2,
        uvs=[f32([0, 0]), f32([1, 0]), f32([0.5, 1e-6])])
    add("normals_near_tangent", "vertex normals 88°, 89°, 89.5° from the face normal",
        ([P0, P1, P2], [tilt([1, 0], 88), tilt([math.cos(0.349), math.sin(0.349)], 89),
                        tilt([math.cos(0.698), math.sin(0.698)], 89.5)]), -0.05, 0.05)
    add("normals_diverging_100deg", "normals tilted 50° outward", radial(50), -0.1, 0.5)
    add("normals_converging_100deg", "normals tilted 50° inward (they cross above the triangle)", radial(-50), -0.1,
        0.3)
    z = f32([0, 0, 1])
    add("parallel_normals", "flat shading", ([P0, P1, P2], [z, z, z]), -0.3, 0.3)
    t = tilt([1, 1], 60)
    add("parallel_normals_tilted", "all normals equal, 60° from the face normal", ([P0, P1, P2], [t, t, t]), -0.3,
        0.3)
    add("coplanar_normals", "cylinder-like normals", ([P0, P1, P2], [tilt([0, -1], 20), tilt([0, -1], 20),
                                                                      tilt([0, 1], 20)]), -0.3, 0.3)
    add("displacement_100x", "h ±100 on a triangle of size 1 (sphere-like normals, R = 200)", sphere_cap(200), -100,
        100)
    add("displacement_100x_focal", "h ±100, R = 50: the prism passes the normals' focus", sphere_cap(50), -100, 100)
    add("translated_1e4", "regular, translated by (1e4, -1e4, 1e4)", radial(15, (1e4, -1e4, 1e4)), -0.2, 0.2)
    add("translated_1e6", "regular, translated by (1e6, 1e6, -1e6)", radial(15, (1e6, 1e6, -1e6)), -0.2, 0.2)
    return cases


def height_map(w, h, seed):
    """core/procedural.cpp's recipe (waves + periodic value noise + sharp plateaus) with
    numpy's random lattice, in [0, 1] with both ends reached."""
    import numpy as np

    rng = np.random.default_rng(seed)
    cw = ch = 16
    lat = rng.uniform(size=(ch, cw))
    x = (np.arange(w) + 0.5) / w
    y = (np.arange(h) + 0.5) / h
    X, Y = np.meshgrid(x, y)
    fx, fy = X * cw, Y * ch
    i, j = np.floor(fx).astype(int), np.floor(fy).astype(int)
    tx, ty = fx - i, fy - j
    sx, sy = tx * tx * (3 - 2 * tx), ty * ty * (3 - 2 * ty)

    def L(a, b):
        return lat[b % ch, a % cw]

    n = (1 - sy) * ((1 - sx) * L(i, j) + sx * L(i + 1, j)) + sy * ((1 - sx) * L(i, j + 1) + sx * L(i + 1, j + 1))
    waves = 0.5 + 0.25 * np.sin(2 * np.pi * 3 * X) * np.cos(2 * np.pi * 2 * Y) + 0.15 * np.sin(2 * np.pi * (5 * X + 7 * Y))
    t = np.clip(0.6 * waves + 0.4 * n + np.where(n > 0.6, 0.35, 0.0) - 0.2, 0, 1)
    t = (t - t.min()) / max(1e-12, t.max() - t.min())
    return np.round(t * 65535).astype(np.uint16)


def write_obj(path, tris):
    """tris: list of (positions[3], normals[3], uvs[3]) float32 triangles."""
    lines = ["# stiff case (experiments/stability)"]
    k = 0
    for ps, ns, uvs in tris:
        for p in ps:
            lines.append("v {:.9g} {:.9g} {:.9g}".format(*map(float, p)))
        for t in uvs:
            lines.append("vt {:.9g} {:.9g}".format(*map(float, t)))
        for n in ns:
            lines.append("vn {:.9g} {:.9g} {:.9g}".format(*map(float, n)))
    for _ in tris:
        a, b, c = k + 1, k + 2, k + 3
        lines.append(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}")
        k += 3
    Path(path).write_text("\n".join(lines) + "\n")


def quad(n, half=1.0, y=0.0, offset=(0, 0, 0), normals=None, uvmap=None):
    """core/procedural.cpp quadMesh(half, y, n) as a triangle list."""
    P, N, U = [], [], []
    for j in range(n + 1):
        for i in range(n + 1):
            u, v = i / n, j / n
            P.append(f32([-half + 2 * half * u + offset[0], y + offset[1], -half + 2 * half * v + offset[2]]))
            N.append(f32([0, 1, 0]))
            U.append(f32([u, v]) if uvmap is None else f32(uvmap(u, v)))
    if normals is not None:
        N = normals(len(N))
    tris = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c = a + 1, a + n + 1
            d = c + 1
            for t in ((a, c, b), (b, c, d)):
                tris.append(([P[x] for x in t], [N[x] for x in t], [U[x] for x in t]))
    return tris


class Case:
    def __init__(self, name, what, tris=None, shape=None, disp=None, hmin=0.0, hmax=0.0, boundary_only=False,
                 sphere=None, offset=None):
        self.name, self.what, self.tris, self.shape = name, what, tris, shape
        self.disp, self.hmin, self.hmax, self.boundary_only, self.sphere = disp, hmin, hmax, boundary_only, sphere
        # offset: the mesh is written at the origin and moved by the scene's transform
        # (its frame, docs/decisions.md "Mesh frames"); `tris` (for the rays) are the
        # moved triangles in float64, `file_tris` what the OBJ holds.
        self.offset, self.file_tris = offset, tris
        if offset is not None:
            import numpy as np
            off = np.asarray(offset, "f8")
            self.tris = [([np.asarray(p, "f8") + off for p in ps], ns, uvs) for ps, ns, uvs in tris]


def cases():
    import numpy as np

    out = []
    for name, what, ps, ns, uvs, hmin, hmax in catalogue():
        uvs = uvs or [f32([0, 0]), f32([1, 0]), f32([0, 1])]
        scale = hmax - hmin
        out.append(Case(name, what, tris=[(ps, ns, uvs)], hmin=hmin, hmax=hmax,
                        disp={"map": (32, 32, 5), "scale": scale, "bias": hmin / scale},
                        boundary_only=(name == "prism_corners_edges")))
    # tests/traversal_test.cpp's stiff scenarios.
    rng = np.random.default_rng(23)

    def twisted_normals(k):
        return [f32(normalize([rng.uniform(-0.5, 0.5), 1.0, rng.uniform(-0.5, 0.5)])) for _ in range(k)]

    twisted = quad(3, normals=twisted_normals)
    twisted_disp = {"map": (48, 48, 7), "scale": 0.15, "bias": -0.5, "tiling": [2, 2]}
    out.append(Case("twisted", "quad 3×3, random vertex normals up to ~35° off (traversal_test)",
                    tris=twisted, disp=twisted_disp, hmin=-0.075, hmax=0.075))
    # The same scene moved through the scene transform: the traversal runs in the mesh's
    # frame, so work and hits follow the untranslated case (steps_per_ray comparable).
    for d in (1e2, 1e4, 1e6):
        out.append(Case(f"twisted_moved_{d:.0e}", f"the twisted quad moved by ({d:.0e}, -{d:.0e}, {d:.0e}) "
                        "through the scene transform", tris=twisted, disp=twisted_disp, hmin=-0.075, hmax=0.075,
                        offset=(d, -d, d)))
    out.append(Case("deep_sphere", "sphere 10×6 displaced 0.6 of its radius inwards (normals converge in the shell)",
                    shape={"type": "sphere", "radius": 1, "segments": [10, 6]},
                    disp={"map": (64, 32, 5), "scale": 0.6, "bias": -1.0, "tiling": [2, 1]}, hmin=-0.6, hmax=0.0,
                    sphere=1.0))
    out.append(Case("tiling_10x", "one quad, 23×19 map tiled 10×11", tris=quad(1),
                    disp={"map": (23, 19, 8), "scale": 0.03, "bias": -0.5, "tiling": [10, 11]}, hmin=-0.015,
                    hmax=0.015))
    out.append(Case("far_from_origin", "quad 2×2 at (1e4, -3e3, 2e4)", tris=quad(2, offset=(1e4, -3e3, 2e4)),
                    disp={"map": (32, 32, 6), "scale": 0.1, "bias": -0.5, "tiling": [3, 3]}, hmin=-0.05, hmax=0.05))
    c, s = math.cos(0.5), math.sin(0.5)
    out.append(Case("rotated_mirrored_uvs", "quad 2×2, uvs rotated 0.5 rad, mirrored, negative",
                    tris=quad(2, uvmap=lambda u, v: (-1.3 + 1.7 * (c * u - s * v), 0.4 - 1.1 * (s * u + c * v))),
                    disp={"map": (29, 35, 12), "scale": 0.08, "bias": -0.5, "tiling": [2, 3]}, hmin=-0.04,
                    hmax=0.04))
    return out


def write_case(ctx, case):
    """Scene files of a case: default strategies and the low-resolution RMIP variant."""
    import png16

    mw, mh, seed = case.disp["map"]
    mp = ctx.tmp("cases", f"{case.name}_map.png")
    png16.write_png16(str(mp), height_map(mw, mh, seed))
    disp = {"map": str(mp), "scale": case.disp["scale"], "bias": case.disp["bias"]}
    if "tiling" in case.disp:
        disp["tiling"] = case.disp["tiling"]
    if case.shape:
        mesh = {"shape": case.shape, "displacement": disp}
    else:
        obj = ctx.tmp("cases", f"{case.name}.obj")
        write_obj(obj, case.file_tris)
        mesh = {"file": str(obj), "displacement": disp}
        if case.offset is not None:
            mesh["transform"] = {"translate": [float(x) for x in case.offset]}
    doc = {"meshes": [mesh]}
    base = ctx.write_scene(f"stiff_{case.name}", doc)
    low = dict(doc, strategies={"range": {"name": "rmip", "resolution": 8, "layout": "corners", "compression": 0}})
    lowp = ctx.write_scene(f"stiff_{case.name}_lowres", low)
    return {"": base, "lowres": lowp}


# ---------------------------------------------------------------------------------------
# Rays


def base_points(case, rng, k):
    """k random points on the base surface with their unit displacement directions."""
    import numpy as np

    if case.sphere:
        d = rng.normal(size=(k, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return case.sphere * d, d
    T = case.tris
    idx = rng.integers(0, len(T), size=k)
    u, v = rng.uniform(size=k), rng.uniform(size=k)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    P = np.array([[np.asarray(p, "f8") for p in T[i][0]] for i in idx])
    N = np.array([[np.asarray(n, "f8") for n in T[i][1]] for i in idx])
    b = np.stack([1 - u - v, u, v], 1)[..., None]
    p = (b * P).sum(1)
    n = (b * N).sum(1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return p, n


def boundary_points(case, rng, k):
    """Points on the prism of a one-triangle case: corners, edges (9) and side walls."""
    import numpy as np

    ps, ns, _ = case.tris[0]
    P = [np.asarray(p, "f8") for p in ps]
    N = [normalize(n) for n in ns]
    out = []
    for _ in range(k):
        kind = rng.integers(0, 3)
        e = rng.integers(0, 3)
        a, b = e, (e + 1) % 3
        h = case.hmin if rng.uniform() < 0.5 else case.hmax
        if kind == 0:  # corner
            out.append(P[a] + h * N[a])
        elif kind == 1:  # cap edge or vertical edge
            if rng.uniform() < 0.5:
                s = rng.uniform()
                n = normalize((1 - s) * N[a] + s * N[b])
                out.append((1 - s) * P[a] + s * P[b] + h * n)
            else:
                out.append(P[a] + rng.uniform(case.hmin, case.hmax) * N[a])
        else:  # side wall
            s = rng.uniform()
            n = normalize((1 - s) * N[a] + s * N[b])
            out.append((1 - s) * P[a] + s * P[b] + rng.uniform(case.hmin, case.hmax) * n)
    return np.array(out)


def rand_dirs(rng, k):
    import numpy as np

    d = rng.normal(size=(k, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def first_rays(case, count, rng):
    """The families that do not need the oracle: (rays (k, 8) float32, family names)."""
    import numpy as np

    if case.sphere:
        lo, hi = np.full(3, -case.sphere * 1.0), np.full(3, case.sphere * 1.0)
    else:
        pts = np.array([np.asarray(p, "f8") for t in case.tris for p in t[0]])
        lo, hi = pts.min(0), pts.max(0)
    hmax = max(abs(case.hmin), abs(case.hmax))
    c = 0.5 * (lo + hi)
    diag = float(np.linalg.norm(hi - lo + 2 * hmax))
    fam, rs = [], []

    def add(o, d, name, tmin=0.0, tmax=np.inf):
        o, d = np.atleast_2d(o), np.atleast_2d(d)
        r = np.zeros((len(o), 8))
        r[:, 0:3], r[:, 3:6], r[:, 6], r[:, 7] = o, d, tmin, tmax
        rs.append(r)
        fam.extend([name] * len(o))

    k = count
    if case.boundary_only:
        tgt = boundary_points(case, rng, 4 * k)
        o = c + 1.5 * diag * rand_dirs(rng, 4 * k)
        d = tgt - o
        add(o, d / np.linalg.norm(d, axis=1, keepdims=True), "prism boundary")
        # grazing along the boundary points
        tgt = boundary_points(case, rng, k)
        d = rand_dirs(rng, k)
        add(tgt - 0.6 * diag * d, d, "prism boundary (random direction)")
    else:
        p, n = base_points(case, rng, k)
        o = c + 1.5 * diag * rand_dirs(rng, k)
        tgt = p + rng.uniform(-1, 1, size=(k, 1)) * hmax * n
        d = tgt - o
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        add(o, d, "camera")
        add(o[: k // 4], d[: k // 4] * 7.5, "camera (|d| = 7.5)")
        add(o[k // 4: k // 2], d[k // 4: k // 2] * 0.02, "camera (|d| = 0.02)")
        p, n = base_points(case, rng, k)
        t = np.cross(n, rand_dirs(rng, k))
        t /= np.maximum(1e-9, np.linalg.norm(t, axis=1, keepdims=True))
        tl = (rng.uniform(size=(k, 1)) - 0.5) * np.where(np.arange(k) % 2, 0.02, 0.2)[:, None]
        dd = t + tl * n
        dd /= np.linalg.norm(dd, axis=1, keepdims=True)
        tgt = p + rng.uniform(-1, 1, size=(k, 1)) * hmax * n
        add(tgt - 0.6 * diag * dd, dd, "grazing")
        p, n = base_points(case, rng, k)
        side = np.where(rng.uniform(size=k) < 0.5, 1.0, -1.0)[:, None]
        start = np.where((np.arange(k) % 3 == 0)[:, None], rng.uniform(-1, 1, size=(k, 1)) * hmax, side * 3 * hmax)
        add(p + start * n, -side * n, "along ±N")
        p, n = base_points(case, rng, k)
        add(p + rng.uniform(-1.2, 1.2, size=(k, 1)) * hmax * n, rand_dirs(rng, k), "inside the shell")
        p, _ = base_points(case, rng, k // 4)
        ax = np.zeros((k // 4, 3))
        ax[np.arange(k // 4), np.arange(k // 4) % 3] = np.where((np.arange(k // 4) // 3) % 2, 1.0, -1.0)
        add(p - (2 * hmax + 0.5 * diag) * ax, ax, "axis-aligned")
        p, _ = base_points(case, rng, k // 4)
        far = c + 1000 * diag * rand_dirs(rng, k // 4)
        d = p - far
        add(far, d / np.linalg.norm(d, axis=1, keepdims=True), "from far away")
        tgt = boundary_points(case, rng, k // 2) if case.tris and len(case.tris) == 1 else None
        if tgt is not None:
            o = c + 1.5 * diag * rand_dirs(rng, len(tgt))
            d = tgt - o
            add(o, d / np.linalg.norm(d, axis=1, keepdims=True), "prism boundary")
    return np.concatenate(rs).astype(np.float32), fam, c, diag


def spawned(rays, hits, fam, c, diag, rng):
    """Spawned and shadow rays from the oracle's hits of the camera-like families."""
    import numpy as np

    sel = np.array([f.startswith(("camera", "prism boundary")) for f in fam]) & np.isfinite(hits["t"])
    o = rays[sel, 0:3].astype("f8")
    d = rays[sel, 3:6].astype("f8")
    p = o + hits["t"][sel][:, None] * d
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    eps = 1e-4 * np.maximum(1.0, np.abs(p).max(axis=1))
    k = len(p)
    out, names = [], []
    nd = R.random_hemisphere(-dn, rng)
    at_hit = np.arange(k) % 2 == 0
    r = np.zeros((k, 8))
    r[:, 0:3] = np.where(at_hit[:, None], p, p - eps[:, None] * dn)
    r[:, 3:6] = nd
    r[:, 6] = np.where(at_hit, eps, 0.0)
    r[:, 7] = np.inf
    out.append(r)
    names += ["spawned (tmin = ε)" if a else "spawned (moved off)" for a in at_hit]
    light = c + 1.2 * diag * rand_dirs(rng, k)
    L = light - (p - eps[:, None] * dn)
    ln = np.linalg.norm(L, axis=1)
    r = np.zeros((k, 8))
    r[:, 0:3] = p - eps[:, None] * dn
    r[:, 3:6] = L / ln[:, None]
    r[:, 7] = ln * (0.3 + 0.7 * rng.uniform(size=k))
    out.append(r)
    names += ["shadow (finite tmax)"] * k
    return np.concatenate(out).astype(np.float32), names


# ---------------------------------------------------------------------------------------
# Translated strip: the same strip at the origin and elsewhere, the same rays moved with it
# (docs/decisions.md, "Mesh frames"). Its 320 000 texels along 100 units are a few dozen
# float ulps wide; a mesh's frame that follows the mesh makes every hit identical.

STRIP_PLACEMENTS = [  # (name, offset, through the scene transform)
    ("authored at x + 100", (100.0, 0.0, 0.0), False),
    ("authored at + (12345.678, -271.828, 0)", (12345.678, -271.828, 0.0), False),
    ("moved by the transform (12345.678, -271.828, 3.3)", (12345.678, -271.828, 3.3), True),
]
STRIP_MAX_DIFFERING = 1e-4  # fraction of rays allowed to differ between placements


def strip_obj(path, offset):
    """50 quads of 2 × 0.01 along x ∈ [0, 100], normal +y, u along x, moved by `offset`
    (float32 arithmetic; the offsets used keep the coordinates exact)."""
    import numpy as np

    off = f32(offset)
    lines = []
    for i in range(51):
        for z, v in ((0.0, 0.0), (0.01, 1.0)):
            q = f32([2.0 * i, 0.0, z])
            p = q + off
            assert all(float(c) == float(a) + float(b) for c, a, b in zip(p, q, off)), "strip coordinates not exact"
            lines.append("v {} {} {}\nvt {} {}\nvn 0 1 0".format(*(str(np.float32(c)) for c in p), i / 50, v))
    for i in range(50):
        a, b, c, d = 2 * i + 1, 2 * i + 2, 2 * i + 3, 2 * i + 4
        lines.append(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\nf {c}/{c}/{c} {b}/{b}/{b} {d}/{d}/{d}")
    Path(path).write_text("\n".join(lines) + "\n")


def strip_rays(count, rng):
    """Grazing rays over the strip (0.5–2.5° down, any heading in the xz plane) starting
    just above the shell, origins on a grid (x 2^-10, y 2^-15, z 2^-22) on which the
    offsets' sums are exact."""
    import numpy as np

    x, z, y = 5 + 90 * rng.uniform(size=count), 0.01 * rng.uniform(size=count), 0.0011 + 0.0002 * rng.uniform(size=count)
    phi, a = 2 * np.pi * rng.uniform(size=count), np.radians(0.5 + 2.0 * rng.uniform(size=count))
    d = np.stack([np.cos(phi) * np.cos(a), -np.sin(a), np.sin(phi) * np.cos(a)], 1)
    o = np.stack([np.round((x - 0.02 * d[:, 0]) * 2.0**10) / 2.0**10, np.round(y * 2.0**15) / 2.0**15,
                  np.round((z - 0.02 * d[:, 2]) * 2.0**22) / 2.0**22], 1)
    r = np.zeros((count, 8))
    r[:, 0:3], r[:, 3:6], r[:, 7] = o, d, np.inf
    return r.astype(np.float32)


def strip_differences(a, b):
    """Rays whose hits differ between two placements: hit/miss, t, or (same triangle) uv,
    bit for bit (the hit files print floats round-trip); equal t on two triangles sharing
    an edge is a tie, not a difference."""
    import numpy as np

    ha, hb = np.isfinite(a["t"]), np.isfinite(b["t"])
    both = ha & hb
    same_t = both & (a["t"] == np.where(hb, b["t"], 0))
    tie = same_t & (a["prim"] != b["prim"])
    same = (~ha & ~hb) | (same_t & (((a["prim"] == b["prim"]) & (a["u"] == b["u"]) & (a["v"] == b["v"])) | tie))
    ta, tb = np.where(both, a["t"], 0), np.where(both, b["t"], 0)
    rel = np.abs(ta - tb) > 0.01 * np.abs(ta)
    return {"differing": int((~same).sum()), "hit_miss_differ": int((ha != hb).sum()),
            "t_differ_1pct": int((both & rel).sum()), "ties": int(tie.sum())}


def translated_strip(ctx):
    """Rows (placement × configuration) and failures of the translated-strip comparison."""
    import numpy as np
    import png16

    mp = ctx.tmp("strip", "strip_map.png")
    png16.write_png16(str(mp), height_map(64, 64, 11))
    disp = {"map": str(mp), "scale": 0.001, "tiling": [5000, 0.2]}

    def scene(name, offset, transform):
        obj = ctx.tmp("strip", f"{name}.obj")
        strip_obj(obj, (0, 0, 0) if transform else offset)
        mesh = {"file": str(obj), "displacement": disp}
        if transform:
            mesh["transform"] = {"translate": [float(np.float32(c)) for c in offset]}
        return ctx.write_scene(f"strip_{name}", {"meshes": [mesh]})

    rays = strip_rays(ctx.pick(20000, 500), np.random.default_rng(11))
    n_brute = ctx.pick(200, 20)
    configs_strip = [("canonical", [], rays), ("bruteforce", ["--baseline", "bruteforce"], rays[:n_brute])]
    near = scene("origin", (0, 0, 0), False)

    def trace(sc, rs, flags, label):
        rp, out = ctx.tmp("strip", f"{label}_rays.bin"), ctx.tmp("strip", f"{label}.csv")
        R.write_rays(rp, rs)
        r = C.run_oblong(ctx, "trace", sc, list(flags) + ["--rays", rp, "-o", out], label=f"strip/{label}", threads=2)
        return R.read_hits(out), r.stats["ray_counters"]["steps_per_ray"]

    at_origin = {label: trace(near, rs, flags, f"origin_{label}") for label, flags, rs in configs_strip}
    rows, failures = [], []
    for k, (what, offset, transform) in enumerate(STRIP_PLACEMENTS):
        sc = scene(f"placement{k}", offset, transform)
        off = f32(offset)
        for label, flags, rs in configs_strip:
            moved = rs.copy()
            moved[:, 0:3] = rs[:, 0:3] + off
            if not np.array_equal(moved[:, 0:3].astype("f8"), rs[:, 0:3].astype("f8") + off.astype("f8")):
                raise C.ExperimentError(f"translated strip {what}: a moved ray origin is not exact")
            got, steps = trace(sc, moved, flags, f"placement{k}_{label}")
            ref, steps0 = at_origin[label]
            d = strip_differences(ref, got)
            rows.append({"placement": what, "offset": " ".join(str(np.float32(c)) for c in offset), "config": label,
                         "rays": len(rs), "hits_at_origin": int(np.isfinite(ref["t"]).sum()), **d,
                         "steps_per_ray_at_origin": steps0, "steps_per_ray_moved": steps})
            if d["differing"] > STRIP_MAX_DIFFERING * len(rs):
                failures.append(f"translated strip {what}/{label}: {d['differing']} of {len(rs)} rays differ")
    return rows, failures


# ---------------------------------------------------------------------------------------


def run(ctx):
    import numpy as np

    count = ctx.pick(200, 12)
    all_configs = configs(ctx)
    names = ctx.pick([c[0] for c in all_configs], QUICK)
    configs_run = [c for c in all_configs if c[0] in names] + ctx.pick(REPORTED, [])
    rows, fam_rows, failures, refused = [], [], [], []
    for case in cases():
        rng = np.random.default_rng(zlib.crc32(case.name.encode()))
        scenes = write_case(ctx, case)
        first, fam, c, diag = first_rays(case, count, rng)
        p1 = ctx.tmp("cases", f"{case.name}_rays1.bin")
        R.write_rays(p1, first)
        try:
            C.run_oblong(ctx, "trace", scenes[""], ["--rays", p1, "-o", ctx.tmp("cases", f"{case.name}_o1.csv"),
                                                    "--baseline", "bruteforce"], label=f"{case.name}/oracle-1",
                         threads=2)
        except C.ExperimentError as e:
            msg = str(e).strip().splitlines()[-1]
            refused.append(f"{case.name}: {msg}")
            rows.append({"case": case.name, "what": case.what, "config": "(scene refused)", "rays": 0,
                         "mismatches": "", "note": msg})
            ctx.log(f"{case.name}: refused: {msg}")
            continue
        h1 = R.read_hits(ctx.tmp("cases", f"{case.name}_o1.csv"))
        sec, sfam = spawned(first, h1, fam, c, diag, rng)
        allr = np.concatenate([first, sec])
        fams = fam + sfam
        rp = ctx.tmp("cases", f"{case.name}_rays.bin")
        R.write_rays(rp, allr)
        C.run_oblong(ctx, "trace", scenes[""], ["--rays", rp, "-o", ctx.tmp("cases", f"{case.name}_oracle.csv"),
                                                "--baseline", "bruteforce"], label=f"{case.name}/bruteforce",
                     threads=2)
        ref = R.read_hits(ctx.tmp("cases", f"{case.name}_oracle.csv"))
        famarr = np.array(fams)
        nhits = int(np.isfinite(ref["t"]).sum())
        for label, variant, flags in configs_run:
            out = ctx.tmp("cases", f"{case.name}_{label}.csv")
            r = C.run_oblong(ctx, "trace", scenes[variant], list(flags) + ["--rays", rp, "-o", out],
                             label=f"{case.name}/{label}", threads=2)
            got = R.read_hits(out)
            cm = R.compare(ref, got, allr)
            exact = label not in ("tessellated", "fixedstep")
            if exact and cm["mismatches"]:
                failures.append(f"{case.name}/{label}: {cm['mismatches']} of {cm['rays']}")
            cnt = r.stats.get("counters", {})
            rows.append({"case": case.name, "what": case.what, "config": label, "exact_claimed": exact,
                         "geometry": r.stats["geometry"], **cm,
                         "steps_per_ray": r.stats["ray_counters"]["steps_per_ray"],
                         "box_only_prisms": cnt.get("traversal/BoxOnlyPrisms", ""),
                         "ill_posed_triangles": cnt.get("traversal/IllPosedTriangles", ""),
                         "rejected_inversions": cnt.get("traversal/RejectedInversions", ""), "note": ""})
            if cm["mismatches"]:
                # per family, for the record
                tr, tg = ref["t"], got["t"]
                hr, hg = np.isfinite(tr), np.isfinite(tg)
                bad = (hr != hg) | (hr & hg & (np.abs(np.where(hr, tr, 0) - np.where(hg, tg, 0)) >
                                               R.REL_T * np.maximum(np.abs(np.where(hr, tr, 0)), 1e-3)))
                for f in sorted(set(fams)):
                    m = famarr == f
                    if bad[m].any():
                        fam_rows.append({"case": case.name, "config": label, "family": f, "rays": int(m.sum()),
                                         "mismatches": int(bad[m].sum())})
        ctx.log(f"{case.name}: {len(allr)} rays ({nhits} oracle hits), "
                f"{sum(1 for x in rows if x['case'] == case.name and x.get('exact_claimed') and x['mismatches'])} "
                f"exact configurations with mismatches")
    strip_rows, strip_failures = translated_strip(ctx)
    failures += strip_failures
    C.write_csv(ctx.out / "translated_strip.csv", strip_rows)
    ctx.log(f"translated strip: {sum(r['differing'] for r in strip_rows)} of {sum(r['rays'] for r in strip_rows)} "
            "rays differ between placements")
    fields = ["case", "what", "config", "exact_claimed", "geometry", "rays", "oracle_hits", "mismatches", "missed_hits",
              "false_hits", "t_mismatches", "max_abs_dt", "steps_per_ray", "box_only_prisms", "ill_posed_triangles",
              "rejected_inversions", "note"]
    C.write_csv(ctx.out / "results.csv", rows, fields)
    if fam_rows:
        C.write_csv(ctx.out / "mismatches_by_family.csv", fam_rows)

    # Plot: mismatch matrix (cases × configurations).
    plt = C.plt()
    case_names = []
    for r in rows:
        if r["case"] not in case_names:
            case_names.append(r["case"])
    cfg_names = [c[0] for c in configs_run]
    M = np.full((len(case_names), len(cfg_names)), np.nan)
    for r in rows:
        if r["config"] in cfg_names and r["rays"]:
            M[case_names.index(r["case"]), cfg_names.index(r["config"])] = r["mismatches"] / r["rays"]
    fig, ax = plt.subplots(figsize=(1.0 + 0.55 * len(cfg_names), 1.2 + 0.28 * len(case_names)))
    from matplotlib.colors import LogNorm

    show = np.where(M > 0, M, np.nan)
    im = ax.imshow(show, norm=LogNorm(vmin=1e-4, vmax=1), cmap="Reds", aspect="auto")
    for i in range(len(case_names)):
        for j in range(len(cfg_names)):
            r = next((x for x in rows if x["case"] == case_names[i] and x["config"] == cfg_names[j]), None)
            txt = "–" if r is None or not r["rays"] else str(r["mismatches"])
            ax.text(j, i, txt, ha="center", va="center", fontsize=6, color="k" if txt in ("0", "–") else "w")
    ax.set_xticks(range(len(cfg_names)), cfg_names, rotation=60, ha="right", fontsize=7)
    ax.set_yticks(range(len(case_names)), case_names, fontsize=7)
    ax.set_title("mismatches against the brute-force oracle (count; colour = fraction of rays)\n"
                 "tessellated and fixedstep are not exact by design", fontsize=8)
    fig.colorbar(im, ax=ax, fraction=0.03, label="mismatching fraction of rays")
    fig.tight_layout()
    fig.savefig(ctx.out / "stability.png")

    header = ["case"] + cfg_names
    trows = []
    for cn in case_names:
        line = [cn]
        for cf in cfg_names:
            r = next((x for x in rows if x["case"] == cn and x["config"] == cf), None)
            line.append("refused" if r is None else f"{r['mismatches']}")
        trows.append(line)
    nr = {cn: next((x["rays"] for x in rows if x["case"] == cn and x["rays"]), 0) for cn in case_names}
    trows = [[f"{t[0]} ({nr[t[0]]} rays)"] + t[1:] for t in trows]
    exact_rows = [r for r in rows if r.get("exact_claimed")]
    tot = sum(r["rays"] for r in exact_rows)
    info = [r for r in rows if r["config"] in ("tessellated", "fixedstep")]
    tess = sum(r["mismatches"] for r in info if r["config"] == "tessellated")
    tsr = sum(r["rays"] for r in info if r["config"] == "tessellated")
    fs = sum(r["mismatches"] for r in info if r["config"] == "fixedstep")
    fsr = sum(r["rays"] for r in info if r["config"] == "fixedstep")
    ref_txt = (f"; for reference, pre-tessellation {tess} of {tsr} and fixed-step marching {fs} of {fsr} rays differ"
               if info else "")
    strip_txt = ("; translated strip (the same strip at the origin and at 3 other placements, the rays moved with "
                 f"it): {sum(r['differing'] for r in strip_rows)} of {sum(r['rays'] for r in strip_rows)} rays differ "
                 "between placements")
    verdict = (f"{len(case_names) - len(refused)} stiff scenes × {len(names)} exact configurations, {tot} ray traces: "
               f"{sum(r['mismatches'] for r in exact_rows)} mismatches against the oracle"
               + strip_txt
               + (f" ({'; '.join(failures)})" if failures else "")
               + ref_txt
               + (f"; scenes refused by the loader: {'; '.join(refused)}" if refused else "") + ".")
    strip_header = ["translated strip: placement", "config", "rays", "hits at the origin", "rays differing",
                    "hit/miss", "t by > 1 %", "steps/ray at the origin → moved"]
    strip_table = [[r["placement"], r["config"], r["rays"], r["hits_at_origin"], r["differing"], r["hit_miss_differ"],
                    r["t_differ_1pct"], f"{r['steps_per_ray_at_origin']:.1f} → {r['steps_per_ray_moved']:.1f}"]
                   for r in strip_rows]
    return {"status": "mismatch" if failures else "ok", "verdict": verdict,
            "tables": [C.md_table(header, trows), C.md_table(strip_header, strip_table)],
            "plots": ["stability.png"],
            "csv": ["results.csv", "translated_strip.csv"] + (["mismatches_by_family.csv"] if fam_rows else []),
            "failures": failures}


if __name__ == "__main__":
    sys.exit(C.main(sys.modules[__name__]))
