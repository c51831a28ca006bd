"""tree's shared-memory tree (`shared_tree`) and the top-down build (`tree_build` 1) of tree
and hybrid: exact against brute on every builtin scene and in the option combinations that
change the shaders' paths; the wave replay (Tree/Hybrid.wave_program) gives the shaders' own
per-pixel counters (tests/app/model/replay_check.py); the groups that read their tree from
shared memory are exactly those the rules say (one tree of 1..SHARED_TREE_NODES nodes: with
tiles of a multiple of 8 pixels every such group, without a vote), with the barriers the
replay counts."""
from __future__ import annotations

import numpy as np
import pytest

from app.model import waves
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, with_role, parts
from app.techniques.blocks import SHARED_TREE_NODES
from app.techniques.tree import group_tiles
from scenes import BUILTIN_SCENES, load_scene
from tests.app.model.replay_check import check, gl_order
from tests.helpers import BUILTIN_LIGHTS, assert_exact, builtin_reference, render_on

SIZE = (72, 48)                  # 9 x 6 groups, as test_waves: whole groups and 4-row halves
LIGHTS = 1536

# the options whose loops the replay walks differently
VARIANTS = [
    ("tree", {}),                                              # shared, 48 px: no vote
    ("tree", {"shared_tree": False}),
    ("tree", {"tile": 20}),                                    # groups straddle tiles: a vote
    ("tree", {"tile": 12, "tree_build": 1}),
    ("tree", {"tile": 16, "lights_per_leaf": 1, "max_leaves": 256}),  # some past 128 nodes
    ("tree", {"tile": 36, "lights_per_leaf": 1, "max_leaves": 128}),
    ("tree", {"tree_build": 1}),
    ("tree", {"tree_build": 1, "duplicated": True, "shared_tree": False}),
    ("hybrid", {"tree_build": 1}),
    ("hybrid", {"tree_build": 1, "specialised": False}),
    ("hybrid", {"tree_build": 1, "radius_scale": 4.0, "scalarize": True}),
]


@pytest.mark.parametrize("scene", ["corridor", "city"])
def test_replay_matches_shader_counters(gl, scene):
    sc = load_scene(scene, lights=LIGHTS, seed=5)
    with Renderer(sc, SIZE) as r:
        for name, opts in VARIANTS:
            check(r, name, opts, 64, scene)
        for name, opts in VARIANTS[:4]:
            check(r, name, opts, 32, scene)


def expected_shared(res, fr, opts) -> np.ndarray:
    """Per group (GL dispatch order), whether it reads its tree from shared memory."""
    ranges = res.build.buffers["ranges"]["offset_count"].astype(np.int64)
    groups = -(-SIZE[0] // 8) * -(-SIZE[1] // 8)
    if opts.get("tile", 48) % 8 == 0:
        count = ranges[group_tiles(fr, res.build.grid), 1]
        return (count >= 1) & (count <= SHARED_TREE_NODES)
    px = np.nonzero(fr.shading)[0]
    cell, group = fr.cell[px], fr.group[px]
    out = np.zeros(groups, bool)
    for g in range(groups):
        c = np.unique(cell[group == g])
        out[g] = len(c) == 1 and 1 <= ranges[c[0], 1] <= SHARED_TREE_NODES
    return out


@pytest.mark.parametrize("opts", [{}, {"tile": 20}, {"tile": 12, "tree_build": 1},
                                  {"tile": 16, "lights_per_leaf": 1, "max_leaves": 256}])
def test_shared_groups_and_barriers(gl, opts):
    """The shader's shared-tree bit per group (WAVE_STATS case bit 2) is the rule's; the
    replay counts one barrier per such group, plus the vote's four per group where the tile
    is not a multiple of 8; its shared-memory node reads are the shared groups' visits and
    each of their invocations loads its nodes (l, l + 64, ...)."""
    sc = load_scene("arena", lights=LIGHTS, seed=7)
    with Renderer(sc, SIZE) as r:
        tech = REGISTRY["tree"]
        res = r.render(tech, 0, opts)
        fr = waves.frame_data(r, res, tech.resolve_options(opts))
        want = expected_shared(res, fr, opts)
        got = (np.ascontiguousarray(res.wave["case_bits"][::-1]).ravel() & 4) != 0
        assert np.array_equal(got, want), opts
        assert want.any(), f"{opts}: no group read a shared tree: the test is void"
        if "max_leaves" in opts:
            assert not want.all(), "trees past 128 nodes should take the global path"
        prog = parts.wave_program(tech, fr, 64)
        vote = 0 if opts.get("tile", 48) % 8 == 0 else 4 * prog.groups
        assert prog.barriers == vote + int(want.sum())
        f = waves.replay(prog).figures
        px = np.nonzero(fr.shading & want[fr.group])[0]
        assert f.loop("lds_node")["lanes"] == int(gl_order(res.nodes)[px].sum())
        ranges = res.build.buffers["ranges"]["offset_count"].astype(np.int64)
        if opts.get("tile", 48) % 8 == 0:
            count = ranges[group_tiles(fr, res.build.grid), 1][want]
            assert f.loop("load")["lanes"] == int(count.sum())   # the image is whole groups


# the option sets brute must agree with on every scene (brute takes none of them)
EXACT_OPTIONS = {
    "topdown": dict(tree_build=1),
    "topdown-t20": dict(tree_build=1, tile=20, slices=4),
    "global-t24-big": dict(shared_tree=False, tile=24, lights_per_leaf=1, max_leaves=256),
    "topdown-t20-big-dup": dict(tile=20, lights_per_leaf=2, max_leaves=128, tree_build=1,
                                duplicated=True)}


@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_options_exact_on_every_scene(gl, name):
    """Every option set against one brute frame a scene (test_exactness's uniform draw,
    rendered once for both: tests.helpers.builtin_reference)."""
    brute = with_role("reference").name
    assert not set().union(*EXACT_OPTIONS.values()) & set(REGISTRY[brute].Options.names())
    scene, ref = builtin_reference(name, BUILTIN_LIGHTS, 1, "uniform", (160, 90))    # test_exactness's
    with Renderer(scene) as r:
        for key, opts in EXACT_OPTIONS.items():
            got = render_on(r, opts, ["tree", "hybrid"], reference=ref)
            assert_exact(got, f"{name} {key} {opts}")


def test_topdown_evaluates_fewer_lights_on_arena(gl):
    """Spread lights (arena at 8,192): the top-down trees evaluate fewer lights per pixel and
    visit fewer nodes than the bottom-up ones, for tree and hybrid; same exact lights."""
    sc = load_scene("arena", lights=8192, seed=1)
    with Renderer(sc, (192, 108)) as r:
        for name in ("tree", "hybrid"):
            a, b = (r.render(REGISTRY[name], 0, {"tree_build": k}) for k in (0, 1))
            sh = a.depth > 0
            assert b.evaluated[sh].mean() < a.evaluated[sh].mean(), name
            assert b.nodes[sh].mean() < a.nodes[sh].mean(), name
            assert np.array_equal(a.contrib_count, b.contrib_count)
