"""Ray sets for `oblong trace` (8 float32 per ray: ox oy oz dx dy dz tmin tmax, the `.bin`
format of render/rays_io.cpp), reading its hits CSV (`t,mesh,prim,u,v`, `inf,,,,` for a
miss) and comparing hits against the oracle with the conformance tests' criterion."""
import math

import numpy as np

REL_T = 1e-5  # tests/traversal_test.cpp sameT: |Δt| <= 1e-5 · max(|t|, 1e-3)


def camera_rays(scene: dict, w: int, h: int) -> np.ndarray:
    """Pinhole camera rays through the pixel centres, as render/camera.cpp makes them."""
    c = scene.get("camera", {})
    fr = np.array(c.get("from", [0, 0, 5]), float)
    to = np.array(c.get("to", [0, 0, 0]), float)
    up = np.array(c.get("up", [0, 1, 0]), float)
    fov = float(c.get("fov", 40))
    f = (to - fr) / np.linalg.norm(to - fr)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    th = math.tan(math.radians(fov) / 2)
    xs, ys = np.meshgrid((np.arange(w) + 0.5), (np.arange(h) + 0.5))
    sx = (2 * xs / w - 1) * th * (w / h)
    sy = (1 - 2 * ys / h) * th
    d = f[None, None, :] + sx[..., None] * r + sy[..., None] * u
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    out = np.zeros((h * w, 8), np.float32)
    out[:, 0:3] = fr
    out[:, 3:6] = d.reshape(-1, 3)
    out[:, 6] = 0
    out[:, 7] = np.inf
    return out


def write_rays(path, rays: np.ndarray) -> None:
    np.ascontiguousarray(rays, dtype="<f4").tofile(path)


def read_hits(path):
    """Arrays t (inf on a miss), mesh, prim (-1 on a miss), u, v (texture coordinates)."""
    t, mesh, prim, u, v = [], [], [], [], []
    with open(path) as f:
        head = f.readline().strip()
        if head != "t,mesh,prim,u,v":
            raise ValueError(f"{path}: unexpected header {head!r}")
        for line in f:
            a = line.rstrip("\n").split(",")
            tt = float(a[0])
            t.append(tt)
            if math.isinf(tt):
                mesh.append(-1), prim.append(-1), u.append(0.0), v.append(0.0)
            else:
                mesh.append(int(a[1])), prim.append(int(a[2])), u.append(float(a[3])), v.append(float(a[4]))
    return {"t": np.array(t), "mesh": np.array(mesh), "prim": np.array(prim), "u": np.array(u), "v": np.array(v)}


def compare(ref: dict, got: dict, rays: np.ndarray | None = None) -> dict:
    """Hit/miss agreement and |Δt| of `got` against the oracle `ref`. |Δt| is in units of
    the ray parameter times |d| (world distance), when rays are given."""
    tr, tg = ref["t"], got["t"]
    if len(tr) != len(tg):
        raise ValueError("hit files of different lengths")
    hr, hg = np.isfinite(tr), np.isfinite(tg)
    both = hr & hg
    scale = np.linalg.norm(rays[:, 3:6].astype(np.float64), axis=1) if rays is not None else np.ones(len(tr))
    dt = np.abs(tr[both] - tg[both]) * scale[both]
    tol = REL_T * np.maximum(np.abs(tr[both]), 1e-3)
    bad_t = np.abs(tr[both] - tg[both]) > tol
    missed = int((hr & ~hg).sum())
    false_hits = int((~hr & hg).sum())
    return {
        "rays": int(len(tr)),
        "oracle_hits": int(hr.sum()),
        "missed_hits": missed,
        "false_hits": false_hits,
        "missed_fraction": missed / max(1, int(hr.sum())),
        "t_mismatches": int(bad_t.sum()),
        "mismatches": int(bad_t.sum()) + missed + false_hits,
        "mean_abs_dt": float(dt.mean()) if dt.size else 0.0,
        "max_abs_dt": float(dt.max()) if dt.size else 0.0,
        "p99_abs_dt": float(np.percentile(dt, 99)) if dt.size else 0.0,
    }


def random_hemisphere(n: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Uniform random directions in the hemispheres around the rows of n (unit)."""
    d = rng.normal(size=n.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    flip = (d * n).sum(axis=1) < 0
    d[flip] = -d[flip]
    return d


def spawned_rays(rays: np.ndarray, hits: dict, rng: np.random.Generator) -> np.ndarray:
    """Secondary rays from the oracle's hits of `rays`, as a path tracer spawns them but
    without the hit normal (not in the hits file): origin moved back along the incoming
    ray by 1e-4·max(1, |p|∞), direction uniform in the hemisphere facing the incoming ray."""
    ok = np.isfinite(hits["t"])
    o = rays[ok, 0:3].astype(np.float64)
    d = rays[ok, 3:6].astype(np.float64)
    p = o + hits["t"][ok][:, None] * d
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    eps = 1e-4 * np.maximum(1.0, np.abs(p).max(axis=1))
    origin = p - eps[:, None] * dn
    nd = random_hemisphere(-dn, rng)
    out = np.zeros((len(p), 8), np.float32)
    out[:, 0:3] = origin
    out[:, 3:6] = nd
    out[:, 6] = 0
    out[:, 7] = np.inf
    return out


def texel_world_size(rays: np.ndarray, hits: dict, w: int, h: int, texels: tuple) -> float:
    """World length of one texel near the camera hits: median over horizontally adjacent
    camera pixels hitting the same displaced mesh of |Δp| / |Δ(uv · map size · tiling)|
    (pairs on the same base triangle when there are enough of them; pairs across a uv
    seam are outliers that the median ignores)."""
    t = hits["t"][: w * h].reshape(h, w)
    o = rays[: w * h, 0:3].astype(np.float64).reshape(h, w, 3)
    d = rays[: w * h, 3:6].astype(np.float64).reshape(h, w, 3)
    p = o + np.where(np.isfinite(t), t, 0.0)[..., None] * d
    uv = np.stack([hits["u"][: w * h], hits["v"][: w * h]], -1).reshape(h, w, 2) * np.array(texels, float)
    prim = hits["prim"][: w * h].reshape(h, w)
    mesh = hits["mesh"][: w * h].reshape(h, w)
    ok = np.isfinite(t[:, :-1]) & np.isfinite(t[:, 1:]) & (mesh[:, :-1] == mesh[:, 1:])
    same = ok & (prim[:, :-1] == prim[:, 1:])
    if same.sum() >= 20:
        ok = same
    dp = np.linalg.norm(p[:, 1:] - p[:, :-1], axis=-1)[ok]
    duv = np.linalg.norm(uv[:, 1:] - uv[:, :-1], axis=-1)[ok]
    sel = duv > 0.25
    if sel.sum() < 5:
        sel = duv > 0
    if not sel.any():
        return float("nan")
    return float(np.median(dp[sel] / duv[sel]))
