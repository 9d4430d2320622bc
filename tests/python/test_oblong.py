"""The Python module against the command line: the same hits, images, info and errors on
the same input, and the arrays docs/python.md documents."""
import json
import threading
import time

import numpy as np
import pytest

import oblong
from conftest import SRC, as_python, plane_scene, rays_toward, read_hits, write_json, write_rays

COBBLES = str(SRC / "scenes" / "maps" / "cobbles_256.png")
SPHERE = str(SRC / "scenes" / "sphere.json")
COUNTERS = ["boxes", "range_queries", "inversions", "cells_marched", "micro_triangles", "prisms", "steps"]


@pytest.fixture(scope="module")
def default_scene():
    return oblong.load()


@pytest.fixture(scope="module")
def sphere():
    return oblong.load(SPHERE)


def cli_trace(cli, tmp_path, scene_args, o, d, tmin, tmax, flags=(), ext=".csv"):
    rays, hits, stats = tmp_path / ("rays" + ext), tmp_path / "hits.csv", tmp_path / "stats.json"
    write_rays(rays, o, d, tmin, tmax)
    r = cli.run("trace", *scene_args, "--rays", rays, "-o", hits, "--stats", stats, *flags)
    assert r.returncode == 0, r.stderr
    return read_hits(hits), json.loads(stats.read_text())


def flags_of(kw):
    """scene.trace's keywords as the command line's flags."""
    out = []
    for k, v in kw.items():
        out += ["--" + k.replace("_", "-"), str(v).lower() if isinstance(v, bool) else str(v)]
    return out


def assert_same_hits(got, want):
    np.testing.assert_array_equal(got["mesh"], want["mesh"])
    np.testing.assert_array_equal(got["prim"], want["prim"])
    np.testing.assert_array_equal(got["t"], want["t"])  # bit for bit, inf for the misses
    np.testing.assert_array_equal(got["uv"], want["uv"])


# The strategies by name, one ablation axis each, and baselines; threads as --threads.
CONFIGS = [
    {},
    {"range": "minmax_mipmap", "splitter": "quadtree", "marching_scale": 1, "inversion_in_traversal": False},
    {"range": "safety_zones", "inverter": "cubic", "splitter": "midpoint3d"},
    {"baseline": "tfdm"},
    {"baseline": "tessellated", "threads": 1},
]


@pytest.mark.parametrize("kw", CONFIGS, ids=lambda kw: "+".join(f"{k}={v}" for k, v in kw.items()) or "default")
def test_trace_same_hits_as_cli(cli, tmp_path, sphere, kw):
    o, d = rays_toward([0, 0, 0], 3.0, 1500, seed=7, spread=1.2)
    tmax = np.where(np.arange(len(o)) % 5 == 0, 2.5, np.inf).astype(np.float32)  # some cut short
    want, stats = cli_trace(cli, tmp_path, [SPHERE], o, d, 0.0, tmax, flags_of(kw))
    got = sphere.trace(o, d, 0.0, tmax, **kw)
    assert 0 < np.count_nonzero(got["mesh"] >= 0) < len(o)  # hits and misses both
    assert_same_hits(got, want)
    # The per-ray counters add up to the command line's --stats totals.
    for name in COUNTERS:
        assert int(got[name].sum()) == stats["ray_counters"][name], name
    assert got["stats"]["ray_counters"] == stats["ray_counters"]
    assert got["stats"]["geometry"] == stats["geometry"]
    assert got["stats"]["config"] == stats["config"]


def test_trace_default_scene_bin_rays(cli, tmp_path, default_scene):
    # The built-in scene (no scene argument), rays from a .bin file, per-ray tmin.
    o, d = rays_toward([0, 0, 0], 4.0, 1000, seed=3, spread=1.5)
    tmin = np.linspace(0.0, 0.5, len(o), dtype=np.float32)
    want, _ = cli_trace(cli, tmp_path, [], o, d, tmin, np.inf, ["--threads", "2"], ext=".bin")
    got = default_scene.trace(o.astype(np.float64), d, tmin, np.inf, threads=2)
    assert np.count_nonzero(got["mesh"] == 1) > 0 and np.count_nonzero(got["mesh"] == 0) > 0
    assert_same_hits(got, want)
    assert got["stats"]["threads"]["requested"] == 2 and 1 <= got["stats"]["threads"]["used"] <= 2


def test_load_dict_same_as_load(cli, tmp_path):
    d = plane_scene(COBBLES)
    path = write_json(tmp_path / "plane.json", d)
    a, b = oblong.load(str(path)), oblong.load_dict(d, path=str(path))
    assert a.path == b.path == str(path)
    o, dirs = rays_toward([0, 0, 0], 2.0, 800, seed=11, spread=0.9)
    ha, hb = a.trace(o, dirs), b.trace(o, dirs)
    assert np.count_nonzero(ha["mesh"] == 0) > 100
    assert_same_hits(hb, ha)
    for name in COUNTERS:
        np.testing.assert_array_equal(hb[name], ha[name])
    # ... and both are the command line's.
    want, _ = cli_trace(cli, tmp_path, [path], o, dirs, 0.0, np.inf)
    assert_same_hits(ha, want)
    # Relative paths are relative to `path`'s folder, as in a file.
    rel = plane_scene("cobbles_256.png")
    c = oblong.load_dict(rel, path=str(SRC / "scenes" / "maps" / "in_maps.json"))
    assert_same_hits(c.trace(o, dirs), ha)


def test_render_same_image_as_cli(cli, tmp_path, sphere):
    out = tmp_path / "img.pfm"
    r = cli.run("render", SPHERE, "-o", out, "--size", "24x16", "--spp", "2", "--integrator", "path", "--seed", "5",
                "--threads", "1", "-q")
    assert r.returncode == 0, r.stderr
    raw = out.read_bytes()
    head = raw.split(b"\n", 3)
    assert head[0] == b"PF" and head[1] == b"24 16"
    pfm = np.frombuffer(head[3], "<f4").reshape(16, 24, 3)[::-1]  # PFM rows run bottom to top
    img = sphere.render(size=(24, 16), spp=2, integrator="path", seed=5, threads=1)
    np.testing.assert_array_equal(img["color"], pfm)
    assert img["stats"]["steps_per_camera_ray"] == pytest.approx(float(img["steps"].mean()), rel=1e-6)
    assert img["stats"]["image"]["width"] == 24 and img["stats"]["spp"] == 2


def test_render_arrays(default_scene):
    r = default_scene.render(size="20x12", spp=1, integrator="primary", range="minmax_mipmap")
    assert set(r) == {"color", "depth", "normal", "steps", "range_queries", "inversions", "cells_marched", "stats"}
    for name, shape in [("color", (12, 20, 3)), ("normal", (12, 20, 3)), ("depth", (12, 20))]:
        assert r[name].shape == shape and r[name].dtype == np.float32, name
    for name in ["steps", "range_queries", "inversions", "cells_marched"]:
        assert r[name].shape == (12, 20) and r[name].dtype == np.float32, name
    hit = np.isfinite(r["depth"])
    assert hit.any() and (~hit).any()
    assert np.all(r["normal"][~hit] == 0) and np.allclose(np.linalg.norm(r["normal"][hit], axis=1), 1, atol=1e-4)
    assert r["steps"][hit].sum() > 0 and r["range_queries"].sum() > 0
    assert r["stats"]["config"]["range"]["name"] == "minmax_mipmap"
    # Without a size: the scene's image block.
    assert oblong.load_dict(plane_scene(COBBLES)).render(integrator="primary")["color"].shape == (24, 32, 3)


def test_trace_arrays(default_scene):
    o = np.array([[0, 0.5, 4], [0, 0.5, 4], [0, 10, 0]], np.float32)
    d = np.array([[0, -0.1, -1], [0, 1, 0], [0, 1, 0]], np.float32)
    r = default_scene.trace(o, d, 0.0, [np.inf, np.inf, 1.0])
    for name, dtype, shape in [("t", np.float32, (3,)), ("mesh", np.int32, (3,)), ("prim", np.int32, (3,)),
                               ("uv", np.float32, (3, 2))] + [(c, np.int64, (3,)) for c in COUNTERS]:
        assert r[name].dtype == dtype and r[name].shape == shape, name
    assert r["mesh"][0] >= 0 and np.isfinite(r["t"][0])
    assert r["mesh"][1] == -1 and r["prim"][1] == -1 and r["t"][1] == np.inf and np.all(r["uv"][1] == 0)
    np.testing.assert_array_equal(r["steps"], r["boxes"] + r["cells_marched"])
    empty = default_scene.trace(np.zeros((0, 3)), np.zeros((0, 3)))
    assert empty["t"].shape == (0,) and empty["uv"].shape == (0, 2)


def test_info_same_as_cli(cli, sphere):
    r = cli.run("info", SPHERE, "--range", "safety_zones")
    assert r.returncode == 0, r.stderr
    text = sphere.info(range="safety_zones", text=True)
    strip = lambda s: [line for line in s.splitlines() if not line.startswith("  peak ")]
    assert strip(text) == strip(r.stdout)
    info = sphere.info(range="safety_zones")
    m = info["meshes"][0]
    assert info["scene"] == SPHERE and info["displaced_meshes"] == 1
    assert m["triangles"] == 3968 and m["traversal"]["range"]["name"] == "safety_zones"
    assert m["prisms"]["built"] == 3968 and m["memory_total"] == info["total_bytes"]


def test_registries_as_cli(cli):
    r = cli.run("info", "--strategies", "--json")
    j = json.loads(r.stdout)
    assert oblong.range_queries() == [e["name"] for e in j["range"]]
    assert oblong.inverters() == [e["name"] for e in j["inverter"]]
    assert oblong.splitters() == [e["name"] for e in j["splitter"]]
    assert oblong.baselines() == [e["name"] for e in j["baselines"]]
    assert oblong.strategies() == j
    assert "rmip" in oblong.range_queries() and "ceres" in oblong.inverters() and "tfdm" in oblong.baselines()


def test_scene_errors_as_cli(cli, tmp_path):
    cases = {
        "missing.json": None,
        "malformed.json": '{"meshes": [',
        "unknown_key.json": json.dumps(dict(plane_scene(COBBLES), colour=1)),
        "bad_strategy.json": json.dumps(plane_scene(COBBLES, range={"name": "nosuch"})),
        "bad_value.json": json.dumps(plane_scene(COBBLES.replace("cobbles", "nothing"))),
    }
    for name, text in cases.items():
        path = tmp_path / name
        if text is not None:
            path.write_text(text)
        # `oblong info` loads the scene and builds its strategies (an unknown name fails there).
        want = cli.error("info", path)
        with pytest.raises(oblong.Error) as e:
            oblong.load(str(path)).info()
        assert str(e.value) == want, name
        if text is not None and name != "malformed.json":
            with pytest.raises(oblong.Error) as e:
                oblong.load_dict(json.loads(text), path=str(path)).info()
            assert str(e.value) == want, name
    assert issubclass(oblong.Error, ValueError)
    with pytest.raises(oblong.Error, match=r"^scene: empty file name"):
        oblong.load("")
    with pytest.raises(oblong.Error, match=r"^<dict>: nested deeper than 64 levels$"):
        deep = {}
        for _ in range(100):
            deep = {"x": deep}
        oblong.load_dict({"meshes": [], "camera": deep})


def test_flag_errors_as_cli(cli, tmp_path):
    path = str(write_json(tmp_path / "plane.json", plane_scene(COBBLES)))  # quick to load and build
    scene = oblong.load(path)
    o, d = rays_toward([0, 0, 0], 3.0, 4, seed=1)
    rays = tmp_path / "rays.csv"
    write_rays(rays, o, d, 0.0, np.inf)
    trace = [("range", "nosuch"), ("inverter", "nosuch"), ("splitter", "nosuch"), ("marching_scale", 0),
             ("step", 1), ("lod", "x"), ("lod", "cone"), ("threads", -1), ("range", ""), ("device", "nosuch")]
    for k, v in trace:
        flag = "--" + k.replace("_", "-")
        want = cli.error("trace", path, "--rays", rays, "-o", tmp_path / "h.csv", flag, v)
        if k == "device":  # the command line's parser says it, with its prefix and hint
            want = want.replace("command line: ", "").replace(" (oblong --help lists the options)", "")
        with pytest.raises(oblong.Error) as e:
            scene.trace(o, d, **{k: v})
        assert str(e.value) == as_python(want), (k, v)
    render = [("spp", 0), ("size", "0x4"), ("size", "9000x9000"), ("integrator", "foo"), ("normals", "foo"),
              ("seed", -1), ("max_depth", 0), ("threads", -2), ("lod_bias", 1)]
    for k, v in render:
        flag = "--" + k.replace("_", "-")
        want = cli.error("render", path, "-o", tmp_path / "x.png", flag, v)
        with pytest.raises(oblong.Error) as e:
            scene.render(**{k: v})
        assert str(e.value) == as_python(want), (k, v)


def test_ray_errors_as_cli(cli, tmp_path, sphere):
    o, d = rays_toward([0, 0, 0], 3.0, 3, seed=2)
    bad = [("zero direction", 1, lambda o, d, t0, t1: d.__setitem__(1, 0)),
           ("nan origin", 2, lambda o, d, t0, t1: o.__setitem__((2, 0), np.nan)),
           ("tmin > tmax", 0, lambda o, d, t0, t1: (t0.__setitem__(0, 2.0), t1.__setitem__(0, 1.0))),
           ("negative tmin", 1, lambda o, d, t0, t1: t0.__setitem__(1, -1.0))]
    for what, i, spoil in bad:
        oo, dd, t0, t1 = o.copy(), d.copy(), np.zeros(3, np.float32), np.full(3, np.inf, np.float32)
        spoil(oo, dd, t0, t1)
        rays = tmp_path / "bad.bin"
        write_rays(rays, oo, dd, t0, t1)
        want = cli.error("trace", SPHERE, "--rays", rays, "-o", tmp_path / "h.csv")
        assert want.startswith(f"{rays}: ray {i}: ")
        with pytest.raises(oblong.Error) as e:
            sphere.trace(oo, dd, t0, t1)
        assert str(e.value) == want[len(f"{rays}: "):], what


def test_vulkan_same_hits_as_cpu():
    # device= is the command line's --device: the Vulkan path finds the CPU's hits.
    scene = oblong.load_dict(plane_scene(COBBLES))
    o, d = rays_toward([0, 0, 0], 2.0, 400, seed=4, spread=0.9)
    cpu = scene.trace(o, d)
    try:
        gpu = scene.trace(o, d, device="vulkan")
    except oblong.Error as e:
        if "no Vulkan" in str(e) or "built without Vulkan" in str(e):
            pytest.skip(str(e))
        raise
    assert np.count_nonzero(cpu["mesh"] == 0) > 100
    assert_same_hits(gpu, cpu)
    assert gpu["stats"]["device"]["api"] == "vulkan"


def test_array_shape_errors(sphere):
    o = np.zeros((5, 3))
    with pytest.raises(oblong.Error) as e:
        sphere.trace(np.zeros((5, 2)), o)
    assert str(e.value) == "origins: expected an array of shape (n, 3), got shape (5, 2)"
    with pytest.raises(oblong.Error) as e:
        sphere.trace(o, np.zeros(3))
    assert str(e.value) == "directions: expected an array of shape (n, 3), got shape (3,)"
    with pytest.raises(oblong.Error) as e:
        sphere.trace(o, np.ones((4, 3)))
    assert str(e.value) == "directions: 4 directions for 5 origins"
    with pytest.raises(oblong.Error) as e:
        sphere.trace(o, np.ones((5, 3)), tmax=np.ones(4))
    assert str(e.value) == "tmax: expected a number or an array of shape (5,), got 1 dimension(s) of 4 value(s)"
    with pytest.raises(oblong.Error) as e:
        sphere.trace([["a", "b", "c"]], np.ones((1, 3)))
    assert str(e.value) == "origins: expected an array of shape (n, 3) of numbers"


def test_gil_released_while_rendering(default_scene):
    # Another Python thread runs while a render is in flight: the main thread's loop
    # never stalls for the render's length, as it would if the GIL were held.
    done, out = threading.Event(), {}

    def work():
        start = time.perf_counter()
        default_scene.render(size=(200, 150), spp=4, integrator="path", threads=1)
        out["seconds"] = time.perf_counter() - start
        done.set()

    t = threading.Thread(target=work)
    ticks = []
    t.start()
    while not done.is_set():
        ticks.append(time.perf_counter())
        time.sleep(0.002)
    t.join()
    gaps = np.diff(ticks)
    assert out["seconds"] > 0.3, "the render is too short to tell"
    assert len(ticks) > 20 and gaps.max() < 0.5 * out["seconds"], (len(ticks), gaps.max(), out["seconds"])


def test_load_mesh_file_as_cli(cli, tmp_path):
    # A mesh file is a scene too (docs/assets.md): its MTL's disp, as the command line reads it.
    (tmp_path / "quad.mtl").write_text(f"newmtl m\nKd 0.5 0.6 0.7\ndisp -mm -0.05 0.1 -s 2 2 {COBBLES}\n")
    (tmp_path / "quad.obj").write_text(
        "mtllib quad.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
        "usemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")
    path = tmp_path / "quad.obj"
    scene = oblong.load(str(path))
    o, dirs = rays_toward([0, 0, 0], 2.0, 400, seed=5, spread=0.8)
    got = scene.trace(o, dirs)
    assert np.count_nonzero(got["mesh"] == 0) > 50
    want, _ = cli_trace(cli, tmp_path, [path], o, dirs, 0.0, np.inf)
    assert_same_hits(got, want)
    # A bad material is the command line's one line.
    (tmp_path / "quad.mtl").write_text("newmtl m\ndisp -mm 0.1 missing.png\n")
    msg = cli.error("info", path)
    with pytest.raises(oblong.Error) as e:
        oblong.load(str(path))
    assert str(e.value) == msg
    assert "quad.mtl: line 2: disp: -mm needs two numbers" in msg
    # The mesh flags as keywords: the command line's --displacement, --scale, --bias, --tiling.
    bare = tmp_path / "bare.obj"
    bare.write_text(path.read_text().replace("mtllib quad.mtl\n", "").replace("usemtl m\n", ""))
    flags = dict(displacement=COBBLES, scale=0.1, bias=-0.5, tiling=(2, 1.5))
    got = oblong.load(str(bare), **flags).trace(o, dirs)
    assert np.count_nonzero(got["mesh"] == 0) > 50
    want, _ = cli_trace(cli, tmp_path, [bare], o, dirs, 0.0, np.inf,
                        ["--displacement", COBBLES, "--scale", "0.1", "--bias", "-0.5", "--tiling", "2,1.5"])
    assert_same_hits(got, want)
    with pytest.raises(oblong.Error, match=r"^scale: applies to a mesh file"):
        oblong.load(None, scale=2)
