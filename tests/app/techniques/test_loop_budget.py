"""No silent truncation: llvmpipe stops every loop of a shader invocation once
their iterations together pass 65,535, with no error.  A frame whose pixels meet more lights
than that runs its passes in dispatch windows (glsl/pixel.glsl), so every technique, brute
included, stays exact at any light count.

The case: 70,000 lights, all visible, all in one tile and one depth slice.  66,000 decoys float
above a floor at the depth of the floor's pixels (every technique's structure lists them for
those pixels, none touches a pixel); 4,000 lights sit on the floor pixels just behind the
decoys in depth order, so they are the 66,001st to 70,000th light the loops meet: a truncated
loop never reaches them.  brute is checked against a float64 reference, every technique
against brute."""
from __future__ import annotations

import numpy as np
import pytest

from app.pipeline import gl as glmod
from app.pipeline.passes import FrameInput
from app.techniques import REGISTRY
from cpu_prep import limits
from scenes.geometry import box_mesh
from scenes.model import Camera, make_lights
from tests.app.techniques.hard_frames import DEPTH, N_DECOYS, Frame, budget_frame, budget_lights, concat, scene_of



def test_lights_past_the_loop_budget_are_shaded_in_every_technique(gl):
    rng = np.random.default_rng(65_536)
    with budget_frame() as f:
        L, band = budget_lights(f, rng)
        b = REGISTRY["brute"].build(FrameInput(L, f.cam, f.scene.max_depth), None)
        assert b.stats["visible_lights"] == len(L)
        order = {int(i): k for k, i in enumerate(b.lights.ids)}
        assert min(order[i] for i in range(N_DECOYS, len(L))) >= limits.SOFTWARE_LOOP_BUDGET, \
            "the lit lights must come after the 65,535th light in depth order"
        res = f.check(L, where="70,000 lights, the lit ones past the loop budget")
        lit_px = res["brute"].contrib_count > 0
        assert (lit_px & band).sum() >= 10
        # brute, and the structures that cannot cull the decoys away from those pixels, loop
        # over more lights than the budget there (trees skip them by depth; perfect lists
        # only what lights the pixel)
        past = {n for n, r in res.items() if r.evaluated[lit_px].max() > limits.SOFTWARE_LOOP_BUDGET}
        assert {"brute", "tiled", "clustered"} <= past, past


def test_without_windows_this_driver_truncates(gl, monkeypatch):
    """The case is a real one on a driver with a loop limit: with dispatch windows disabled,
    brute misses the lit lights (on a GPU driver without the limit it stays exact)."""
    rng = np.random.default_rng(65_536)
    with budget_frame() as f:
        L, _ = budget_lights(f, rng)
        windowed = f.render(L, techniques=["brute"])["brute"]
        monkeypatch.setattr(limits, "DISPATCH_WINDOW", 1 << 30)
        single = f.render(L, techniques=["brute"])["brute"]
    if glmod.limits().loop_budget:
        assert windowed.contrib_count.sum() > 0
        assert (single.contrib_count < windowed.contrib_count).any(), \
            "one dispatch over 70,000 lights was not truncated: the loop limit changed?"
        assert single.evaluated.max() <= limits.SOFTWARE_LOOP_BUDGET
    else:
        assert np.array_equal(single.contrib_hash, windowed.contrib_hash)


# ---- every light affecting: evaluate_all_lights at its worst ------------------------------
N_ALL = 40_000          # three windows of DISPATCH_WINDOW; 83,751 iterations in one dispatch


def all_affecting_lights(f: Frame) -> np.ndarray:
    """N_ALL lights 1 m above the floor pixel nearest the band's middle, each reaching the
    floor pixels within ~6 m: there every light of every window affects the pixel."""
    depth = f.pos[..., 3]
    ys, xs = np.nonzero(f.covered)
    k = np.argmin(np.abs(depth[ys, xs] - DEPTH))
    c = f.pos[ys[k], xs[k], :3].astype(np.float64) + [0.0, 1.0, 0.0]
    L = make_lights(N_ALL)
    L["position"] = f.to_world(c[None])
    L["radius"] = 6.0
    L["color"] = np.random.default_rng(7).uniform(0.2, 1.0, (N_ALL, 3))
    return L


def test_every_light_of_every_window_affecting_stays_in_the_budget(gl, monkeypatch):
    """evaluate_all_lights (glsl/pixel.glsl: an affects mask a run of 32 lights, then its set
    bits) spends up to 2 + 3/32 iterations a light when every light affects the pixel
    (cpu_prep/limits.py): 40,000 lights all reaching the same floor pixels.  Every technique
    gives brute's lights there, brute the float64 reference's (all 40,000 at each lit pixel;
    tiled's and fptl's overflowed tiles shade through the same loop beside their lists); in
    one dispatch the driver stops brute short: the case reaches the budget."""
    with budget_frame() as f:
        L = all_affecting_lights(f)
        res = f.check(L, where="40,000 lights, every one affecting the lit pixels")
        cnt = res["brute"].contrib_count
        assert (cnt == N_ALL).sum() >= 20, "the lit pixels should meet every light"
        assert set(np.unique(cnt)) <= {0, N_ALL}
        monkeypatch.setattr(limits, "DISPATCH_WINDOW", 1 << 30)
        single = f.render(L, techniques=["brute"])["brute"]
    if glmod.limits().loop_budget:
        assert single.contrib_count.max() < N_ALL, \
            "one dispatch of 40,000 all-affecting lights was not truncated: the loop's cost changed?"
    else:
        assert np.array_equal(single.contrib_hash, res["brute"].contrib_hash)


def test_a_listed_tile_beside_an_overflowed_one_in_one_vector(gl, monkeypatch):
    """The budget's worst pass: lanes of one 8-lane vector in two 4-pixel tiles, one walking
    its list of 40,000 lights, the other (its tile overflowed the pool) every light through
    evaluate_all_lights, every light affecting every pixel: 34,305 + 16,385 iterations a
    window together (cpu_prep/limits.py), and every pixel meets all 40,000 lights."""
    from app.techniques import tiled
    from cpu_prep import layouts
    from tests.helpers import assert_exact
    t = np.tan(np.radians(20.0))
    wall = box_mesh((-2 * t * 10, -2 * t * 10, -10.01), (2 * t * 10, 2 * t * 10, -10.0))
    cam = Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), fov_y_deg=40.0, near=0.1, far=100.0)
    monkeypatch.setattr(tiled, "POOL_MAX_ENTRIES", N_ALL)     # room for one tile's list
    with Frame(scene_of([wall], cam, size=(8, 8), max_depth=50.0)) as f:
        assert f.covered.all()
        L = make_lights(N_ALL)
        L["position"] = f.to_world(np.array([[0.0, 0.0, -9.0]]))
        L["radius"] = 8.0
        res = f.render(L, {"tile": 4}, techniques=["brute", "tiled"])
        counts = f.renderer.read("ranges").view(layouts.CELL_RANGE)["offset_count"][:, 1]
        assert sorted(counts.tolist()) == [N_ALL] + [tiled.OVERFLOW] * 3, counts
    assert_exact(res, "a listed and an overflowed tile in one vector")
    assert (res["brute"].contrib_count == N_ALL).all() and (res["tiled"].evaluated == N_ALL).all()


@pytest.mark.parametrize("longest,expect", [
    (0, 1), (limits.DISPATCH_WINDOW, 1), (limits.DISPATCH_WINDOW + 1, 2), (70_000, 5)])
def test_windows_cover_every_position_once(longest, expect):
    from app.techniques.base import windows
    from cpu_prep.camera import frame_camera
    fi = FrameInput(make_lights(0), frame_camera(Camera((0, 0, 0), (0, 0, -1)), 8, 8), 10.0,
                    loop_budget=limits.SOFTWARE_LOOP_BUDGET)
    w = windows(fi, longest)
    assert len(w) == expect and w[0][0] == 0 and w[-1][1] == limits.WINDOW_ALL
    assert all(a[1] == b[0] for a, b in zip(w, w[1:]))
    fi.loop_budget = None
    assert windows(fi, 10**7) == [(0, limits.WINDOW_ALL)]


# ---- lanes in lockstep: the budget is the SIMD vector's --------------------------------
COLUMNS, PER_COLUMN = 8, 9_000


def lockstep_frame() -> tuple[Frame, np.ndarray]:
    """An 8x8 image whose 8 columns see 8 strips at 8 depths, and 9,000 small lights just in
    front of each strip: a row of the 8x8 group (llvmpipe's 8-lane vector) meets 72,000
    lights, each lane 9,000 of them in leaves of its own, at its own steps of the traversal."""
    t = np.tan(np.radians(20.0))
    depths = 10.0 + 5.0 * np.arange(COLUMNS)
    meshes, lights = [], []
    rng = np.random.default_rng(8)
    for k, z in enumerate(depths):
        x0, x1 = (-1 + 2 * k / COLUMNS + 0.02) * t * z, (-1 + 2 * (k + 1) / COLUMNS - 0.02) * t * z
        meshes.append(box_mesh((x0, -t * z, -z - 0.01), (x1, t * z, -z)))
        L = make_lights(PER_COLUMN)
        L["position"] = np.column_stack([rng.uniform(x0, x1, PER_COLUMN),
                                         rng.uniform(-t * z, t * z, PER_COLUMN),
                                         np.full(PER_COLUMN, -z + 0.3)])
        L["radius"] = 0.6
        lights.append(L)
    cam = Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), fov_y_deg=40.0, near=0.1, far=200.0)
    return Frame(scene_of(meshes, cam, size=(8, 8), max_depth=60.0)), concat(*lights)


def test_lanes_in_lockstep_share_the_budget(gl):
    """Tree traversals whose lanes meet 9,000 lights each in leaves of their own, 72,000 on
    one 8-lane row, stay exact: their dispatch windows shrink by the driver's lanes in
    lockstep (gl.Limits.loop_lanes), since the driver counts a vector's iterations and
    leaves met at different steps add up.  (Measured before the fix: city, 1,000,000 lights,
    320x180, a tree pixel met 34,071 of its 42,779 lights in windows of 16,384; hybrid lost
    lights at 11 pixels; now both equal clustered at every pixel.)"""
    frame, L = lockstep_frame()
    with frame as f:
        res = f.check(L, where="8 lanes, 8 depths, 72,000 lights")
        lit = res["brute"].contrib_count > 0
        assert lit.all(axis=0).sum() >= 6, "every column should be lit"
        for name in ("tree", "hybrid"):
            ev = res[name].evaluated[lit]
            assert ev.min() >= 0.9 * PER_COLUMN, name    # each lane walks its column's lights
        if glmod.limits().loop_budget:
            assert glmod.limits().loop_lanes == 8           # "256 bits" of 32-bit lanes
            shade = [k for k in res["tree"].meta["gpu_ms"] if k != "gbuffer"]
            assert shade, "the tree's shading pass ran"


def test_windows_shrink_by_the_lanes_in_lockstep():
    from app.techniques.base import windows
    from cpu_prep.camera import frame_camera
    fi = FrameInput(make_lights(0), frame_camera(Camera((0, 0, 0), (0, 0, -1)), 8, 8), 10.0,
                    loop_budget=limits.SOFTWARE_LOOP_BUDGET, loop_lanes=8)
    assert len(windows(fi, 70_000)) == 5                       # one inner loop: lanes agree
    w = windows(fi, 70_000, steps=1 << 15)                     # a traversal: leaves add up
    assert len(w) == -(-70_000 // (limits.DISPATCH_WINDOW // 8))
    assert all(b[0] - a[0] == limits.DISPATCH_WINDOW // 8 for a, b in zip(w, w[1:]))
    assert len(windows(fi, 70_000, steps=2)) == -(-70_000 // (limits.DISPATCH_WINDOW // 2))
