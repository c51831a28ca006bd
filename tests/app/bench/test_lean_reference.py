"""The lean C (app/bench/c_reference/lean_ref.c, the hybrid's CPU stage as the tree paper
describes it, written apart from the lab) against our numba stage, where the two designs
agree: the same light set in every cell but where our margins widen a bound (ours is the
lean C's set plus lights within a cell of the lean box, never fewer); the same list / tree
choice wherever the cell's light set is the same and listing 2's mean is not at the
threshold; trees that hold each cell's lights in order and bound their depths; `bench cpu
--lean-reference` prints the third column.  No skip: without a C compiler these fail."""
from __future__ import annotations

import json

import numpy as np
import pytest

from app import bench
from app.bench.c_reference import CReferenceError
from app.bench.c_reference.lean import LeanReference, list_differences
from cpu_prep import frame as cpuframe, grid as gridmod, hybrid as hybridmod
from cpu_prep.camera import frame_camera
from scenes.model import Camera
from tests.helpers import random_lights


@pytest.fixture(scope="module")
def lean():
    try:
        r = LeanReference()
    except CReferenceError as exc:
        pytest.fail(f"the lean C cannot be built here (it needs `cc`: scripts/setup.sh "
                    f"installs gcc): {exc}")
    yield r
    r.close()


def frame(seed: int, n: int, size, near_eye: bool):
    """n point lights around a random camera (near_eye: small lights a few metres around
    it, a far near plane, so lights cross it and contain the eye)."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-5, 5, 3) if near_eye else rng.uniform((-25, 0, -25), (25, 20, 25))
    lo, hi = (pos - 4.0, pos + 4.0) if near_eye else ((-30, -5, -30), (30, 25, 30))
    lights = random_lights(rng, n, lo, hi, radius=(0.05, 3.0 if near_eye else 8.0), spot_share=0.0)
    near = float(rng.choice([0.25, 1.0])) if near_eye else 0.1
    cam = Camera(tuple(pos), tuple(pos + rng.normal(size=3)), (0.0, 1.0, 0.0),
                 float(rng.uniform(30, 100)), near, 200.0)
    return lights, frame_camera(cam, *size)


CASES = [  # seed, lights, size, near_eye, tile, slices, lights_per_leaf, max_leaves
    (1, 2000, (320, 180), False, 16, 16, 6, 64),
    (2, 1500, (333, 127), True, 24, 16, 4, 16),
    (3, 1200, (97, 61), False, 8, 1, 2, 8),
    (4, 800, (320, 180), True, 48, 4, 1, 2),
]


def build_both(lean, case):
    seed, n, size, near_eye, tile, slices, per_leaf, max_leaves = case
    lights, cam = frame(seed, n, size, near_eye)
    max_depth = 150.0
    grid = gridmod.make_grid(cam, tile, slices, max_depth, 5.0)
    pl = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())
    offsets, entries, boxes = gridmod.bin_rects(grid, pl.rect, pl.depth_lo, pl.depth_hi)
    _, _, _, is_tree = hybridmod.plan_and_build(grid, offsets, entries, pl.depth_lo,
                                                pl.depth_hi, max_depth, 1.0, per_leaf, max_leaves)
    f = lean.frame(lights, cam, grid, max_depth, per_leaf, max_leaves)
    ours = dict(pl=pl, offsets=offsets.copy(), entries=entries.copy(), boxes=boxes.copy(),
                is_tree=is_tree.copy())
    return f, ours, grid


def cell_xyz(grid, cells):
    cells = np.asarray(cells, np.int64)
    s, t = cells % grid.slices, cells // grid.slices
    return t % grid.tiles_x, t // grid.tiles_x, s


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"seed{c[0]}")
def test_lists_are_ours_less_the_margins(lean, case):
    f, o, grid = build_both(lean, case)
    d = list_differences(f, o["pl"].ids, o["offsets"], o["entries"])
    assert d["lean_entries"] > 100 and len(d["lean_only"]) == 0
    assert len(d["ours_only"]) <= 0.05 * d["our_entries"]     # a margin's width of cells
    # each pair only ours has: a cell within one of the lean box of that light (its tiles
    # and slices widened by the margins), or a light the lean C sees nothing of, in a cell
    # of ours at the grid's edge
    where = {int(i): j for j, i in enumerate(f.ids)}
    x, y, s = cell_xyz(grid, d["ours_only"] >> 32)
    for cx, cy, cs, light in zip(x, y, s, (d["ours_only"] & 0xFFFFFFFF).tolist()):
        j = where.get(light)
        b = {k: int(f.boxes[j][k]) for k in f.boxes.dtype.names} if j is not None else None
        if b is not None and b["x0"] <= b["x1"]:
            assert b["x0"] - 1 <= cx <= b["x1"] + 1 and b["y0"] - 1 <= cy <= b["y1"] + 1
            assert b["s0"] - 1 <= cs <= b["s1"] + 1
        else:
            assert (cx in (0, grid.tiles_x - 1) or cy in (0, grid.tiles_y - 1)
                    or cs in (0, grid.slices - 1)), (light, cx, cy, cs)


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"seed{c[0]}")
def test_the_lean_cull_drops_only_lights_at_the_margins(lean, case):
    """Every light our cull keeps and the lean C's drops reaches into the frustum by less
    than our margins (a pixel on the sides, a relative 1e-5 on near and far)."""
    seed, n, size, near_eye = case[:4]
    lights, cam = frame(seed, n, size, near_eye)
    f, o, _ = build_both(lean, case)
    pl = o["pl"]
    dropped = ~np.isin(pl.ids, f.ids)
    assert not np.isin(f.ids, pl.ids, invert=True).any() and dropped.sum() < 0.02 * len(pl.ids)
    c, r = pl.center[dropped], lights["radius"][pl.ids[dropped]].astype(np.float64)
    d = -c[:, 2]
    tx, ty = cam.tan_half_x, cam.tan_half_y
    reach = np.min([d + r - cam.near, cam.far - (d - r),
                    (c[:, 0] + tx * d) / np.hypot(1, tx) + r, (-c[:, 0] + tx * d) / np.hypot(1, tx) + r,
                    (c[:, 1] + ty * d) / np.hypot(1, ty) + r, (-c[:, 1] + ty * d) / np.hypot(1, ty) + r],
                   axis=0)
    pixel = 2.0 * max(tx / cam.width, ty / cam.height) * np.maximum(d, cam.near)
    assert (reach <= 2.0 * pixel + 1e-4 * (r + np.abs(d))).all()


@pytest.mark.parametrize("case", CASES[:2], ids=lambda c: f"seed{c[0]}")
def test_the_same_choice_where_the_sets_agree(lean, case):
    f, o, grid = build_both(lean, case)
    ids, ent, off = o["pl"].ids, o["entries"], o["offsets"]
    lo_s, hi_s = hybridmod.cell_depth_ranges(grid, 150.0)
    agree = 0
    for c in range(grid.cells):
        mine = ids[ent[off[c]:off[c + 1]]]
        if len(mine) == 0 or set(mine.tolist()) != set(f.ids[f.entries[f.offsets[c]:f.offsets[c + 1]]].tolist()):
            continue
        s = c % grid.slices
        lo, hi = o["pl"].depth_lo[ent[off[c]:off[c + 1]]], o["pl"].depth_hi[ent[off[c]:off[c + 1]]]
        mean = np.mean(np.maximum(np.minimum(hi, hi_s[s]) - np.maximum(lo, lo_s[s]), 0.0))
        if abs(mean - 0.5 * (hi_s[s] - lo_s[s])) > 1e-3 * (hi_s[s] - lo_s[s]):
            assert f.is_tree[c] == o["is_tree"][c], c
            agree += 1
    assert agree > 50 and 0 < f.is_tree.sum() < grid.cells


def subtree(bits, p: int) -> int:
    """The nodes of the depth-first subtree at p, checked against its skip count (a leaf
    skips itself; an inner node its two subtrees, one after the other, and itself)."""
    skip = int(bits[p] >> 17)
    if bits[p] & 1:
        assert skip == 1
        return 1
    left = subtree(bits, p + 1)
    assert skip == 1 + left + subtree(bits, p + 1 + left)
    return skip


def test_trees_hold_each_cells_lights(lean):
    f, _, grid = build_both(lean, CASES[1])
    assert f.is_tree.any()
    for c in range(grid.cells):
        first, count = int(f.ranges[c, 0]), int(f.ranges[c, 1] & 0x7FFFFFFF)
        a, b = int(f.offsets[c]), int(f.offsets[c + 1])
        if a == b:
            assert count == 0
            continue
        nodes = f.nodes[first:first + count]
        assert bool(f.ranges[c, 1] >> 31) == f.is_tree[c] and (count == 1) != f.is_tree[c]
        assert subtree(nodes["bits"], 0) == count            # skip counts: each subtree's size
        leaves = [(int(nd["first_light"]), int(nd["bits"] >> 1) & 0xFFFF, nd)
                  for nd in nodes if nd["bits"] & 1]
        assert len(leaves) & (len(leaves) - 1) == 0 and 2 * len(leaves) - 1 == count
        pos = a                                              # depth first: leaves in order
        for start, n, nd in leaves:
            assert start == pos or n == 0
            if n:
                z = f.depth[f.entries[start:start + n]]
                assert nd["min_depth"] == z[:, 0].min() and nd["max_depth"] == z[:, 1].max()
            pos += n
        assert pos == b


def test_bench_prints_the_lean_column(lean, capsys):
    bench.main(["cpu", "--lean-reference", "--scene", "arena", "--technique", "hybrid",
                "--lights", "1024", "--size", "320x180", "--repeat", "3", "--json"])
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert d["identical"] and list(d["rows"]) == ["cull", "sort + gather", "bin", "plan + build", "total"]
    L = d["lean"]
    assert list(L["rows"]) == list(d["rows"]) and L["lists"]["lean_only"] == 0
    t = L["rows"]["total"]
    assert t["lean_min_ms"] > 0 and t["ratio_min"] == pytest.approx(
        t["numba_min_ms"] / t["lean_min_ms"], rel=1e-2)
    q = t["paired_ratio_quartiles"]
    assert q[0] <= t["paired_ratio_median"] <= q[1]
    bench.main(["cpu", "--lean-reference", "--scene", "arena", "--technique", "clustered",
                "--lights", "512", "--size", "97x61", "--repeat", "2"])
    text = capsys.readouterr().out
    assert "lean C" in text and "numba / lean C" in text
    bench.main(["cpu", "--lean-reference", "--scene", "arena", "--technique", "clustered",
                "--lights", "512", "--size", "97x61", "--repeat", "2", "--json"])
    L = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["lean"]
    assert list(L["steps"]) == ["cull", "sort", "gather", "bin"] and "plan + build" not in L["rows"]
