"""Froxel light sets (cpu_prep/froxels.py): brute's sets equal a float64 oracle of "meets"
written here with its own geometry (the cell as 12 triangles, Ericson's closest point), and a
cell technique's sets (the union of the clustered cells a froxel overlaps, then the exact test)
equal brute's, on a builtin scene and the hard cases: a light straddling a froxel slice
boundary and a column plane, across the near plane, around the camera, past fog.far."""
import math

import numpy as np
import pytest

from cpu_prep import frame as cpuframe, froxels as fx, grid as gridmod
from cpu_prep.camera import frame_camera
from cpu_prep.limits import DEFAULT_NEAR_SLICE_DEPTH
from scenes import Camera, load_scene, make_lights
from scenes.model import LIGHT_SPOT

from helpers import random_shapes

# ---- the oracle -------------------------------------------------------------------------

TRIANGLES = [(0, 1, 3), (0, 3, 2), (4, 5, 7), (4, 7, 6), (0, 2, 6), (0, 6, 4),
             (1, 3, 7), (1, 7, 5), (0, 1, 5), (0, 5, 4), (2, 3, 7), (2, 7, 6)]


def closest_on_triangle(p, a, b, c):
    """Ericson, Real-Time Collision Detection 5.1.5, over rows of p (n, 3)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = ap @ ab, ap @ ac
    bp = p - b
    d3, d4 = bp @ ab, bp @ ac
    cp = p - c
    d5, d6 = cp @ ab, cp @ ac
    vc, vb, va = d1 * d4 - d3 * d2, d5 * d2 - d1 * d6, d3 * d6 - d5 * d4
    with np.errstate(divide="ignore", invalid="ignore"):
        on_ab = a + np.outer(d1 / (d1 - d3), ab)
        on_ac = a + np.outer(d2 / (d2 - d6), ac)
        on_bc = b + np.outer((d4 - d3) / ((d4 - d3) + (d5 - d6)), c - b)
        den = 1.0 / (va + vb + vc)
        inside = a + np.outer(vb * den, ab) + np.outer(vc * den, ac)
    conds = [(d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (vc <= 0) & (d1 >= 0) & (d3 <= 0),
             (d6 >= 0) & (d5 <= d6), (vb <= 0) & (d2 >= 0) & (d6 <= 0),
             (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)]
    picks = [np.broadcast_to(a, p.shape), np.broadcast_to(b, p.shape), on_ab,
             np.broadcast_to(c, p.shape), on_ac, on_bc]
    out = inside.copy()
    done = np.zeros(len(p), bool)
    for cond, pick in zip(conds, picks):
        take = cond & ~done
        out[take] = pick[take]
        done |= take
    return out


def oracle_sets(fg: fx.FroxelGrid, lb: fx.LightBounds) -> list[list[int]]:
    """Per froxel (id order), the lights that meet it, by the definition, in float64."""
    w, h, d = fg.dims
    us, vs = fg.ndc()
    out = []
    c, r = lb.centre, lb.radius
    depth = -c[:, 2]
    for k in range(d):
        for j in range(h):
            for i in range(w):
                screen = ((lb.rect[:, 0] < fg.xs[i + 1]) & (fg.xs[i] < lb.rect[:, 1])
                          & (lb.rect[:, 2] < fg.ys[j + 1]) & (fg.ys[j] < lb.rect[:, 3]))
                deep = (lb.depth[:, 0] < fg.zs[k + 1]) & (fg.zs[k] < lb.depth[:, 1])
                with np.errstate(divide="ignore", invalid="ignore"):
                    inside = ((depth >= fg.zs[k]) & (depth <= fg.zs[k + 1])
                              & (c[:, 0] >= us[i] * fg.tan_x * depth) & (c[:, 0] <= us[i + 1] * fg.tan_x * depth)
                              & (c[:, 1] >= vs[j] * fg.tan_y * depth) & (c[:, 1] <= vs[j + 1] * fg.tan_y * depth))
                q = fg.corners(i, j, k)
                d2 = np.full(len(c), np.inf)
                for a, b, e in TRIANGLES:
                    p = closest_on_triangle(c, q[a], q[b], q[e])
                    d2 = np.minimum(d2, ((p - c) ** 2).sum(1))
                meets = screen & deep & (inside | (d2 < r * r))
                out.append(np.flatnonzero(meets).tolist())
    return out


def as_lists(sets: fx.FroxelSets) -> list[list[int]]:
    o = sets.offsets
    return [sets.entries[o[f]:o[f + 1]].astype(int).tolist() for f in range(len(o) - 1)]


# ---- frames -------------------------------------------------------------------------------

CAM = Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 60.0, 0.1, 200.0)
SIZE = (96, 54)
FAR = 40.0


def prepared(lights, camera=CAM, size=SIZE):
    cam = frame_camera(camera, *size)
    return cam, cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())


def cell_grid(cam, tile=16, slices=12, max_depth=150.0):
    return gridmod.make_grid(cam, tile, slices, max_depth, DEFAULT_NEAR_SLICE_DEPTH)


def cell_sets(fg, cam, pl, grid, lb):
    offsets, entries = cpuframe.bin_cells(pl, cam, grid, cpuframe.StageTimes())
    ranges = np.stack([offsets[:-1], np.diff(offsets)], 1)
    return fx.froxel_sets_from_cells(fg, grid, ranges, entries, lb), ranges, entries


def hard_lights(fg: fx.FroxelGrid) -> np.ndarray:
    """The hard cases, each a light (point unless said), in view space = world (CAM)."""
    us, vs = fg.ndc()
    k = 5
    z = fg.zs[k]                                       # a slice boundary
    x_plane = us[7] * fg.tan_x * z                     # a column's side plane at that depth
    rows = [
        ((x_plane, 0.0, -z), 0.3 * (fg.zs[k + 1] - fg.zs[k])),   # centred on a slice edge and a column plane
        ((0.3, 0.2, -(z + 1e-9)), 0.2),                # a hair past the slice edge
        ((0.0, 0.1, -0.05), 0.5),                      # across the near plane (centre before it)
        ((0.2, -0.1, 0.3), 3.0),                       # the camera inside it
        ((1.0, 0.0, -(FAR + 3.0)), 2.0),               # wholly past fog.far: no froxel
        ((-1.0, 0.5, -(FAR + 0.5)), 2.0),              # straddling fog.far
        ((2.0, 1.0, -7.0), 1e-3),                      # far smaller than a froxel
        ((0.0, 0.0, -12.0), 60.0),                     # holding the whole grid
    ]
    lights = make_lights(len(rows))
    for n, (p, r) in enumerate(rows):
        lights["position"][n], lights["radius"][n] = p, r
    spot = make_lights(1)                              # a spot across the near plane
    spot["type"], spot["position"], spot["radius"] = LIGHT_SPOT, (0.0, 0.0, 0.5), 6.0
    spot["direction"], spot["cos_outer"], spot["cos_inner"] = (0.0, 0.0, -1.0), math.cos(0.4), 1.0
    return np.concatenate([lights, spot])


def random_frame_lights(seed=3, n=150):
    rng = np.random.default_rng(seed)
    return random_shapes(rng, n, (-30, -15, -60), (30, 15, 2))


@pytest.fixture(scope="module")
def hard():
    cam = frame_camera(CAM, *SIZE)
    fg = fx.make_froxel_grid(cam, (16, 9, 12), FAR)
    lights = np.concatenate([hard_lights(fg), random_frame_lights()])
    cam, pl = prepared(lights)
    return cam, pl, fg


def test_brute_sets_equal_the_float64_oracle_on_the_hard_cases(hard):
    cam, pl, fg = hard
    lb = fx.light_bounds(pl)
    got = as_lists(fx.froxel_sets_all(fg, lb))
    want = oracle_sets(fg, lb)
    assert got == want
    pos = {int(i): n for n, i in enumerate(pl.ids)}
    per_light = np.zeros(len(pl), int)
    for lst in got:
        per_light[lst] += 1
    assert per_light[pos[4]] == 0                    # wholly past fog.far
    assert per_light[pos[5]] > 0                     # straddling it: its last slice
    for light in (0, 1, 2, 3, 8):                    # slice edge, near plane, camera, spot
        assert per_light[pos[light]] > 0, light
    assert per_light[pos[7]] == fg.count             # holding the whole grid
    # the light on a slice edge meets froxels on both sides of it
    f = np.array([n for n, lst in enumerate(got) if pos[0] in lst])
    assert {4, 5} <= set((f // (fg.dims[0] * fg.dims[1])).tolist())


@pytest.mark.parametrize("dims", [(16, 9, 12), (7, 5, 9), "matched"])
def test_cell_sets_equal_brute_sets(hard, dims):
    cam, pl, fg = hard
    grid = cell_grid(cam)
    if dims == "matched":
        fg = fx.matched_grid(cam, grid, FAR)
    elif dims != fg.dims:
        fg = fx.make_froxel_grid(cam, dims, FAR)
    lb = fx.light_bounds(pl)
    cells, ranges, entries = cell_sets(fg, cam, pl, grid, lb)
    brute = fx.froxel_sets_all(fg, lb)
    assert np.array_equal(cells.offsets, brute.offsets)
    assert np.array_equal(cells.entries, brute.entries)
    assert cells.candidates >= len(cells.entries) and brute.candidates == fg.count * len(pl)


def test_a_builtin_scene_brute_oracle_and_cells_agree():
    scene = load_scene("hangar", 120, seed=2)
    cam, pl = prepared(scene.lights, scene.camera, (80, 45))
    fg = fx.make_froxel_grid(cam, (10, 6, 8), 60.0)
    lb = fx.light_bounds(pl)
    brute = fx.froxel_sets_all(fg, lb)
    assert as_lists(brute) == oracle_sets(fg, lb)
    grid = cell_grid(cam, 16, 16, scene.max_depth)
    cells, _, _ = cell_sets(fg, cam, pl, grid, lb)
    assert np.array_equal(cells.entries, brute.entries) and np.array_equal(cells.offsets, brute.offsets)
    assert len(brute.entries) > fg.count            # lit: many lights a froxel


def test_matched_grid_is_one_froxel_a_cell_and_the_centre_cell_shortcut_misses_only_elsewhere(hard):
    cam, pl, fg = hard
    grid = cell_grid(cam)
    lb = fx.light_bounds(pl)
    mg = fx.matched_grid(cam, grid, FAR)
    offsets, entries = cpuframe.bin_cells(pl, cam, grid, cpuframe.StageTimes())
    ranges = np.stack([offsets[:-1], np.diff(offsets)], 1)
    tx, ty, s = fx.cell_edges(grid)
    # every matched froxel lies in one cell: its centre's
    for axis_edges, cells in ((mg.xs, tx), (mg.ys, ty), (mg.zs, s)):
        lo, hi = axis_edges[:-1], axis_edges[1:]
        first = np.searchsorted(cells, lo, side="right") - 1
        last = np.searchsorted(cells, hi, side="left") - 1
        assert np.array_equal(first, last)
    for g, misses in ((mg, False), (fx.make_froxel_grid(cam, (16, 9, 12), FAR), True)):
        exact = as_lists(fx.froxel_sets_from_cells(g, grid, ranges, entries, lb))
        centre = as_lists(fx.centre_cell_sets(g, grid, ranges, entries))
        missing = sum(len(set(e) - set(c)) for e, c in zip(exact, centre))
        assert (missing > 0) == misses, (g.dims, missing)


def test_figures_follow_the_dump_contract(hard):
    cam, pl, fg = hard
    sets = fx.froxel_sets_all(fg, fx.light_bounds(pl))
    count, hashes = fx.set_figures(sets, pl.ids, fg.dims)
    w, h, d = fg.dims
    assert count.shape == hashes.shape == (d, h, w) and count.dtype == hashes.dtype == np.uint32
    from app.dump import mix
    lists = as_lists(sets)
    for f in (0, fg.count // 2, fg.count - 1):
        k, j, i = f // (w * h), f // w % h, f % w
        want = np.bitwise_xor.reduce(mix(pl.ids[lists[f]]), initial=np.uint32(0))
        assert count[k, h - 1 - j, i] == len(lists[f]) and hashes[k, h - 1 - j, i] == want


def test_grid_layout_and_budget():
    cam = frame_camera(CAM, *SIZE)
    fg = fx.make_froxel_grid(cam, (8, 4, 6), FAR)
    assert fg.zs[0] == CAM.near and fg.zs[-1] == FAR
    assert np.allclose(fg.zs[1:] / fg.zs[:-1], (FAR / CAM.near) ** (1 / 6))      # exponential
    assert fg.xs[0] == 0 and fg.xs[-1] == SIZE[0] and fg.ys[-1] == SIZE[1]
    big = frame_camera(CAM, 4096, 2048)
    for dims, word in (((4096, 2048, 1), "budget"), ((97, 4, 4), "1..96"), ((8, 4, 0), "D must")):
        with pytest.raises(fx.FroxelError, match=word):
            fx.make_froxel_grid(big if word == "budget" else cam, dims, FAR)
    assert fx.make_froxel_grid(big, (2048, 1024, 2), FAR).count == fx.MAX_FROXELS


def test_the_same_sets_on_one_thread_and_on_runs_of_slices(hard):
    import cpu_prep
    cam, pl, fg = hard
    lb = fx.light_bounds(pl)
    grid = cell_grid(cam)
    with cpu_prep.using_threads(1):
        one = fx.froxel_sets_all(fg, lb), cell_sets(fg, cam, pl, grid, lb)[0]
    with cpu_prep.using_threads(2):
        runs = fx.froxel_sets_all(fg, lb), cell_sets(fg, cam, pl, grid, lb)[0]
    for a, b in zip(one, runs):
        assert np.array_equal(a.offsets, b.offsets) and np.array_equal(a.entries, b.entries)
        assert a.candidates == b.candidates
