"""sample-list: S draws a shading pixel from its cluster list, reproducible per seed and
frame, its support exact against brute (test_exactness and test_hard_cases hold that for
every technique) and unbiased (tests/app/test_sampling_check.py)."""
import numpy as np
import pytest

from app.pipeline.renderer import Renderer
from app.techniques import get
from cpu_prep import sampling
from scenes import load_scene


@pytest.fixture(scope="module")
def city():
    scene = load_scene("city", lights=1024, seed=1)
    scene.resolution = (96, 64)
    with Renderer(scene) as r:
        yield r


def _render(r, **opts):
    t = get("sample-list")
    return r.render(t, 0, t.resolve_options(opts))


def test_a_seed_and_frame_reproduce_the_frame_bit_for_bit(gl, city):
    a, b = _render(city, sample_seed=7), _render(city, sample_seed=7)
    assert np.array_equal(a.image, b.image)
    other = _render(city, sample_seed=8)
    later = _render(city, sample_seed=7, sample_frame=1)
    assert not np.array_equal(a.image, other.image) and not np.array_equal(a.image, later.image)
    # the draw changes, the support does not
    assert np.array_equal(a.contrib_hash, other.contrib_hash)


@pytest.mark.parametrize("samples", [1, 5, 64])
def test_each_shading_pixel_evaluates_its_samples(gl, city, samples):
    """S evaluations where the pixel's cell lists a light, none elsewhere."""
    res = _render(city, light_samples=samples)
    counts = res.build.buffers["ranges"]["offset_count"][:, 1]
    shading = res.depth > 0
    listed = shading & (counts[res.cell] > 0)
    assert listed.mean() > 0.5
    assert (res.evaluated[listed] == samples).all()
    assert res.evaluated[~listed].max(initial=0) == 0


def test_its_cdf_words_end_every_list_at_the_total(gl, city):
    res = _render(city)
    r = res.build.buffers["ranges"]["offset_count"].astype(np.int64)
    full = r[:, 1] > 0
    cdf = res.build.buffers["sample_cdf"]
    assert (cdf[r[full, 0] + r[full, 1] - 1] == sampling.MASS_TOTAL).all()
