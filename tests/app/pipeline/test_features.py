"""Simulate only the effects a scene calls for: a point-only scene's program has no spot
code and renders identically to the general program."""
import numpy as np

from app.pipeline import features
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.helpers import make_scene, random_lights


def test_point_only_source_has_no_cone_test():
    point = features.features_glsl(("point",))
    general = features.features_glsl(("point", "spot"))
    assert "spot" not in point and "cos_outer" not in point
    assert "spot_cone_contains" in general and "type == LIGHT_POINT" in general
    assert "type ==" not in features.features_glsl(("spot",))   # spots only: no type test
    assert "#define HAS_SPOT 0" in point and "#define HAS_SPOT 1" in general


def test_feature_set_follows_visible_types():
    assert features.feature_set(np.array([0, 0], np.uint8)) == ("point",)
    assert features.feature_set(np.array([1], np.uint8)) == ("spot",)
    assert features.feature_set(np.array([1, 0], np.uint8)) == ("point", "spot")


def test_point_only_program_renders_like_the_general_one(gl, rng, monkeypatch):
    lights = random_lights(rng, 300, (-20, 0, -40), (20, 5, 5), spot_share=0.0)
    scene = make_scene(lights)
    with Renderer(scene) as r:
        special = r.render(REGISTRY["hybrid"])
        text = r.programs.sources
        assert special.meta["features"] == ["point"]
        assert not any("spot_cone_contains" in t for t in text.values())
        # the general program: both light types compiled in for the same lights
        monkeypatch.setattr(features, "feature_set", lambda types, specular=False: ("point", "spot"))
        general = r.render(REGISTRY["hybrid"])
        assert general.meta["features"] == ["point", "spot"]
        assert np.array_equal(general.contrib_hash, special.contrib_hash)
        assert np.array_equal(general.contrib_count, special.contrib_count)
        assert np.allclose(general.image, special.image, rtol=1e-5, atol=1e-7)
        assert special.contrib_count.sum() > 0


def test_specular_code_only_where_a_material_has_it():
    assert "#define SPECULAR 0" in features.features_glsl(("point",))
    assert "#define SPECULAR 1" in features.features_glsl(("point", features.SPECULAR))
    assert features.feature_set(np.array([0], np.uint8), specular=True) == ("point", "specular")


def test_matte_scene_renders_alike_with_and_without_specular_code(gl, rng, monkeypatch):
    lights = random_lights(rng, 200, (-20, 0, -40), (20, 5, 5))
    with Renderer(make_scene(lights, size=(64, 40))) as r:
        matte = r.render(REGISTRY["clustered"])
        assert "specular" not in matte.meta["features"]
        real = features.feature_set
        monkeypatch.setattr(features, "feature_set", lambda t, s=False: real(t, True))
        general = r.render(REGISTRY["clustered"])
        assert "specular" in general.meta["features"]
    assert np.array_equal(general.image, matte.image)
    assert matte.contrib_count.sum() > 0


def test_glossy_surfaces_add_highlights_not_lights(gl, rng):
    """The same scene, its surfaces matte and then glossy: identical light sets per pixel
    (materials change shading, never culling), brighter highlights where glossy."""
    from tests.helpers import floor_and_boxes
    lights = random_lights(rng, 200, (-20, 0, -40), (20, 5, 5))
    out = {}
    for rough in (0.0, 0.3):
        meshes = floor_and_boxes()
        for m in meshes:
            m.roughness, m.metallic = rough, 0.0
        with Renderer(make_scene(lights, meshes=meshes, size=(64, 40))) as r:
            out[rough] = r.render(REGISTRY["brute"])
    a, b = out[0.0], out[0.3]
    assert "specular" in b.meta["features"] and "specular" not in a.meta["features"]
    assert np.array_equal(a.contrib_hash, b.contrib_hash)
    assert np.abs(b.image - a.image).max() > 1e-3
