"""Light shapes: point, spot, capsule and box, each with its one affects() test,
in every technique.  brute against a float64 oracle of the light model; every technique
against brute on random mixes, with the eye inside capsules and boxes, shapes through the
near plane, boxes on tile edges, capsules of length 0 and spots of inner 0 / outer 90."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.pipeline import features
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT, LIGHT_TYPES, Camera
from tests.helpers import CAMERA, affects64, assert_exact, assume_lit, make_scene, pixel_oracle, random_shapes, render_all, render_on



def test_brute_matches_the_float64_light_model_for_every_shape(gl):
    rng = np.random.default_rng(11)
    lights = random_shapes(rng, 240, (-14, -1, -34), (14, 7, 6))
    with Renderer(make_scene(lights, size=(96, 64))) as r:
        res = r.render(REGISTRY["brute"])
        count, hashes, near, inside = pixel_oracle(r, lights)
    ok = ~near
    assert ok.mean() > 0.8
    assert np.array_equal(res.contrib_count[ok], count[ok])
    assert np.array_equal(res.contrib_hash[ok], hashes[ok])
    for t in (LIGHT_SPOT, LIGHT_CAPSULE, LIGHT_BOX):     # every shape lights something
        assert inside[:, lights["type"] == t].sum() > 50, LIGHT_TYPES[t]


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31), n=st.integers(1, 400), tile=st.sampled_from([8, 16, 33]),
       w=st.integers(1, 100), h=st.integers(1, 70))
def test_random_shape_mixes_are_exact(gl, seed, n, tile, w, h):
    rng = np.random.default_rng(seed)
    lights = random_shapes(rng, n, (-20, -2, -40), (20, 9, 9))
    results = render_all(make_scene(lights, size=(w, h)), dict(tile=tile))
    assert_exact(results, f"seed {seed}")
    assume_lit(results)


def _around(center, rng, n, kind, **kw):
    """n lights of one shape centred within a metre of `center`."""
    L = random_shapes(rng, n, np.asarray(center) - 1.0, np.asarray(center) + 1.0,
                      shares=[float(i == kind) for i in range(4)], **kw)
    return L


@pytest.mark.parametrize("kind", [LIGHT_CAPSULE, LIGHT_BOX])
def test_eye_inside_and_shapes_across_the_near_plane(gl, kind):
    """Shapes around the eye (which sits inside each of them) and crossing the near plane,
    plus shapes on the floor: every technique exact, brute against the oracle."""
    rng = np.random.default_rng(kind)
    eye = np.array(CAMERA.position)
    L = _around(eye, rng, 40, kind, radius=(2.0, 6.0), length=(1.0, 8.0), extent=(2.0, 6.0))
    near = _around(eye + np.array([0.0, -0.5, -0.1]), rng, 40, kind, radius=(0.05, 0.3),
                   length=(0.0, 1.0), extent=(0.02, 0.3))
    floor = random_shapes(rng, 120, (-10, -1, -30), (10, 1, 5),
                          shares=[float(i == kind) for i in range(4)])
    lights = np.concatenate([L, near, floor])
    scene = make_scene(lights, size=(64, 40))
    with Renderer(scene) as r:
        res = render_on(r)
        count, hashes, nb, _ = pixel_oracle(r, lights)
    assert_exact(res, f"{LIGHT_TYPES[kind]} around the eye")
    ok = ~nb
    assert np.array_equal(res["brute"].contrib_count[ok], count[ok])
    from cpu_prep.camera import look_at
    at_eye, _ = affects64(np.zeros((1, 3)), lights, look_at(CAMERA.position, CAMERA.target, CAMERA.up))
    assert at_eye.sum() >= 20, "the case must hold the eye inside many shapes"
    assert res["brute"].contrib_count.sum() > 1000


def test_boxes_exactly_on_tile_edges(gl):
    """Axis-aligned boxes whose faces project onto the tile grid's edges (view along -z,
    boxes facing the camera): a box face on x = k * tile pixels."""
    from cpu_prep.camera import frame_camera
    cam = Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), near=0.1, far=300.0)
    size, tile, depth = (96, 64), 16, 20.0
    fc = frame_camera(cam, *size)
    from scenes.geometry import box_mesh
    wall = box_mesh((-1e3, -1e3, -depth - 1.0), (1e3, 1e3, -depth))
    rng = np.random.default_rng(5)
    L = random_shapes(rng, 24, (-1, -1, -depth), (1, 1, -depth), shares=(0, 0, 0, 1))
    xs = [(2.0 * k * tile / size[0] - 1.0) * fc.tan_half_x * depth for k in range(1, size[0] // tile)]
    for i in range(len(L)):
        x_edge = xs[i % len(xs)]
        half = rng.uniform(0.2, 2.0)
        L["position"][i] = (x_edge + half * (1 if i % 2 else -1), rng.uniform(-3, 3), -depth)
        L["direction"][i] = (0.0, 0.0, -1.0)              # along the view axis
        L["up"][i] = (0.0, 1.0, 0.0)                      # right = +-x
        L["extent"][i] = (half, rng.uniform(0.5, 3), 0.5)
    scene = make_scene(L, meshes=[wall], size=size, camera=cam)
    res = render_all(scene, dict(tile=tile))
    assert_exact(res, "boxes on tile edges")
    assert res["brute"].contrib_count.sum() > 500


def test_specialised_programs_compile_only_the_shapes_present():
    cap = features.features_glsl(("capsule",))
    assert "capsule_contains" in cap and "box_" not in cap and "spot_" not in cap
    assert "id_type.y" not in cap
    every = features.features_glsl(LIGHT_TYPES)
    assert all(f"LIGHT_{t.upper()}" in every for t in LIGHT_TYPES[:-1])


def test_specialised_program_renders_like_the_general_one(gl, monkeypatch):
    rng = np.random.default_rng(3)
    lights = random_shapes(rng, 200, (-14, -1, -34), (14, 7, 6), shares=(0, 0, 1, 1))
    with Renderer(make_scene(lights, size=(64, 40))) as r:
        special = r.render(REGISTRY["clustered"])
        assert special.meta["features"] == ["capsule", "box"]
        monkeypatch.setattr(features, "feature_set", lambda types, specular=False: LIGHT_TYPES)
        general = r.render(REGISTRY["clustered"])
    assert general.meta["features"] == list(LIGHT_TYPES)
    assert np.array_equal(general.contrib_hash, special.contrib_hash)
    assert np.allclose(general.image, special.image, rtol=1e-5, atol=1e-7)
    assert special.contrib_count.sum() > 0
