"""sample-tree: S stochastic descents a shading pixel of its tile's light tree.  Its support
(tree.glsl's exact traversal) equals brute's on the arena and in a hard case (the camera
inside lights, lights across the near plane); its estimate passes the statistical check
and its faulty shaders fail it; a seed reproduces its frame bit for bit; every pixel whose
tree reaches a light evaluates exactly S; the mean over K seeds converges as 1/sqrt(K)."""
from types import SimpleNamespace

import numpy as np
import pytest

from app import sampling_check as sc
from app.techniques import get
from app.errors import UserError
from app.techniques.sample_tree import check_loops
from scenes.model import LIGHT_POINT, LIGHT_SPOT, make_lights
from tests.app.techniques.hard_frames import Frame, axis_camera, concat, scene_of, unit, wall
from tests.helpers import assert_exact, floor_and_boxes, random_lights, with_brute

NAME = "sample-tree"


@pytest.fixture(scope="module")
def arena():
    with with_brute("arena", 2048, 3, (128, 72)) as got:
        yield got


def _render(r, **opts):
    t = get(NAME)
    return r.render(t, 0, t.resolve_options(opts))


@pytest.mark.parametrize("opts", [{}, dict(tile=16, lights_per_leaf=1, max_leaves=8, tree_build=1),
                                  dict(duplicated=True, light_samples=3)],
                         ids=["defaults", "topdown-tiny-leaves", "duplicated"])
def test_its_support_is_brutes_on_the_arena(gl, arena, opts):
    r, ref = arena
    res = _render(r, **opts)
    assert ref.contrib_count.sum() > 0
    assert np.array_equal(res.contrib_count, ref.contrib_count)
    assert np.array_equal(res.contrib_hash, ref.contrib_hash)


def test_its_support_is_brutes_with_the_camera_in_lights_and_lights_across_the_near_plane(gl):
    rng = np.random.default_rng(5)
    near = 0.1
    cam = axis_camera(fov=70.0, near=near, far=200.0)
    with Frame(scene_of([wall(near * 1.5 + 0.05, half=50.0)] + floor_and_boxes(), cam)) as f:
        n = 40
        inside = random_lights(rng, n, (-1, -1, -1), (1, 1, 1), radius=(0.5, 30.0), spot_share=0.3)
        inside["position"] = unit(rng.normal(size=(n, 3))) * (inside["radius"] * rng.uniform(0, 0.9, n))[:, None]
        inside["type"][0], inside["position"][0], inside["radius"][0] = LIGHT_POINT, 0.0, 20.0
        across = make_lights(n)                      # centres at depth near +- r
        r = rng.uniform(0.05, 3.0, n) * 0.1 * rng.choice([1.0, 10.0], n)
        depth = near + r * rng.uniform(-0.99, 0.99, n)
        across["position"] = np.column_stack([rng.uniform(-1, 1, (n, 2)) * np.maximum(depth, near)[:, None], -depth])
        across["radius"] = r
        spot = rng.random(n) < 0.3
        across["type"][spot] = LIGHT_SPOT
        across["direction"] = unit(rng.normal(size=(n, 3)) + [0, 0, -1.5])
        across["cos_outer"][spot] = across["cos_inner"][spot] = np.cos(np.radians(40.0))
        L = concat(inside, across, f.anchors(rng, 6))
        for opts in ({}, dict(tile=8, lights_per_leaf=2, max_leaves=16)):
            res = f.render(L, opts, techniques=["brute", NAME, "tree"])
            f.check(L, opts, where=f"camera in lights, near plane {opts}", results=res)
            reach = res["tree"].evaluated > 0
            assert reach.any() and (res[NAME].evaluated[reach] == 4).all()


def test_its_estimate_is_unbiased_and_converges_as_one_over_sqrt_k(gl, arena):
    r, ref = arena
    t = get(NAME)
    images = sc.seed_images(r, t, t.resolve_options(), 0, 64, 16)
    v = sc.judge(NAME, images, ref.image, ref.depth > 0)
    assert v.passed, v.message()
    shading = ref.depth > 0
    lum, want = sc.luminance(images)[:, shading], sc.luminance(ref.image)[shading]
    rmse = lambda k: np.sqrt(np.mean((lum[:k].mean(0) - want) ** 2))
    assert 1.4 < rmse(4) / rmse(16) < 3.0, rmse(4) / rmse(16)


@pytest.mark.parametrize("fault", [1, 2])
def test_its_faulty_shaders_fail_the_check(gl, arena, fault):
    r, ref = arena
    t = get(NAME)
    v = sc.check(r, t, t.resolve_options(), ref, seeds=4, defines={"SAMPLE_FAULT": fault})
    assert not v.passed, f"SAMPLE_FAULT {fault}: {v.message()}"


def test_a_seed_and_frame_reproduce_the_frame_bit_for_bit(gl, arena):
    r, _ = arena
    a, b = _render(r, sample_seed=7), _render(r, sample_seed=7)
    assert np.array_equal(a.image, b.image) and np.array_equal(a.nodes, b.nodes)
    other, later = _render(r, sample_seed=8), _render(r, sample_seed=7, sample_frame=1)
    assert not np.array_equal(a.image, other.image) and not np.array_equal(a.image, later.image)
    assert np.array_equal(a.contrib_hash, other.contrib_hash)        # the support stays


@pytest.mark.parametrize("samples", [1, 7])
def test_each_pixel_whose_tree_reaches_a_light_evaluates_its_samples(gl, arena, samples):
    """S evaluations where tree's traversal of the same trees evaluates a light, none
    elsewhere; the nodes read: the root's pieces, then per descent the root and two
    children a level."""
    r, ref = arena
    res = _render(r, light_samples=samples)
    tree = r.render(get("tree"), 0)
    reach = (ref.depth > 0) & (tree.evaluated > 0)
    assert reach.mean() > 0.5
    assert (res.evaluated[reach] == samples).all()
    assert res.evaluated[~reach].max(initial=0) == 0
    levels = res.nodes[reach] - 1 - samples
    assert (levels >= 0).all() and (levels % 2 == 0).all()
    assert (res.nodes[reach] < tree.nodes[reach] * samples).mean() > 0.5


def test_a_frame_whose_descents_could_pass_the_loop_limit_is_refused():
    opts = get(NAME).resolve_options({"light_samples": 64})
    limited, unlimited = SimpleNamespace(loop_budget=65535), SimpleNamespace(loop_budget=None)
    leaves = np.array([6, 256, 70_000])             # 70,000: drawn uniformly, no bound pass
    check_loops(limited, opts, np.array([16]), np.array([1]), leaves)   # 64 x (16 x 5 + 513)
    with pytest.raises(UserError, match="loop limit"):
        check_loops(limited, opts, np.array([64]), np.array([1 << 14]), leaves)
    check_loops(unlimited, opts, np.array([64]), np.array([1 << 14]), leaves)   # no limit


@pytest.mark.parametrize("opts", [{}, dict(tree_build=1, lights_per_leaf=1, light_samples=9, sample_seed=5)],
                         ids=["full-trees", "topdown-draw-dependent"])
def test_its_wave_replay_makes_the_shaders_draws_again(gl, arena, opts):
    """The replay's lights evaluated and nodes read equal the shader's counters at every
    pixel; in unbalanced (top-down) trees a descent's length is its draws', so another seed
    in the replay misses them."""
    from app.model import waves
    from app.techniques import parts
    r, _ = arena
    t = get(NAME)
    res = r.render(t, 0, t.resolve_options(opts))
    order = lambda a: np.ascontiguousarray(a[::-1]).ravel()         # GL rows
    ev, nodes = order(res.evaluated), order(res.nodes)
    fr = waves.frame_data(r, res, t.resolve_options(opts))
    rp = waves.replay(parts.wave_program(t, fr, 64))
    assert np.array_equal(rp.evaluated, ev) and np.array_equal(rp.nodes, nodes)
    assert ((rp.contrib > 0) & (order(res.contrib_count) == 0)).sum() == 0   # draws in the support
    if opts:
        assert len(np.unique(nodes[nodes > 0])) > 4
        other = waves.frame_data(r, res, t.resolve_options(dict(opts, sample_seed=6)))
        assert (waves.replay(parts.wave_program(t, other, 64)).nodes != nodes).sum() > 100


def test_its_replay_draws_the_lights_the_shader_shaded(gl, arena):
    """One sample unweighted (SAMPLE_FAULT 1: the image is the drawn light's f): wherever it
    lit the pixel, the replay's drawn light affects it; another seed's draws miss ~200."""
    from app.model import waves
    from app.techniques import parts
    r, _ = arena
    t = get(NAME)
    opts = t.resolve_options({"light_samples": 1, "lights_per_leaf": 32})
    res = r.render(t, 0, opts, defines={"SAMPLE_FAULT": 1})
    lit = np.ascontiguousarray(res.image[::-1]).reshape(-1, 3).max(1) > 0
    hits = lambda o: waves.replay(parts.wave_program(t, waves.frame_data(r, res, o), 64)).contrib > 0
    assert lit.sum() > 300 and not (lit & ~hits(opts)).any()
    assert (lit & ~hits(opts.with_(sample_seed=99))).sum() > 50
