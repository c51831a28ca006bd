"""zbin (Drobot 2017): the memory table from the build's own buffers, the memory budget, the
four variants of the slides' optimization table exact against brute with either wave API,
their per-wave counters, dispatch windows, and the 32-bit LUT past 65,536 visible lights."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.pipeline.passes import FrameInput
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from app.techniques.base import windows
from app.techniques.zbin import VARIANTS, variant_flags
from cpu_prep import limits, zbin as zb
from cpu_prep.camera import frame_camera
from hypothesis import HealthCheck, given, settings, strategies as st
from scenes import BUILTIN_SCENES, load_scene
from scenes.model import Camera, make_lights
from tests.helpers import BUILTIN_LIGHTS, assert_exact, assume_lit, make_scene, options, random_lights

ROOT = Path(__file__).resolve().parents[3]
ZBIN = REGISTRY["zbin"]
SIZE = (96, 64)


def frame_1080p(n: int, seed: int = 0) -> FrameInput:
    """n small point lights, all inside the view of a 1920x1080 camera looking down -z."""
    cam = frame_camera(Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 60.0, 0.1, 500.0),
                       1920, 1080)
    rng = np.random.default_rng(seed)
    depth = rng.uniform(5.0, 200.0, n)
    L = make_lights(n)
    xy = rng.uniform(-0.8, 0.8, (n, 2)) * depth[:, None] * np.array([cam.tan_half_x, cam.tan_half_y])
    L["position"] = np.column_stack([xy, -depth])
    L["radius"] = rng.uniform(0.5, 3.0, n)
    return FrameInput(L, cam, 250.0)


def test_memory_table_from_the_build():
    """The slides' memory table (1080p, a 256-bit array): 240 x 135 tiles of 8 px,
    1,036,800 bytes of bit arrays, and 8096 z-bins in 32,384 bytes: the build's buffers."""
    b = ZBIN.build(frame_1080p(256), None)
    assert b.stats["visible_lights"] == 256
    assert b.buffers["tile_bits"].nbytes == 1_036_800
    assert b.buffers["zbins"].nbytes == 32_384
    assert b.stats["bit_tile_used"] == 8 and b.stats["tiles"] == 240 * 135
    assert b.stats["words_per_tile"] == 8 and b.stats["zbins"] == 8096
    assert b.stats["bits_bytes"] == 1_036_800 and b.stats["zbin_bytes"] == 32_384
    assert b.stats["zbin_id_bits"] == 16
    # the tile variants have no LUT (the table's "Tiled Buffer" row)
    for v in (0, 2):
        bt = ZBIN.build(frame_1080p(256), {"zbin_variant": v})
        assert "zbins" not in bt.buffers and bt.stats["zbin_bytes"] == 0
        assert bt.buffers["tile_bits"].nbytes == 1_036_800


def test_memory_budget_sets_the_tile_at_65536_lights():
    """65,536 lights at 1080p in 8 px tiles would take 265 MB: the budget doubles the tile."""
    fi = frame_1080p(65_536, seed=1)
    b = ZBIN.build(fi, None)
    assert b.stats["visible_lights"] == 65_536
    assert b.stats["bit_tile_used"] == 32 and b.stats["words_per_tile"] == 2048
    assert b.buffers["tile_bits"].nbytes == b.stats["bits_bytes"] <= 32 << 20
    assert b.stats["zbin_id_bits"] == 16                 # ids 0..65,535 still fit 16 bits
    small = ZBIN.build(fi, {"bit_budget_mib": 1.0})
    assert small.stats["bit_tile_used"] == 256 and small.buffers["tile_bits"].nbytes <= 1 << 20
    assert small.grid.tile == 256                        # the window's tile view draws it


@pytest.fixture(scope="module")
def hangar():
    scene = load_scene("hangar", lights=1500, seed=3)
    r = Renderer(scene, SIZE)
    yield r, r.render(REGISTRY["brute"])
    r.release()


def per_wave(a: np.ndarray, wave_shape, reduce) -> np.ndarray:
    """Per 8x8 group (image order) reduction of a per-pixel (image order) array."""
    gh, gw = wave_shape
    h, w = a.shape
    p = np.zeros((gh * 8, gw * 8), np.int64)
    p[:h, :w] = a[::-1]                  # GL row order, as the groups run
    return reduce(p.reshape(gh, 8, gw, 8), axis=(1, 3))[::-1]


@pytest.mark.parametrize("native", [False, True], ids=["emulated", "native"])
def test_every_variant_is_exact_and_counts_its_loops(gl, hangar, native):
    r, ref = hangar
    res = {}
    for v in range(4):
        # the base tile has no wave operation: it refuses --native-wave (options' rule)
        got = r.render(ZBIN, 0, options("zbin", zbin_variant=v, native_wave=native))
        assert_exact({"brute": ref, "zbin": got}, f"variant {VARIANTS[v]}")
        assert got.meta["stats"]["variant"] == VARIANTS[v]
        native_here = native and v != 0
        assert got.meta["wave"] == (f"native-{r.limits.native_wave}" if native_here else "emulated-64")
        res[v] = got
    shading = ref.depth > 0
    for v, got in res.items():
        masked, scalarized = variant_flags(v)
        wave, ev = got.wave, got.evaluated.astype(np.int64)
        lane = res[v & 1].evaluated.astype(np.int64)     # the per-lane loop of the same masks
        # lane_loops.x: the lanes' own iterations (the per-lane loop), lane_loops.y: the longest
        assert np.array_equal(wave["lane_loops"][..., 0], per_wave(lane, wave.shape, np.sum))
        assert np.array_equal(wave["lane_loops"][..., 1], per_wave(lane, wave.shape, np.max))
        # iterations: the wave's loop; the per-lane loop runs as long as its longest lane
        assert np.array_equal(wave["iterations"], per_wave(ev, wave.shape, np.max))
        assert (wave["iterations"] >= wave["lane_loops"][..., 1]).all()
        assert (ev[shading] >= lane[shading]).all() and (ev[~shading] == 0).all()
        if scalarized and not native:
            # one scalar loop per 64-lane wave: every shading lane runs all of it
            full = per_wave(np.where(shading, ev, -1), wave.shape, np.max)
            low = per_wave(np.where(shading, ev, 1 << 40), wave.shape, np.min)
            assert np.array_equal(full[full >= 0], low[full >= 0])
        s = got.meta["stats"]
        assert s["wave_iterations"] == int(wave["iterations"].sum())
        assert s["lane_iterations"] == int(lane.sum())
        assert s["lane_max_iterations"] == int(wave["lane_loops"][..., 1].sum())
    # z-bins only remove lights (the mask is exact: a subset of the tile's per pixel)
    assert (res[1].evaluated <= res[0].evaluated).all()
    assert res[1].evaluated.sum() < res[0].evaluated.sum()
    # the tile and the groups are both 8 px: a scalarized tile merges nothing new
    assert np.array_equal(res[2].evaluated, res[0].evaluated)


@pytest.mark.parametrize("distribution", ["uniform", "geometry"])
@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_every_variant_is_exact_on_builtin_scenes(gl, name, distribution):
    """test_exactness.py renders the default variant on every builtin scene; here all four
    (and the scalarized ones on the native wave too), at a smaller size."""
    scene = load_scene(name, lights=BUILTIN_LIGHTS, seed=1, distribution=distribution)
    with Renderer(scene, (96, 54)) as r:
        ref = r.render(REGISTRY["brute"])
        assert ref.contrib_count.sum() > 0
        for v in range(4):
            for native in (False, True) if variant_flags(v)[1] else (False,):
                got = r.render(ZBIN, 0, options("zbin", zbin_variant=v, native_wave=native))
                assert_exact({"brute": ref, "zbin": got}, f"{name}/{distribution} variant {v} native {native}")


@settings(max_examples=10, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31), n=st.integers(1, 600), fov=st.floats(20, 120),
       w=st.integers(1, 130), h=st.integers(1, 90), bit_tile=st.sampled_from([4, 5, 8, 16, 33]),
       zbins=st.sampled_from([1, 7, 8096, 65536]), near=st.sampled_from([0.01, 0.1, 1.0]),
       native=st.booleans(), printed=st.booleans())
def test_random_scenes_every_variant(gl, seed, n, fov, w, h, bit_tile, zbins, near, native, printed):
    rng = np.random.default_rng(seed)
    lights = random_lights(rng, n, (-25, -2, -45), (25, 10, 12), radius=(0.05, 12.0))
    cam = Camera((0.0, 2.0, 8.0), (rng.uniform(-3, 3), 1.0, -20.0), fov_y_deg=fov, near=near, far=300.0)
    scene = make_scene(lights, size=(w, h), camera=cam)
    with Renderer(scene) as r:
        res = {"brute": r.render(REGISTRY["brute"])}
        for v in range(4):
            res[f"zbin{v}"] = r.render(ZBIN, 0, options("zbin", zbin_variant=v, bit_tile=bit_tile,
                                                        zbins=zbins, native_wave=native,
                                                        printed_mask=printed))
        assert_exact(res, f"seed {seed}")
        assume_lit(res)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_lights_on_zbin_boundaries(gl, seed):
    """A wall whose pixels sit exactly on a z-bin boundary (max depth chosen so that
    depth * bins / max_depth is an integer, then swept a few float32 ulp either side), lights
    touching its pixels from in front and behind at r (1 +- a few ulp), and lights whose depth
    range ends exactly on it, small lights on its pixels: the z-bin variants exact, brute
    against the float64 reference."""
    from tests.app.techniques.hard_frames import (F32_EPS, Frame, axis_camera, concat,
                                                  lights_ending_on, scene_of, wall)
    rng = np.random.default_rng(seed)
    with Frame(scene_of([wall(13.7)], axis_camera(fov=60.0, near=0.1, far=1e4), size=(32, 24))) as f:
        L, b = lights_ending_on(rng, f, f.pos[..., 3] > 0)
        L = concat(L, f.anchors(rng, 6, radius=(0.05, 0.5)))     # anchors: surely lit
        bins, k = 8096, 600
        for ulps in (-3, -1, 0, 1, 3):
            f.scene.max_depth = b * bins / k * (1 + ulps * F32_EPS)
            res = {"brute": f.render(L, techniques=["brute"])["brute"]}
            for v in (1, 3):
                res[f"zbin{v}"] = f.renderer.render(ZBIN, 0, {"zbin_variant": v, "zbins": bins}, lights=L)
            f.check(L, where=f"z-bin boundary, {ulps} ulp", results=res)


def test_native_and_emulated_waves_agree(gl, hangar):
    r, ref = hangar
    for v in range(4):
        emu = r.render(ZBIN, 0, {"zbin_variant": v})
        nat = r.render(ZBIN, 0, options("zbin", zbin_variant=v, native_wave=True))
        assert np.array_equal(emu.image, nat.image)
        assert np.array_equal(emu.contrib_hash, nat.contrib_hash)
        if variant_flags(v)[1]:        # a native subgroup merges a part of the group's lanes
            assert (nat.evaluated <= emu.evaluated).all()
        else:
            assert np.array_equal(emu.evaluated, nat.evaluated)


def test_printed_mask_is_exact_and_looser(gl, hangar):
    """The listing's mask as printed leaks lights of other words: exact, more evaluations
    (on the CPU's tiles; the tile depth test removes most of what it leaks)."""
    r, ref = hangar
    for v in (1, 3):
        for depth in (False, True):
            opts = {"zbin_variant": v, "tile_depth": depth}
            tight = r.render(ZBIN, 0, opts)
            printed = r.render(ZBIN, 0, dict(opts, printed_mask=True))
            assert_exact({"brute": ref, "zbin": printed}, f"printed mask {opts}")
            assert (printed.evaluated >= tight.evaluated).all()
            if not depth:
                assert printed.evaluated.sum() > tight.evaluated.sum()


def test_tile_options_and_bins_keep_exactness(gl, hangar):
    r, ref = hangar
    for opts in ({"bit_tile": 5}, {"bit_tile": 16, "zbin_variant": 2}, {"zbins": 1},
                 {"zbins": 3, "zbin_variant": 1}, {"bit_budget_mib": 1 / 64}, {"zbins": 100_000}):
        got = r.render(ZBIN, 0, opts)
        assert_exact({"brute": ref, "zbin": got}, str(opts))
    # the budget doubled the tile: reported, exact
    assert got.meta["stats"]["bit_tile_used"] == 8
    tiny = r.render(ZBIN, 0, {"bit_budget_mib": 1 / 64})
    assert tiny.meta["stats"]["bit_tile_used"] > 8
    assert tiny.meta["bytes"]["tile_bits"] <= 1 << 14


@pytest.mark.parametrize("window", [64, 48], ids=["aligned", "unaligned"])
def test_dispatch_windows_give_the_same_frame(gl, hangar, monkeypatch, window):
    """Windows of 64 lights (whole words) or 48 (words split between windows) give the same
    lights, counters and image as one dispatch."""
    r, ref = hangar
    one = {v: r.render(ZBIN, 0, {"zbin_variant": v}) for v in range(4)}
    monkeypatch.setattr(limits, "DISPATCH_WINDOW", window)
    fi = r.frame_input(0, 64)
    if fi.loop_budget is None:
        pytest.skip("this driver has no loop limit: no dispatch windows")
    assert len(windows(fi, one[0].meta["stats"]["visible_lights"])) > 10
    for v in range(4):
        got = r.render(ZBIN, 0, {"zbin_variant": v})
        for f in ("image", "evaluated", "contrib_count", "contrib_hash"):
            assert np.array_equal(getattr(got, f), getattr(one[v], f)), (v, f)
        assert np.array_equal(got.wave["iterations"], one[v].wave["iterations"])
        assert np.array_equal(got.wave["lane_loops"][..., 0], one[v].wave["lane_loops"][..., 0])


def test_past_65536_lights_the_lut_widens(gl):
    """70,000 visible lights, the lit ones sorted past id 65,535 (tests/app/techniques/
    test_loop_budget.py's case): the 32-bit LUT keeps their ids; every masked variant exact."""
    from tests.app.techniques.hard_frames import budget_frame, budget_lights
    rng = np.random.default_rng(65_537)
    with budget_frame() as f:
        L, _ = budget_lights(f, rng)
        b = ZBIN.build(FrameInput(L, f.cam, f.scene.max_depth), None)
        assert b.stats["zbin_id_bits"] == 32 and b.buffers["zbins"].shape == (8096, 2)
        mn, mx = zb.unpack_lut(b.buffers["zbins"])
        assert mx.max() == len(L) - 1
        brute = f.render(L, techniques=["brute"])["brute"]
        lit = brute.contrib_count > 0
        assert lit.any()
        for v in (1, 3):
            got = f.renderer.render(ZBIN, 0, {"zbin_variant": v}, lights=L)
            assert_exact({"brute": brute, "zbin": got}, f"70,000 lights, variant {v}")
            assert got.meta["stats"]["zbin_id_bits"] == 32
            assert got.meta["bytes"]["zbins"] == 8096 * 8


def test_capture_runs_zbin_with_its_flags(tmp_path):
    out = subprocess.run([sys.executable, "-m", "app.capture", "--scene", "hangar", "--technique", "zbin",
                          "--lights", "300", "--size", "64x40", "--zbin-variant", "1", "--bit-tile", "16",
                          "--dump", str(tmp_path / "z.npz"), "--heatmap", str(tmp_path / "h.png")],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    with np.load(tmp_path / "z.npz") as d:
        meta = json.loads(str(d["meta"]))
    assert meta["technique"] == "zbin" and meta["options"]["zbin_variant"] == 1
    s = meta["stats"]
    assert s["bit_tile_used"] == 16 and s["variant"] == "tile + zbin" and s["zbins"] == 8096
    assert meta["bytes"]["tile_bits"] == s["bits_bytes"] and meta["bytes"]["zbins"] == 8096 * 4
    assert s["lane_iterations"] > 0 and s["wave_iterations"] > 0


def test_tile_depth_keeps_only_bits_of_lights_meeting_the_tiles_depths(gl, hangar):
    """zbin_tile_depth.comp: the culled bits are a subset of the CPU's, exactly those whose
    light's depth range meets the tile's min / max depth (no geometry: none), and the frame
    stays exact with fewer lights evaluated."""
    r, ref = hangar
    got = r.render(ZBIN, 0, {"zbin_variant": 0})
    b = got.build
    cpu = np.ascontiguousarray(b.buffers["tile_bits"]).view(np.uint32)
    culled = r.read("zbin_bits").view(np.uint32)
    assert ((culled & ~cpu) == 0).all()
    g, n = b.grid, len(b.lights)
    words = culled.size // (g.tiles_x * g.tiles_y)
    depth = got.depth[::-1]                                   # GL row order
    lo, hi = b.lights.depth_lo, b.lights.depth_hi
    rng = np.random.default_rng(0)
    for t in rng.choice(g.tiles_x * g.tiles_y, 40, replace=False):
        ty, tx = divmod(int(t), g.tiles_x)
        d = depth[ty * g.tile:(ty + 1) * g.tile, tx * g.tile:(tx + 1) * g.tile]
        d = d[d > 0]
        ids = np.nonzero(np.unpackbits(cpu[t * words:(t + 1) * words].view(np.uint8), bitorder="little"))[0]
        want = ids[(lo[ids] <= d.max()) & (hi[ids] >= d.min())] if d.size else ids[:0]
        have = np.nonzero(np.unpackbits(culled[t * words:(t + 1) * words].view(np.uint8), bitorder="little"))[0]
        assert np.array_equal(want, have), (t, want, have)
    off = r.render(ZBIN, 0, {"zbin_variant": 0, "tile_depth": False})
    assert_exact({"brute": ref, "zbin": got}, "tile depth")
    assert got.evaluated.sum() < off.evaluated.sum()
    assert 0 < got.meta["stats"]["depth_kept_share"] < 1
