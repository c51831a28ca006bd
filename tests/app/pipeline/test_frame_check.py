"""The frame graph is checked before its first dispatch (app/pipeline/validate.py): a pass
that sets a uniform its shaders never declare, reads a buffer nothing provided, or is a bad
step (its groups, its draw, its dispatch windows) fails in one line naming the technique,
the pass and the name, and no step of the list has run.  A uniform that a define leaves
unused (the driver drops it) is no error."""
from __future__ import annotations

import pytest

from app.pipeline.passes import Buffer, Draw, HostStep, Pass
from app.pipeline.renderer import Renderer
from app.pipeline.validate import GraphError, declarator_names
from cpu_prep.limits import WINDOW_ALL
from scenes.model import make_lights
from tests.helpers import make_scene

MARK = """#version 430
// define: USE_EXTRA
layout(local_size_x = 1) in;
layout(std430, binding = B_MARKER) buffer Marker { uint marker[]; };
uniform uint u_value;
uniform uvec2 u_window;
#if USE_EXTRA
uniform uint u_extra;            // declared, and dropped by the driver when USE_EXTRA is 0
#endif
void main() {
    marker[0] = u_value;
#if USE_EXTRA
    marker[1] = u_extra;
#endif
}
"""
VIRTUAL = {"mark.comp": MARK}


def mark(name="mark", uniforms=None, reads=(), groups=(1, 1, 1), extra=0) -> Pass:
    """A pass that writes u_value to marker[0] (and u_extra to marker[1] with USE_EXTRA)."""
    return Pass(name, "mark.comp", reads=reads, writes={"marker": Buffer(16, cleared=True)},
                groups=groups, defines={"USE_EXTRA": extra},
                uniforms=dict({"u_value": 7}, **(uniforms or {})))


@pytest.fixture
def renderer(gl):
    with Renderer(make_scene(make_lights(0), size=(8, 8))) as r:
        yield r


def fails_before_dispatch(renderer, bad, match: str) -> str:
    """Run [a good pass, bad]: the check refuses the list in one line, nothing ran."""
    with pytest.raises(GraphError, match=match) as e:
        renderer.run([mark("first"), bad], VIRTUAL, technique="probe")
    assert "\n" not in str(e.value) and "technique 'probe'" in str(e.value)
    assert "marker" not in renderer.provided() and "marker" not in renderer.buffers
    return str(e.value)


def test_unknown_uniform_is_an_error_before_any_dispatch(renderer):
    msg = fails_before_dispatch(renderer, mark("second", {"u_valeu": 3}),
                                r"pass 'second' sets uniform 'u_valeu', which none of its shaders \(mark\.comp\) declares")
    assert "closest: 'u_value'" in msg


def test_uniform_a_define_leaves_unused_is_no_error(renderer):
    renderer.run([mark(uniforms={"u_extra": 5}, extra=0)], VIRTUAL, technique="probe")
    assert list(renderer.read("marker")[:2]) == [7, 0]
    renderer.run([mark(uniforms={"u_extra": 5}, extra=1)], VIRTUAL, technique="probe")
    assert list(renderer.read("marker")[:2]) == [7, 5]


def test_missing_buffer_is_an_error_before_any_dispatch(renderer):
    fails_before_dispatch(renderer, mark("second", reads=("nowhere",)),
                          r"pass 'second' reads buffer 'nowhere', which nothing in this frame provides")


@pytest.mark.parametrize("bad, match", [
    (mark("second", groups=(-1, 1, 1)), r"pass 'second': groups x = -1 is outside 0\.\.\d+"),
    (mark("second", groups=(1.5, 1, 1)), r"pass 'second': groups \(1\.5, 1, 1\) is not three whole"),
    ({"name": "second"}, r"step 1 is a dict, not a Pass or a HostStep"),
    (Pass("second", ("a.vert", "a.frag"), draw=Draw(mode="quads")),
     r"pass 'second': mode 'quads' is not one of triangles, triangle_strip"),
    (Pass("second", ("a.vert", "a.frag"), draw=Draw(target="screen")),
     r"pass 'second': target 'screen' is not one of gbuffer"),
    (Pass("second", "mark.comp", groups=(1, 1)), r"pass 'second': groups \(1, 1\) is not three"),
])
def test_bad_step_is_an_error_before_any_dispatch(renderer, bad, match):
    fails_before_dispatch(renderer, bad, match)


@pytest.mark.parametrize("windows, match", [
    ([(0, 100), (200, WINDOW_ALL)], r"dispatch window \[200, \d+\) should start at light 100"),
    ([(0, 100)], r"dispatch windows stop at light 100"),
    ([(50, WINDOW_ALL)], r"dispatch window \[50, \d+\) should start at light 0"),
])
def test_dispatch_windows_must_cover_every_light(renderer, windows, match):
    steps = [mark("shade", {"u_window": w}) for w in windows]
    with pytest.raises(GraphError, match=r"technique 'probe', pass 'shade'.*" + match):
        renderer.run(steps, VIRTUAL, technique="probe")
    assert "marker" not in renderer.buffers


def test_windows_that_tile_the_sequence_run(renderer):
    """Each sequence starts at 0 once the last one reached WINDOW_ALL (a band per sequence)."""
    steps = [mark("shade", {"u_window": w}) for w in [(0, 100), (100, 300), (300, WINDOW_ALL)]]
    renderer.run(steps + steps, VIRTUAL, technique="probe")
    assert renderer.read("marker")[0] == 7


def test_steps_a_host_step_returns_are_checked_before_they_run(renderer):
    later = HostStep("plan", (), lambda got: ({}, [mark("late", reads=("nowhere",))]))
    with pytest.raises(GraphError, match=r"technique 'probe', pass 'late' reads buffer 'nowhere'"):
        renderer.run([later], VIRTUAL, technique="probe")
    assert "marker" not in renderer.buffers


def test_declarator_names():
    assert declarator_names("vec3 u_a, u_b[4]") == ["u_a", "u_b"]
    assert declarator_names("highp float u_c = 1.0") == ["u_c"]
    assert declarator_names("sampler2D g_albedo") == ["g_albedo"]


def test_draw_modes_are_moderngls():
    """passes.py names the GL enums itself, so the CPU stage's users load no moderngl."""
    import moderngl
    from app.pipeline.passes import DRAW_MODES
    assert DRAW_MODES == {"triangles": moderngl.TRIANGLES, "triangle_strip": moderngl.TRIANGLE_STRIP}
