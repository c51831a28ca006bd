"""Draw features the raster technique added to the frame graph: a technique's own
depth (+ stencil) Target, scaled and multisampled; the greater_equal depth test; per-instance
stencil sequences (StencilStep); the driver's sample positions."""
from __future__ import annotations

import numpy as np
import pytest

from app.pipeline import features, gl as glmod
from app.pipeline.passes import Buffer, Draw, Pass, StencilStep, Target
from app.pipeline.renderer import Renderer
from scenes.model import make_lights
from tests.helpers import make_scene

VERT = """#version 430
// A rectangle over the whole target at window depth u_z; with u_thirds, step 0 of instance i
// covers the left (i + 1) thirds only.
uniform float u_z;
uniform int u_thirds;
uniform int u_instance;
uniform int u_step;
flat out int v_instance;
const int corner[6] = int[6](0, 1, 2, 2, 1, 3);
void main() {
    int c = corner[gl_VertexID];                       // a rectangle of two triangles
    vec2 p = vec2(c & 1, c >> 1) * 2.0 - 1.0;
    int i = u_instance + gl_InstanceID;
    if (u_thirds == 1 && u_step == 0 && p.x > 0.0) p.x = -1.0 + 2.0 * float(i + 1) / 3.0;
    v_instance = i;
    gl_Position = vec4(p, 2.0 * u_z - 1.0, 1.0);
}
"""
FILL = """#version 430
// Depth 0.25 on the left half of the pixels, 0.75 on the right (every sample of a pixel).
uniform ivec2 u_target;
void main() { gl_FragDepth = int(gl_FragCoord.x) < u_target.x / 2 ? 0.25 : 0.75; }
"""
PROBE = """#version 430
// Counts the fragments that pass (per instance, per step), ORs the sample masks, marks the
// pixels (an MSAA pixel on the rectangle's diagonal is shaded once per triangle).
layout(early_fragment_tests) in;
layout(std430, binding = B_HITS) buffer Hits { uint hits[]; };
uniform int u_step;
uniform ivec2 u_target;
flat in int v_instance;
void main() {
    atomicAdd(hits[v_instance * 2 + u_step], 1u);
    atomicOr(hits[16], uint(gl_SampleMaskIn[0]));
    atomicOr(hits[17 + int(gl_FragCoord.y) * u_target.x + int(gl_FragCoord.x)], 1u);
}
"""
VIRTUAL = {"t.vert": VERT, "t_fill.frag": FILL, "t_probe.frag": PROBE}


@pytest.fixture
def renderer(gl):
    with Renderer(make_scene(make_lights(0), size=(30, 20))) as r:
        yield r


def _run(r, target, draw_kw, z, thirds=0, instances=1):
    virtual = dict(features.virtual_files(("point",)), **VIRTUAL)
    size = (-(-30 // target.scale), -(-20 // target.scale))
    fill = Pass("fill", ("t.vert", "t_fill.frag"), timed=False,
                draw=Draw(count=6, target=target, depth_test="always", depth_write=True, clear=True),
                uniforms={"u_z": 0.5, "u_thirds": 0, "u_target": size, "u_instance": 0})
    probe = Pass("probe", ("t.vert", "t_probe.frag"), writes={"hits": Buffer((17 + 600) * 4, cleared=True)},
                 timed=False, draw=Draw(count=6, target=target, instances=instances, **draw_kw),
                 uniforms={"u_z": z, "u_thirds": thirds, "u_instance": 0, "u_step": 0,
                           "u_target": size})
    r.run([fill, probe], virtual)
    return r.read("hits").copy(), size


@pytest.mark.parametrize("scale,samples", [(1, 0), (2, 0), (2, 4), (1, 4)])
def test_own_target_keeps_what_a_pass_wrote(renderer, scale, samples):
    """A fill pass writes depth into the Target; a later pass tests against it: at window depth
    0.5, greater_equal passes where the fill wrote 0.25 (left half), less_equal on the right."""
    t = Target("t-depth", scale=scale, samples=samples)
    for test, half in (("greater_equal", "left"), ("less_equal", "right")):
        hits, (w, h) = _run(renderer, t, dict(depth_test=test), 0.5)
        passed = hits[17:17 + w * h].reshape(h, w) != 0
        expect = np.zeros((h, w), bool)
        expect[:, :w // 2] = True
        assert np.array_equal(passed, expect if half == "left" else ~expect), (test, scale, samples)
        assert hits[16] == (0b1111 if samples == 4 else 1)


def test_stencil_sequence_per_instance(renderer):
    """Per instance: step 0 sets the stencil (its own reference) over its third, step 1 (the
    whole target) passes only where step 0 of the same instance set it, then zeroes it."""
    t = Target("t-stencil", stencil=True)
    seq = (StencilStep(func="always", ops=("keep", "keep", "replace")),
           StencilStep(func="equal", ops=("keep", "keep", "zero")))
    hits, (w, h) = _run(renderer, t, dict(stencil=seq), 0.5, thirds=1, instances=3)
    for i in range(3):
        covered = sum(1 for x in range(w) if x + 0.5 < w * (i + 1) / 3) * h
        assert hits[2 * i] == covered                       # step 0 drew its third
        assert hits[2 * i + 1] == covered                   # step 1 passed exactly there


def test_sample_positions_one_per_quadrant(gl):
    pos = glmod.limits().sample_positions(4)
    assert len(pos) == 4 and all(0.0 <= a < 1.0 and 0.0 <= b < 1.0 for a, b in pos)
    assert len({(int(a * 2), int(b * 2)) for a, b in pos}) == 4


def test_frame_input_carries_the_renderers_limits(gl):
    scene = make_scene(make_lights(0), size=(8, 8))
    with Renderer(scene) as r:
        fin = r.frame_input(0, 1)
    assert fin.limits is r.limits and fin.limits.sample_positions(4) == r.limits.sample_positions(4)
