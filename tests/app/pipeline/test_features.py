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
    assert "spot_cone_contains" in general and "id_type.y" in general
    assert "id_type.y" not in features.features_glsl(("spot",))   # spots only: no type test


def test_feature_set_follows_visible_types():
    assert features.feature_set(np.array([0, 0], np.uint8)) == ("point",)
    assert features.feature_set(np.array([1], np.uint8)) == ("spot",)
    assert features.feature_set(np.array([1, 0], np.uint8)) == ("point", "spot")


def test_point_only_program_renders_like_the_general_one(gl, rng, monkeypatch):
    lights = random_lights(rng, 300, (-20, 0, -40), (20, 5, 5), spot_share=0.0)
    scene = make_scene(lights)
    r = Renderer(scene)
    try:
        special = r.render(REGISTRY["hybrid"])
        text = r.programs.sources
        assert special.meta["features"] == ["point"]
        assert not any("spot_cone_contains" in t for t in text.values())
        # the general program: both light types compiled in for the same lights
        monkeypatch.setattr(features, "feature_set", lambda types: ("point", "spot"))
        general = r.render(REGISTRY["hybrid"])
        assert general.meta["features"] == ["point", "spot"]
        assert np.array_equal(general.contrib_hash, special.contrib_hash)
        assert np.array_equal(general.contrib_count, special.contrib_count)
        assert np.allclose(general.image, special.image, rtol=1e-5, atol=1e-7)
        assert special.contrib_count.sum() > 0
    finally:
        r.release()
