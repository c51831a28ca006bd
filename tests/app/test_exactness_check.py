"""app.exactness: when a technique is not exact, the check names the first differing pixel
and the lights that differ there, and writes the technique's, the reference's and a
difference image (as Mitsuba's render tests do)."""
import numpy as np
from PIL import Image

from app.exactness import check
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from app.techniques.base import Technique, prepare, shading_passes
from tests.helpers import make_scene, random_lights

SKIP_SOME = """#version 430
// brute, but it skips the light whose id is a multiple of 5 (a deliberately wrong technique)
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
void main() {
    PixelState s = load_pixel();
    if (s.shading)
        for (uint i = 0u; i < u_light_count; ++i)
            if (lights[i].id_type.x % 5u != 0u) evaluate_light(s, lights[i]);
    store_pixel(s);
    write_wave_stats(s.evaluated, 1u);
}
"""


class Lossy(Technique):
    name = "lossy"
    glsl = {"lossy.comp": SKIP_SOME}

    def build(self, frame, opts):
        return prepare(frame)

    def passes(self, build, opts):
        return shading_passes(build, "lossy.comp", longest=len(build.lights))


def test_a_wrong_technique_is_explained(gl, rng, tmp_path):
    lights = random_lights(rng, 80, (-10, 0, -30), (10, 6, 5), radius=(1.0, 8.0))
    with Renderer(make_scene(lights, size=(40, 24))) as r:
        ref = r.render(REGISTRY["brute"])
        bad = r.render(Lossy())
        assert check(ref, ref) is None
        m = check(bad, ref, r, Lossy(), REGISTRY["brute"], {}, tmp_path)
        x, row = m.first
        debug = r.render(REGISTRY["brute"], debug_pixel=(x, row), readback=False).debug_lights
    assert m is not None and m.pixels > 0
    assert m.missing and all(i % 5 == 0 for i in m.missing) and not m.extra
    # the ids are the ones brute itself finds at that pixel, and the counts tell the same
    assert set(m.missing) <= set(debug.tolist()) and len(debug) == m.count[1]
    assert m.count[0] == m.count[1] - len(m.missing)
    text = m.message()
    assert f"x={x}, row={row}" in text and "missing lights" in text and "\n" not in text
    diff = np.asarray(Image.open(m.images["difference"]).convert("RGB"))
    assert {"lossy", "brute", "difference"} == set(m.images)
    assert (diff == (255, 40, 40)).all(2).any() and (diff == (255, 230, 0)).all(2).any()


def test_the_suites_assert_names_the_lights(gl, rng):
    """tests.helpers.assert_exact, as every exactness test uses it, carries the explanation."""
    import pytest
    from tests.helpers import assert_exact, registered, render_all
    with registered(Lossy()):
        res = render_all(make_scene(random_lights(rng, 60, (-10, 0, -30), (10, 6, 5),
                                                  radius=(1.0, 8.0)), size=(32, 20)),
                         techniques=["brute", "lossy"])
    with pytest.raises(AssertionError, match=r"lossy differs from brute .* missing lights \[") as e:
        assert_exact(res, "lossy case")
    assert "test-artifacts" in str(e.value)
