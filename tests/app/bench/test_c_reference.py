"""The plain C reference of the CPU stage (app/bench/c_reference/hybrid_ref.c) against ours:
on small random frames of point lights (random cameras, the camera inside lights, lights
across the near plane, lights at identical depths, odd screens, 1 to 16 slices, several
leaf sizes and tree sizes) every output of the C build equals our numba build's bit for
bit; a scene with other lights, other techniques and options it does not do are refused in
one line; `bench cpu --c-reference` prints its comparison.  No skip: without a C compiler
these tests fail, saying so (scripts/setup.sh installs gcc)."""
from __future__ import annotations

import json

import numba
import numpy as np
import pytest

from app import bench
from app.bench import c_reference as cref
from app.bench.c_reference import compare as ccompare
from app.pipeline.passes import FrameInput
from app.results import CPU_STAGES
from app.techniques import REGISTRY
from cpu_prep import frame as cpuframe, grid as gridmod, hybrid as hybridmod, lights as lightsmod
from cpu_prep.arena import Arena
from cpu_prep.camera import frame_camera
from scenes.model import LIGHT_SPOT, Camera
from tests.helpers import options, random_lights

CELL_TREE_BIT = np.uint32(1 << 31)


@pytest.fixture(scope="module")
def ref():
    try:
        r = cref.CReference()
    except cref.CReferenceError as exc:
        pytest.fail(f"the C reference cannot be built here (it needs `cc`: scripts/setup.sh "
                    f"installs gcc): {exc}")
    yield r
    r.close()


def same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.names:
        a, b = a.view(np.uint8), b.view(np.uint8)
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


def point_frame(seed: int, n: int, size, kind: str):
    """n point lights and a camera: `spread` in a 60 m box, the camera among them (inside
    some of the larger ones); `near` many small lights a few metres around the eye with a
    far near plane (crossing it, behind it, containing the eye); `ties` a third of the
    lights at another third's positions and radii (identical depths: the sort's stability);
    `crowd` every light in view of an eye at the origin looking down -z (on a 1x1 screen one
    cell holds them all, more than a leaf's 16-bit count)."""
    rng = np.random.default_rng(seed)
    if kind == "crowd":
        lights = random_lights(rng, n, (-2, -2, -60), (2, 2, -10), radius=(0.05, 1.0), spot_share=0.0)
        cam = Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 60.0, 0.1, 200.0)
        return lights, frame_camera(cam, *size)
    if kind == "near":
        pos = rng.uniform(-5, 5, 3)
        lights = random_lights(rng, n, pos - 4.0, pos + 4.0, radius=(0.05, 3.0), spot_share=0.0)
        near = float(rng.choice([0.25, 1.0, 2.0]))
    else:
        lights = random_lights(rng, n, (-30, -5, -30), (30, 25, 30), radius=(0.05, 8.0), spot_share=0.0)
        pos = rng.uniform((-25, 0, -25), (25, 20, 25))
        near = float(rng.choice([0.05, 0.25, 1.0]))
    if kind == "ties":
        k = n // 3
        lights["position"][:k] = lights["position"][k:2 * k]
        lights["radius"][:k] = lights["radius"][k:2 * k]
    if n and rng.random() < 0.5:                 # the eye inside a light
        lights["position"][n // 2] = pos
        lights["radius"][n // 2] = 6.0
    target = pos + rng.normal(size=3)
    cam = Camera(tuple(pos), tuple(target), (0.0, 1.0, 0.0), float(rng.uniform(20, 120)),
                 near, float(rng.choice([40.0, 200.0])))
    return lights, frame_camera(cam, *size)


def ours(lights, cam, tile, slices, max_depth, per_leaf, max_leaves, radius_scale):
    """Our numba stage's outputs, step by step as the hybrid technique runs it."""
    keyed, depth = lightsmod.cull(lights, cam)
    sorted_ = lightsmod.sort_ids(keyed.copy(), depth).copy()
    pl = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())
    grid = gridmod.make_grid(cam, tile, slices, max_depth, 5.0)
    offsets, entries, _ = gridmod.bin_rects(grid, pl.rect, pl.depth_lo, pl.depth_hi)
    ranges, nodes, _, is_tree = hybridmod.plan_and_build(
        grid, offsets, entries, pl.depth_lo, pl.depth_hi, max_depth, radius_scale, per_leaf,
        max_leaves)
    ranges = ranges.copy()
    ranges["offset_count"][:, 1] |= is_tree.astype(np.uint32) * CELL_TREE_BIT
    return dict(sorted=sorted_, ids=pl.ids, gpu=pl.gpu, rect=pl.rect, depth_lo=pl.depth_lo,
                depth_hi=pl.depth_hi, offsets=offsets, entries=entries, ranges=ranges,
                nodes=nodes, is_tree=is_tree)


CASES = [  # seed, lights, size, kind, tile, slices, lights_per_leaf, max_leaves, radius_scale
    (1, 300, (320, 180), "spread", 48, 16, 6, 64, 1.0),
    (2, 2500, (320, 180), "spread", 16, 16, 1, 64, 1.0),
    (3, 1200, (97, 61), "near", 8, 4, 3, 8, 0.5),
    (4, 800, (320, 180), "ties", 48, 1, 2, 16, 1.0),
    (5, 3000, (1, 1), "spread", 48, 16, 6, 64, 4.0),
    (6, 1500, (333, 127), "near", 37, 16, 16, 4, 2.0),
    (7, 2000, (320, 180), "ties", 16, 16, 6, 1, 1.0),
    (8, 600, (97, 61), "near", 16, 1, 1, 2, 1.0),
    (9, 0, (320, 180), "spread", 48, 16, 6, 64, 1.0),
    (10, 1000, (640, 360), "ties", 24, 16, 4, 32, 1e3),
    (11, 70000, (1, 1), "crowd", 48, 1, 6, 1, 1e-3),      # a list of two leaves (16-bit count)
    (12, 70000, (1, 1), "crowd", 48, 1, 6, 1, 1e3),       # a tree of max_leaves 1: two leaves
]


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"seed{c[0]}-{c[1]}-{c[3]}")
def test_every_output_equals_ours_bit_for_bit(ref, case):
    seed, n, size, kind, tile, slices, per_leaf, max_leaves, scale = case
    lights, cam = point_frame(seed, n, size, kind)
    want = ours(lights, cam, tile, slices, 150.0, per_leaf, max_leaves, scale)
    for _ in range(2):                       # the second frame reuses the C side's buffers
        got = ref.frame(lights, cam, tile, slices, 5.0, 150.0, per_leaf, max_leaves, scale)
        for k, v in want.items():
            assert same(getattr(got, k), v), k
        # each step timed (CLOCK_MONOTONIC, ns): finite, and the frame took time
        assert set(got.ms) == set(cref.STEPS) and all(0 <= v < 6e4 for v in got.ms.values())
        assert got.total_ms > 0, got.ms
    if kind == "near":                       # the frames hold the hard cases they are for
        cz, r = ours_spheres(lights, cam)
        assert np.any((-cz - r < cam.near) & (-cz + r > cam.near))
    if kind == "crowd":                      # the one cell's leaves split the 16-bit count
        assert len(want["ids"]) > 65535 and len(want["nodes"]) == 3
    if kind == "ties" and n:
        assert len(np.unique(want["sorted"] >> np.uint64(32))) < len(want["sorted"])
    # clustered: the same stage without plan and trees, list ranges
    got = ref.frame(lights, cam, tile, slices, 5.0, 150.0, hybrid=False)
    for k in ("sorted", "gpu", "rect", "depth_lo", "depth_hi", "offsets", "entries"):
        assert same(getattr(got, k), want[k]), k
    rng = got.ranges["offset_count"]
    assert np.array_equal(rng[:, 0], want["offsets"][:-1]) and np.array_equal(rng[:, 1], np.diff(want["offsets"]))
    assert len(got.nodes) == 0 and not got.is_tree.any()


def ours_spheres(lights, cam):
    """(depth, radius) of each visible light's culling sphere, from our pack."""
    pl = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())
    return pl.center[:, 2], pl.bound_radius


@pytest.mark.parametrize("name", ["hybrid", "clustered"])
def test_equals_the_technique_build(ref, name):
    """Against the technique's own build (the buffers the GPU gets), with its options."""
    lights, cam = point_frame(11, 1500, (320, 180), "spread")
    opts = REGISTRY[name].resolve_options(options(name, tile=16, slices=16, lights_per_leaf=4,
                                                  max_leaves=16, radius_scale=2.0))
    b = REGISTRY[name].build(FrameInput(lights, cam, 150.0, Arena()), opts)
    kw = dict(lights_per_leaf=4, max_leaves=16, radius_scale=2.0) if name == "hybrid" else {}
    got = ref.frame(lights, cam, 16, 16, opts.near_slice_depth, 150.0, hybrid=name == "hybrid", **kw)
    assert same(got.gpu, b.buffers["lights"]) and same(got.entries, b.buffers["entries"])
    assert same(got.ranges, b.buffers["ranges"])
    if name == "hybrid":
        assert same(got.nodes, b.buffers["nodes"]) and int(got.is_tree.sum()) > 0
    assert not ccompare.differences(got, b, name == "hybrid")


def test_other_lights_are_refused(ref):
    lights, cam = point_frame(12, 200, (320, 180), "spread")
    lights["type"][7] = LIGHT_SPOT
    with pytest.raises(cref.CReferenceError, match="point lights only.*1 others \\(spot\\)"):
        ref.frame(lights, cam, 48, 16, 5.0, 150.0)


@pytest.mark.parametrize("argv, word", [
    (["--scene", "gallery"], "point lights only"),
    (["--technique", "tree"], "hybrid and clustered"),
    (["--threads", "0"], "single-threaded"),
    (["--sort-buckets", "64"], "--sort-buckets"),
    (["--sweep", "64,128"], "one light count"),
    (["--scene", "hangar", "--lights", "65536", "--size", "1920x1080"], "storage-block limit"),
])
def test_cli_refusals_are_one_line(ref, capsys, argv, word):
    from app.cli import run_main
    base = ["cpu", "--c-reference", "--lights", "64", "--size", "64x48", "--repeat", "1"]
    if "--scene" not in argv:
        base += ["--scene", "arena"]
    with pytest.raises(SystemExit) as e:
        run_main(lambda: bench.main(base + argv))
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and word in err[0], err


def test_cli_compares_both(ref, capsys):
    bench.main(["cpu", "--c-reference", "--scene", "arena", "--technique", "hybrid",
                "--lights", "1024", "--size", "320x180", "--tile", "48", "--slices", "16",
                "--repeat", "3", "--json"])
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1
    d = json.loads(out[0])
    assert d["identical"] and d["differ"] == [] and d["repeat"] == 3 and d["threads"] == 1
    assert list(d["rows"]) == ["cull", "sort + gather", "bin", "plan + build", "total"]
    t = d["rows"]["total"]
    assert t["c_min_ms"] > 0 and t["numba_min_ms"] > 0
    assert t["ratio_min"] == pytest.approx(t["numba_min_ms"] / t["c_min_ms"], rel=1e-2)
    bench.main(["cpu", "--c-reference", "--scene", "arena", "--lights", "1024", "--size",
                "320x180", "--repeat", "2", "--threads", "2", "--json"])
    d2 = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert d2["identical"] and d2["threads"] == min(2, numba.config.NUMBA_NUM_THREADS)
    assert set(d["c_steps"]) == set(cref.STEPS) and 0 < d["visible"] <= 1024
    assert set(d["numba_stages"]) == set(CPU_STAGES) and len(d["load"]["before"]) == 3
    bench.main(["cpu", "--c-reference", "--scene", "arena", "--technique", "clustered",
                "--lights", "512", "--size", "97x61", "--repeat", "2"])
    text = capsys.readouterr().out
    assert "identical: yes" in text and "plan + build" not in text and "ratio" in text


def test_rebuilt_when_the_source_changes(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    a = cref.library_path()
    src = tmp_path / "hybrid_ref.c"
    src.write_text(cref.SOURCE.read_text() + "\n/* changed */\n")
    monkeypatch.setattr(cref, "SOURCE", src)
    b = cref.library_path()
    assert a != b and a.exists() and b.exists() and a.parent == b.parent == tmp_path / "many-light-lab" / "c_reference"
    assert cref.library_path() == b                  # cached: not built again


def test_no_compiler_is_one_line(monkeypatch):
    monkeypatch.setenv("CC", "no-such-cc-here")
    with pytest.raises(cref.CReferenceError, match="C compiler.*no-such-cc-here.*gcc"):
        cref.compiler()
