"""Two eyes (app.stereo): the eye and union cameras, both ways exact against brute in each
eye on builtin scenes and a hard case, the union mapping shown to matter, the refusals."""
import math

import numpy as np
import pytest

from app import stereo
from app.errors import UserError
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from cpu_prep import caps
from cpu_prep.camera import frame_camera
from scenes import load_scene
from scenes.model import Camera, make_lights
from tests.helpers import CAMERA, make_scene, random_lights

# techniques that share their structure (a culling one, a sampler's support), and tile ones
# that share their cull and sort
TECHNIQUES = ("clustered", "hybrid", "sample-list", "tiled", "tree", "zbin")
CAP = next(n for n in caps.NAMES if n != caps.NONE and not caps.per_tile(n))


def centre(fov=60.0, size=(96, 64), near=0.1, far=200.0):
    return frame_camera(Camera((1.0, 2.0, 3.0), (4.0, 1.0, -20.0), fov_y_deg=fov, near=near, far=far),
                        *size)


@pytest.mark.parametrize("fov,size,sep", [(60.0, (96, 64), 0.064), (90.0, (64, 96), 0.3),
                                          (20.0, (160, 90), 2.0)])
def test_union_frustum_holds_both_eyes_near_plane_included(fov, size, sep):
    c = centre(fov, size)
    left, right = stereo.eye_cameras(c, sep)
    union = stereo.union_camera(c, sep)
    assert stereo.contains(union, left) and stereo.contains(union, right)
    for eye in (left, right):      # the eyes' near-plane corners, the plane included
        assert stereo.inside(union, stereo.frustum_corners(eye, far=eye.near)).all()
    # the centre camera holds neither eye, and a union whose near plane lies past the
    # eyes' does not hold their near plane: the check can fail
    assert not stereo.contains(c, left) and not stereo.contains(c, right)
    d = stereo.pullback(c, sep) * (1 + stereo.UNION_MARGIN)
    late = stereo.moved(c, (0, 0, d), near=c.near + 1.01 * d, far=union.far)
    assert not stereo.contains(late, left)


def test_eyes_are_the_centre_moved_along_its_right_vector():
    c = centre()
    left, right = stereo.eye_cameras(c, 0.064)
    pos = lambda cam: np.linalg.inv(cam.view_from_world)[:3, 3]
    right_vec = c.view_from_world[0, :3]
    assert np.allclose(pos(right) - pos(left), 0.064 * right_vec, atol=1e-12)
    assert np.allclose((pos(right) + pos(left)) / 2, pos(c), atol=1e-12)
    for eye in (left, right):
        assert np.array_equal(eye.view_from_world[:3, :3], c.view_from_world[:3, :3])
        assert np.array_equal(eye.clip_from_view, c.clip_from_view)
    union = stereo.union_camera(c, 0.064)
    back = pos(c) - pos(union)        # along the forward axis, (sep/2)/tan(fov_x/2) and the margin
    assert np.allclose(back / np.linalg.norm(back), -c.view_from_world[2, :3])
    assert math.isclose(np.linalg.norm(back), 0.032 / c.tan_half_x * (1 + stereo.UNION_MARGIN))


def _exact_both_ways(renderer, sep, techniques=TECHNIQUES):
    ref = stereo.reference(renderer, sep)
    assert all(ref.results[e].contrib_count.sum() > 0 for e in stereo.EYES)
    for name in techniques:
        for way in stereo.WAYS:
            sf = stereo.render(renderer, REGISTRY[name], None, way, sep)
            assert stereo.mismatches(sf, ref) == {e: (0, 0) for e in stereo.EYES}, (name, way)
            assert {sf.results[e].meta["eye"] for e in stereo.EYES} == set(stereo.EYES)
    return ref


@pytest.mark.parametrize("scene", ["arena", "city"])
def test_both_ways_exact_per_eye_on_builtin_scenes(gl, scene):
    with Renderer(load_scene(scene, lights=1024, seed=3), (96, 54)) as r:
        _exact_both_ways(r, stereo.DEFAULT_SEPARATION)


def _hard_lights(sep):
    """A light between the eyes (both cameras inside it), lights across one eye's near plane
    only (one tiny, one reaching the floor), a light on the floor that only the left eye
    sees (between the two eyes' left frustum planes), and random lights around them."""
    c = frame_camera(CAMERA, 96, 64)
    inv = np.linalg.inv(c.view_from_world)
    world = lambda p: (inv @ np.r_[p, 1.0])[:3]
    h = sep / 2
    hard = make_lights(4)
    hard["color"], hard["intensity"] = 1.0, 3.0
    hard["position"][0], hard["radius"][0] = world((0, 0, 0)), 8.0
    # the left eye's near plane, left of the right eye's near-plane rectangle
    x_near = -h - 0.9 * c.near * c.tan_half_x
    hard["position"][1], hard["radius"][1] = world((x_near, 0, -c.near)), 0.02
    hard["position"][2], hard["radius"][2] = world((-h - 2.0, 0, -c.near)), 3.5
    # on the floor (world y = 0.02) at depth 6, midway between the eyes' left planes
    z = 6.0
    x = -z * c.tan_half_x
    y0, y1 = world((x, 0, -z))[1], world((x, 1, -z))[1]
    hard["position"][3] = world((x, (0.02 - y0) / (y1 - y0), -z))
    hard["radius"][3] = 0.4 * h
    rng = np.random.default_rng(5)
    return np.concatenate([hard, random_lights(rng, 400, (-20, 0, -40), (20, 6, 10), (0.2, 3.0))])


def test_both_ways_exact_per_eye_on_the_hard_case(gl):
    sep = 0.6
    lights = _hard_lights(sep)
    lit = {}
    for k in (0, 3):        # the light between the eyes lights both; the one-eye light the left
        with Renderer(make_scene(lights[k:k + 1]), (96, 64)) as r:
            one = stereo.reference(r, sep)
            lit[k] = {e: int((one.results[e].contrib_count > 0).sum()) for e in stereo.EYES}
    assert lit[0]["left"] > 0 and lit[0]["right"] > 0, lit
    assert lit[3]["left"] > 0 and lit[3]["right"] == 0, lit
    with Renderer(make_scene(lights), (96, 64)) as r:
        _exact_both_ways(r, sep)


def test_the_union_mapping_is_needed(gl, monkeypatch):
    """Each eye's pixels read the union camera's cells through its offset: without the
    offset (the union's cells looked up as if the eye were the union camera) they miss lights."""
    sep = 1.0
    with Renderer(make_scene(_hard_lights(sep)), (96, 64)) as r:
        ref = stereo.reference(r, sep)
        monkeypatch.setattr(stereo, "offset_into", lambda outer, inner: (0.0, 0.0, 0.0))
        sf = stereo.render(r, REGISTRY["clustered"], None, "union", sep)
        assert sum(c + h for c, h in stereo.mismatches(sf, ref).values()) > 0


@pytest.mark.parametrize("name,values", [("clustered", {"scalarize": True}),
                                         ("clustered", {"duplicated": True}),
                                         ("clustered", {"feature_variants": True}),
                                         ("hybrid", {"feature_variants": True, "duplicated": True})])
def test_the_shared_structure_is_exact_with_its_options(gl, name, values):
    """The scalarized walk, duplicated light copies (packed per eye), and the feature
    variants (their classification and per-mask dispatches map pixels as the shading does)."""
    sep = 0.6
    with Renderer(make_scene(_hard_lights(sep)), (96, 64)) as r:
        ref = stereo.reference(r, sep)
        t = REGISTRY[name]
        sf = stereo.render(r, t, t.Options.make(values, t.name), "union", sep)
        assert stereo.mismatches(sf, ref) == {e: (0, 0) for e in stereo.EYES}, values


def test_the_shared_structure_outlives_later_renders(gl):
    """Renders after a union frame reuse the renderer's arena (a check's references, another
    technique): the shared build keeps its own, so its eyes render again exactly."""
    sep = 0.6
    with Renderer(make_scene(_hard_lights(sep)), (96, 64)) as r:
        ref = stereo.reference(r, sep)
        sf = stereo.render(r, REGISTRY["clustered"], None, "union", sep)
        stereo.render(r, REGISTRY["tree"], None, "per-view", 2.0)
        for e in stereo.EYES:
            t, kw = sf.renders[e]
            again = r.render(t, **kw)
            assert (again.contrib_count == ref.results[e].contrib_count).all(), e
            assert (again.contrib_hash == ref.results[e].contrib_hash).all(), e


def test_union_shares_what_the_declaration_says(gl):
    with Renderer(load_scene("arena", lights=1024, seed=3), (96, 54)) as r:
        per = stereo.render(r, REGISTRY["clustered"], None, "per-view", 0.064)
        one = stereo.render(r, REGISTRY["clustered"], None, "union", 0.064)
        tiles = stereo.render(r, REGISTRY["tree"], None, "union", 0.064)
    assert one.share == stereo.STRUCTURE and tiles.share == stereo.CULL_SORT
    assert one.entries() < per.entries()           # one grid's lists, not two
    assert set(one.shared_ms[0]) >= {"cull", "sort", "bin"}
    assert set(tiles.shared_ms[0]) == {"cull", "sort"}
    for e in stereo.EYES:                          # per eye: the records, or the rest of the build
        assert set(one.results[e].meta["cpu_ms"]) == {"pack", "upload"}
        assert "cull" not in tiles.results[e].meta["cpu_ms"]
        assert one.results[e].meta["share"] == stereo.STRUCTURE


@pytest.mark.parametrize("values,needle", [({"build": "gpu"}, "--build gpu"),
                                           ({"cap_policy": CAP}, "--cap-policy"),
                                           ({"stochastic": 4}, "--stochastic")])
def test_union_refuses_what_it_cannot_share_in_one_line(values, needle):
    t = REGISTRY["clustered"]
    opts = t.Options.make(values, t.name)
    why = stereo.refusal(t, opts, "union")
    assert needle in why and "\n" not in why
    assert stereo.refusal(t, opts, "per-view") is None
    with pytest.raises(UserError):
        stereo.refuse(t, opts, "union")


def test_separation_and_way_are_checked():
    for bad in (0.0, -0.1, float("nan"), 11.0):
        with pytest.raises(UserError):
            stereo.check_separation(bad)
    assert "per-view" in stereo.refusal(REGISTRY["clustered"], None, "both")
