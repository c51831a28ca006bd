"""brute against a float64 numpy oracle: per-pixel count and hash equal away from
light-volume boundaries; the dump arrays' orientation (row 0 = top)."""
import numpy as np
import pytest

from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.helpers import make_scene, pixel_oracle, random_lights


@pytest.mark.parametrize("size", [(96, 64), (1, 1), (333, 217)])
def test_brute_matches_float64_oracle(gl, rng, size):
    lights = random_lights(rng, 150, (-15, -1, -35), (15, 6, 8), radius=(0.5, 8.0))
    scene = make_scene(lights, size=size)
    with Renderer(scene) as r:
        res = r.render(REGISTRY["brute"])
        count, hashes, near, _ = pixel_oracle(r, lights, scene.camera)
    ok = ~near
    assert res.contrib_count.shape == (size[1], size[0])
    assert np.array_equal(res.contrib_count[ok], count[ok])
    assert np.array_equal(res.contrib_hash[ok], hashes[ok])
    if size != (1, 1):
        assert count.sum() > 100 and ok.mean() > 0.9


def test_image_rows_start_at_the_top(gl, rng):
    """The floor is at the bottom of the image, the sky (depth 0) at the top."""
    scene = make_scene(random_lights(rng, 10, (-5, 0, -10), (5, 2, 0)), size=(64, 48))
    with Renderer(scene) as r:
        res = r.render(REGISTRY["brute"])
    assert (res.depth[-1] > 0).all() and (res.depth[0] == 0).any()
