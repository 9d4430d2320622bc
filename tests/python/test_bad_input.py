"""Bad input to the Python module (docs/bad_input.md, "The Python module"): never a crash,
a hang or unbounded memory; a wrong type or an unknown keyword is one line naming the
keyword; messages name keywords, not the command line's flags."""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import oblong
from conftest import SRC, as_python, plane_scene

COBBLES = str(SRC / "scenes" / "maps" / "cobbles_256.png")


def run_python(code, timeout=120, memory=None, env=None):
    """`code` in a fresh interpreter (the one running the tests, with the module on its
    path): a crash or a hang there is this test's failure, not the end of the run.
    memory: an address-space limit in bytes, so that a run that grows without bound
    fails at once."""
    def limit():
        if memory:
            import resource
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=timeout, preexec_fn=limit, env={**os.environ, **(env or {})})


@pytest.fixture(scope="module")
def plane():
    return oblong.load_dict(plane_scene(COBBLES))


def test_unloaded_scene_raises():
    # Scene.__new__ makes an instance no load filled in: every method and property of it
    # raises (they read a null scene and crashed with SIGSEGV).
    r = run_python("""
        import numpy as np, oblong
        calls = {"path": lambda s: s.path, "load_seconds": lambda s: s.load_seconds, "info": lambda s: s.info(),
                 "render": lambda s: s.render(size=(4, 4)),
                 "trace": lambda s: s.trace(np.zeros((1, 3)), np.ones((1, 3)))}
        for name, call in calls.items():
            try:
                call(oblong.Scene.__new__(oblong.Scene))
            except ValueError as e:
                print(name, "|", e, flush=True)
            else:
                print(name, "| no exception", flush=True)
    """, timeout=60)
    assert r.returncode == 0, (r.returncode, r.stdout, r.stderr)
    lines = r.stdout.splitlines()
    assert [line.split(" | ")[0] for line in lines] == ["path", "load_seconds", "info", "render", "trace"], r.stdout
    for line in lines:
        assert "Scene was not loaded" in line and "oblong.load" in line, line


@pytest.mark.parametrize("build,limit", [
    ("l = []; l.append(l); l.append(l); d = {'meshes': l}", "nested deeper than 64 levels"),
    ("d = {}; d['x'] = d", "nested deeper than 64 levels"),
    ("a = []\nfor _ in range(28): a = [a, a]\nd = {'meshes': a}", "more than 1048576 values"),
    ("d = {'meshes': [[0.5] * 1100 for _ in range(1000)]}", "more than 1048576 values"),
], ids=["self_list", "self_dict", "doubling_list", "wide"])
def test_load_dict_bounded(build, limit):
    # A list inside itself, or the same list twice taken 28 times over (2^29 values from
    # 28 small lists), is refused at once: it ran for minutes and grew to gigabytes.
    r = run_python(build + """
import time, oblong
start = time.perf_counter()
try:
    oblong.load_dict(d)
except oblong.Error as e:
    print(e)
print(time.perf_counter() - start)
""", timeout=60, memory=3 << 30)
    assert r.returncode == 0, (r.returncode, r.stdout, r.stderr[-2000:])
    message, seconds = r.stdout.splitlines()
    assert message.startswith("<dict>: ") and limit in message, message
    assert float(seconds) < 10


def test_load_dict_within_bounds(tmp_path):
    # The bounds leave every real scene alone: 64 levels and many values load.
    s = plane_scene(COBBLES)
    deep = {}
    for _ in range(60):
        deep = {"x": deep}
    with pytest.raises(oblong.Error, match="unknown key"):  # past the bounds, refused by the schema
        oblong.load_dict({**s, "extra": deep})
    s["lights"] = s["lights"] * 5000
    assert oblong.load_dict(s).path == "<dict>"


def test_trace_refuses_more_rays_than_memory(plane, monkeypatch):
    # Checked against the memory budget before the arrays are converted: a broadcast of
    # 1e6 rays is 48 bytes until it is copied.
    monkeypatch.setenv("OBLONG_MEMORY_LIMIT", "64M")
    o = np.broadcast_to(np.array([0.1, 2.0, 0.1]), (10**6, 3))
    d = np.broadcast_to(np.array([0.0, -1.0, 0.0]), (10**6, 3))
    with pytest.raises(oblong.Error) as e:
        plane.trace(o, d)
    msg = str(e.value)
    assert msg.startswith("origins: tracing 1000000 rays needs "), msg
    assert "that OBLONG_MEMORY_LIMIT allows" in msg and "rays fit" in msg, msg
    fit = int(msg.split("at most ")[1].split()[0])
    assert 10**4 < fit < 10**6
    # What fits is traced.
    assert (plane.trace(o[:1000], d[:1000])["mesh"] == 0).all()
    # A list is counted before it is converted, too.
    with pytest.raises(oblong.Error, match=r"^origins: tracing 1000000 rays"):
        plane.trace([[0.1, 2.0, 0.1]] * 10**6, d)


@pytest.mark.parametrize("n", [10**8, 10**9])
def test_trace_huge_broadcast_refused_at_once(n):
    # 1e8 broadcast rays reached 6.2 GB before a MemoryError; 1e9 said "expected an
    # array ... of numbers". Under a 4 GiB budget both are refused before any copy.
    r = run_python(f"""
        import numpy as np, oblong
        s = oblong.load()
        o = np.broadcast_to(np.array([0.0, 0.0, 5.0]), ({n}, 3))
        d = np.broadcast_to(np.array([0.0, 0.0, -1.0]), ({n}, 3))
        try:
            s.trace(o, d)
        except oblong.Error as e:
            print(e)
    """, timeout=120, memory=4 << 30, env={"OBLONG_MEMORY_LIMIT": "4G"})
    assert r.returncode == 0, (r.returncode, r.stdout, r.stderr[-2000:])
    assert r.stdout.startswith(f"origins: tracing {n} rays needs "), r.stdout
    assert "rays fit: trace them in batches" in r.stdout


WRONG_TYPES = [
    ("render", {"marching_scale": "4"}, "marching_scale: expected a number, got str '4'"),
    ("render", {"size": 8}, 'size: expected "WxH" or (width, height), got int 8'),
    ("render", {"size": (8.5, 4)}, "size: expected an integer, got float 8.5"),
    ("render", {"spp": 1.5}, "spp: expected an integer, got float 1.5"),
    ("render", {"spp": "4"}, "spp: expected an integer, got str '4'"),
    ("render", {"max_depth": None}, "max_depth: expected an integer, got NoneType None"),
    ("render", {"integrator": 3}, "integrator: expected a str, got int 3"),
    ("render", {"seed": 1.5}, "seed: expected an integer, got float 1.5"),
    ("render", {"lod_bias": "1"}, "lod_bias: expected a number, got str '1'"),
    ("trace", {"threads": "2"}, "threads: expected an integer, got str '2'"),
    ("trace", {"device": 0}, "device: expected a str, got int 0"),
    ("trace", {"range": 5}, "range: expected a str, got int 5"),
    ("trace", {"step": "1"}, "step: expected a number, got str '1'"),
    ("trace", {"inversion_in_traversal": 1}, "inversion_in_traversal: expected a bool, got int 1"),
    ("trace", {"lod": [1]}, "lod: expected \"off\", \"cone\" or a number, got list [1]"),
    ("info", {"text": "yes"}, "text: expected a bool, got str 'yes'"),
    ("load", {"tiling": "2"}, "tiling: expected a number or (tu, tv), got str '2'"),
    ("load", {"tiling": (2, "x")}, "tiling: expected a number, got str 'x'"),
    ("load", {"scale": "1"}, "scale: expected a number, got str '1'"),
    ("load", {"bias": [1]}, "bias: expected a number, got list [1]"),
    ("load", {"displacement": 5}, "displacement: expected a str or an os.PathLike, got int 5"),
    ("load", {"path": 5}, "path: expected a str or an os.PathLike, got int 5"),
    ("load_dict", {"d": [1]}, "d: expected a dict (a scene in the scene file's schema), got list [1]"),
    ("load_dict", {"path": 5}, "path: expected a str or an os.PathLike, got int 5"),
]


@pytest.mark.parametrize("call,kw,want", WRONG_TYPES, ids=[f"{c}-{next(iter(k))}" for c, k, _ in WRONG_TYPES])
def test_wrong_typed_keyword_named(plane, tmp_path, call, kw, want):
    # A TypeError naming the keyword and the type (it was "RuntimeError: Unable to cast
    # Python instance to C++ type", or pybind11's whole signature).
    o, d = np.zeros((2, 3)), np.ones((2, 3))
    calls = {"render": lambda: plane.render(**{"size": (4, 3), **kw}), "trace": lambda: plane.trace(o, d, **kw),
             "info": lambda: plane.info(**kw), "load": lambda: oblong.load(**{"path": str(tmp_path / "q.obj"), **kw}),
             "load_dict": lambda: oblong.load_dict(**{"d": plane_scene(COBBLES), **kw})}
    with pytest.raises(TypeError) as e:
        calls[call]()
    assert str(e.value) == want


def test_exception_of_float_goes_through(plane):
    # An exception raised by a value's own __float__ (or __index__) is the caller's: it
    # comes back as raised, not as a cast failure.
    class Bad:
        def __float__(self):
            raise KeyError("from __float__")

        def __index__(self):
            raise KeyError("from __index__")

    for call in [lambda: plane.render(size=(4, 3), marching_scale=Bad()),
                 lambda: plane.trace(np.zeros((2, 3)), np.ones((2, 3)), step=Bad(), baseline="fixedstep"),
                 lambda: plane.render(size=(4, 3), spp=Bad()),
                 lambda: oblong.load(None, scale=Bad()),
                 lambda: oblong.load_dict({**plane_scene(COBBLES), "image": {"width": Bad(), "height": 8}})]:
        with pytest.raises(KeyError, match="from __"):
            call()


def test_empty_displacement_refused_as_cli(cli, tmp_path):
    # displacement='' is the command line's `--displacement ''`: an empty value, not "none".
    (tmp_path / "q.obj").write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n")
    path = tmp_path / "q.obj"
    want = cli.error("info", path, "--displacement", "")
    with pytest.raises(oblong.Error) as e:
        oblong.load(str(path), displacement="")
    assert str(e.value) == as_python(want) == "displacement: empty value"


UNKNOWN = [
    ("render", lambda s, o, d: s.render(sppp=4), "Scene.render() got an unexpected keyword argument 'sppp' "
                                                 "(did you mean 'spp'?)"),
    ("trace", lambda s, o, d: s.trace(o, d, treads=1), "Scene.trace() got an unexpected keyword argument 'treads' "
                                                       "(did you mean 'threads'?)"),
    ("info", lambda s, o, d: s.info(rnage="rmip"), "Scene.info() got an unexpected keyword argument 'rnage' "
                                                   "(did you mean 'range'?)"),
    ("load", lambda s, o, d: oblong.load(None, scael=2), "load() got an unexpected keyword argument 'scael' "
                                                         "(did you mean 'scale'?)"),
    ("load_dict", lambda s, o, d: oblong.load_dict({}, color=1), "load_dict() got an unexpected keyword argument "
                                                                 "'color'"),
    ("render_positional", lambda s, o, d: s.render((4, 3)), "Scene.render() takes 0 positional arguments "
                                                            "(1 more given)"),
    ("trace_positional", lambda s, o, d: s.trace(o, d, 0, 1, 4), "Scene.trace() takes 4 positional arguments "
                                                                 "(1 more given)"),
]


@pytest.mark.parametrize("name,call,want", UNKNOWN, ids=[u[0] for u in UNKNOWN])
def test_unknown_keyword_one_line(plane, name, call, want):
    # One line naming the keyword and the accepted ones, not pybind11's signature dump.
    with pytest.raises(TypeError) as e:
        call(plane, np.zeros((2, 3)), np.ones((2, 3)))
    msg = str(e.value)
    assert msg.startswith(want), msg
    assert "\n" not in msg and "incompatible function arguments" not in msg and "Invoked with" not in msg
    assert len(msg) < 400


def test_messages_name_keywords_not_flags(plane):
    # The command line's messages, their flags named as keywords.
    cases = [(lambda: plane.render(spp=0), "spp: must be >= 1, got 0"),
             (lambda: plane.render(max_depth=0), "max_depth: must be >= 1, got 0"),
             (lambda: plane.render(size="0x4"), "size: expected positive sizes, got '0x4'"),
             (lambda: plane.render(lod_bias=1), "lod_bias: applies to lod='cone' only (a λ per ray)"),
             (lambda: plane.trace(np.zeros((1, 3)), np.ones((1, 3)), step=1),
              "step: only applies to baseline='fixedstep'"),
             (lambda: plane.trace(np.zeros((1, 3)), np.ones((1, 3)), threads=-1), "threads: must be >= 0, got -1"),
             (lambda: oblong.load(None, scale=2), "scale: applies to a mesh file")]
    for call, want in cases:
        with pytest.raises(oblong.Error) as e:
            call()
        assert str(e.value).startswith(want)
        assert "--" not in str(e.value)


def test_quoted_flag_kept(tmp_path):
    # Only the command line's flags are translated: a scene's own text stays as given.
    with pytest.raises(oblong.Error) as e:
        oblong.load_dict({**plane_scene(COBBLES), "--range": 1})
    assert "'--range'" in str(e.value)


def test_import_without_numpy_hints():
    # Another interpreter than Debian's /usr/bin/python3 (the one the module is built
    # for) has no numpy: the import says so and what to do.
    r = run_python("""
        import sys
        sys.modules["numpy"] = None  # `import numpy` fails, as where numpy is not installed
        try:
            import oblong
        except ImportError as e:
            print(e)
    """, timeout=60)
    assert r.returncode == 0, r.stderr
    msg = r.stdout
    assert "oblong needs numpy" in msg and "/usr/bin/python3" in msg and "install numpy" in msg, msg
    assert sys.executable in msg


@pytest.mark.parametrize("ext", [".bin", ".csv"])
def test_cli_trace_refuses_more_rays_than_memory(cli, tmp_path, ext):
    # `oblong trace` holds the rays, their hits and the hits file at once: more than the
    # budget is one line before the scene loads (4M rays under a 20M limit ran, 774 MB).
    scene = tmp_path / "plane.json"
    scene.write_text(__import__("json").dumps(plane_scene(COBBLES)))
    n = 100_000
    rays = tmp_path / ("rays" + ext)
    rows = np.tile(np.array([0.1, 2.0, 0.1, 0.0, -1.0, 0.0, 0.0, np.inf], np.float32), (n, 1))
    if ext == ".bin":
        rows.astype("<f4").tofile(rays)
    else:
        rays.write_text("ox,oy,oz,dx,dy,dz,tmin,tmax\n" + "0.1,2,0.1,0,-1,0,0,inf\n" * n)
    hits = tmp_path / "hits.csv"
    r = subprocess.run([cli.binary, "trace", scene, "--rays", rays, "-o", hits], capture_output=True, text=True,
                       env={**os.environ, "OBLONG_MEMORY_LIMIT": "8M"})
    assert r.returncode == 1, r.stderr
    assert r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith(f"oblong: {rays}: tracing {n} rays needs "), r.stderr
    assert "that OBLONG_MEMORY_LIMIT allows" in r.stderr and "rays fit: split the ray file" in r.stderr
    assert not hits.exists()
    # What fits is traced.
    fit = int(r.stderr.split("at most ")[1].split()[0])
    assert 1000 < fit < n
    small = tmp_path / ("small" + ext)
    if ext == ".bin":
        rows[:1000].astype("<f4").tofile(small)
    else:
        small.write_text("ox,oy,oz,dx,dy,dz,tmin,tmax\n" + "0.1,2,0.1,0,-1,0,0,inf\n" * 1000)
    r = subprocess.run([cli.binary, "trace", scene, "--rays", small, "-o", hits, "-q"], capture_output=True,
                       text=True, env={**os.environ, "OBLONG_MEMORY_LIMIT": "8M"})
    assert r.returncode == 0, r.stderr
    assert hits.exists()
