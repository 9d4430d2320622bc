"""Shared fixtures of the Python module's tests (run by CTest `python`, which sets
PYTHONPATH to the module's folder, OBLONG_BINARY to the command line and
OBLONG_SOURCE_DIR to the source tree)."""
import json
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import oblong

SRC = Path(os.environ.get("OBLONG_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BINARY = os.environ.get("OBLONG_BINARY", str(SRC / "build" / "oblong"))


class Cli:
    """The command line, run on the same input as the module."""

    def __init__(self, binary):
        self.binary = binary

    def run(self, *args, cwd=None):
        return subprocess.run([self.binary, *map(str, args)], capture_output=True, text=True, cwd=cwd)

    def error(self, *args, cwd=None):
        """The one-line message of a run that must fail, without the "oblong: " prefix."""
        r = self.run(*args, cwd=cwd)
        assert r.returncode == 1, f"oblong {' '.join(map(str, args))}: exit {r.returncode}, {r.stderr}"
        lines = [line for line in r.stderr.splitlines() if not line.startswith("oblong: warning:")]
        assert len(lines) == 1, r.stderr
        assert lines[0].startswith("oblong: ")
        return lines[0][len("oblong: "):]


@pytest.fixture(scope="session")
def cli():
    assert Path(BINARY).exists(), f"{BINARY} missing (set OBLONG_BINARY)"
    return Cli(BINARY)


def write_rays(path, o, d, tmin, tmax):
    """A ray file as `oblong trace` reads it: CSV, or 8 float32 per ray for .bin."""
    n = len(o)
    tmin = np.broadcast_to(np.asarray(tmin, np.float32), (n,))
    tmax = np.broadcast_to(np.asarray(tmax, np.float32), (n,))
    rows = np.column_stack([np.asarray(o, np.float32), np.asarray(d, np.float32), tmin, tmax]).astype(np.float32)
    if str(path).endswith(".bin"):
        rows.astype("<f4").tofile(path)
        return
    with open(path, "w") as f:
        f.write("ox,oy,oz,dx,dy,dz,tmin,tmax\n")
        for r in rows:
            # %.9g round-trips a float32 exactly.
            f.write(",".join("%.9g" % x for x in r) + "\n")


def read_hits(path):
    """The hits file of `oblong trace` as arrays shaped like scene.trace's."""
    t, mesh, prim, uv = [], [], [], []
    with open(path) as f:
        assert f.readline().strip() == "t,mesh,prim,u,v"
        for line in f:
            v = line.strip().split(",")
            if v[1] == "":
                t.append(np.inf), mesh.append(-1), prim.append(-1), uv.append((0.0, 0.0))
            else:
                t.append(float(v[0])), mesh.append(int(v[1])), prim.append(int(v[2]))
                uv.append((float(v[3]), float(v[4])))
    return {"t": np.array(t, np.float32), "mesh": np.array(mesh, np.int32), "prim": np.array(prim, np.int32),
            "uv": np.array(uv, np.float32).reshape(-1, 2)}


def rays_toward(center, radius, n, seed, spread=1.0):
    """n rays from a sphere of `radius` around `center` toward points near it: most hit a
    scene of about unit size there, some miss."""
    rng = np.random.default_rng(seed)
    center = np.asarray(center, np.float64)
    o = rng.normal(size=(n, 3))
    o = center + radius * o / np.linalg.norm(o, axis=1, keepdims=True)
    target = center + rng.uniform(-spread, spread, size=(n, 3))
    return o.astype(np.float32), (target - o).astype(np.float32)


def plane_scene(map_path, **strategies):
    """A small displaced plane (8 base triangles) with a camera, as a scene dict."""
    s = {
        "image": {"width": 32, "height": 24},
        "camera": {"from": [0.0, 1.2, 1.6], "to": [0.0, 0.0, 0.0], "up": [0, 1, 0], "fov": 45},
        "lights": [{"type": "directional", "direction": [-0.5, -0.7, -0.4], "intensity": 3.0}],
        "meshes": [{"shape": {"type": "plane", "size": 2, "segments": 2},
                    "displacement": {"map": map_path, "scale": 0.05, "bias": -0.5, "tiling": 2}}],
    }
    if strategies:
        s["strategies"] = strategies
    return s


def write_json(path, obj):
    Path(path).write_text(json.dumps(obj, indent=1))
    return path


# The module's keywords, each the command line's flag of the same name (`max_depth` is
# `--max-depth`).
KEYWORDS = {"range", "inverter", "splitter", "baseline", "marching_scale", "inversion_in_traversal", "step", "lod",
            "lod_bias", "size", "spp", "integrator", "max_depth", "normals", "seed", "threads", "device",
            "displacement", "scale", "bias", "tiling"}


def as_python(msg):
    """The command line's message as the module says it: `--spp: ...` is `spp: ...`, and a
    flag inside the text its keyword (`--baseline fixedstep` is `baseline='fixedstep'`)."""
    def kw(flag):
        k = flag.replace("-", "_")
        assert k in KEYWORDS, flag
        return k

    msg = re.sub(r"^--([a-z-]+):", lambda m: kw(m[1]) + ":", msg)
    values = "|".join(["cone", "off", "cpu", "vulkan", *oblong.range_queries(), *oblong.inverters(),
                       *oblong.splitters(), *oblong.baselines()])
    msg = re.sub(rf"--([a-z-]+) ({values})\b", lambda m: f"{kw(m[1])}='{m[2]}'", msg)
    msg = re.sub(r"(?<![\w/.'\"-])--([a-z-]+)", lambda m: kw(m[1]) + "=", msg)
    assert "--" not in msg, msg
    return msg
