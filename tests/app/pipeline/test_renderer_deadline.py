"""Renderer.render(deadline=): the frame stops between two of its passes once the deadline
has passed (FrameTimeout, one line naming the technique), the CPU build and the passes that
compiled not counted; the renderer renders the next frame as a fresh one would."""
import time as real_time

import numpy as np
import pytest

from app.errors import FrameTimeout
from app.pipeline import renderer as renderer_module
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.helpers import make_scene, random_lights


def scene():
    return make_scene(random_lights(np.random.default_rng(3), 48, (-8, 0, -30), (8, 5, -2)), size=(48, 32))


def outputs(result):
    return result.image, result.evaluated, result.contrib_hash


class JumpingClock:
    """renderer.time's stand-in: the real clock, plus `jump` s after each counted pass."""

    def __init__(self, jump):
        self.offset, self.jump = 0.0, jump

    def perf_counter(self):
        return real_time.perf_counter() + self.offset


def test_a_deadline_already_past_stops_before_the_first_pass_and_the_next_frame_is_whole(gl):
    t = REGISTRY["clustered"]
    with Renderer(scene()) as fresh:
        want = outputs(fresh.render(t))
    with Renderer(scene()) as r:
        with pytest.raises(FrameTimeout, match=r"^clustered: frame stopped at its deadline after .* s of its passes"):
            r.render(t, deadline=real_time.perf_counter() - 1.0)
        got = outputs(r.render(t))
    for a, b in zip(want, got):
        np.testing.assert_array_equal(a, b)


def test_a_frame_over_its_deadline_stops_between_passes_and_the_renderer_stays_usable(gl, monkeypatch):
    t = REGISTRY["fptl"]                              # three passes: light_aabb, fptl_lists, shade
    with Renderer(scene()) as fresh:
        want = outputs(fresh.render(t))
    with Renderer(scene()) as r:
        r.render(t)                                   # compiles: the timed-out frame is a warm one
        clock = JumpingClock(100.0)
        monkeypatch.setattr(renderer_module, "time", clock)
        passes = []
        run_pass = r._run_pass

        def slow_pass(p, *args, **kw):
            run_pass(p, *args, **kw)
            if kw.get("record", True):
                passes.append(p.name)
                clock.offset += clock.jump            # each of the technique's passes: 100 s
        monkeypatch.setattr(r, "_run_pass", slow_pass)
        with pytest.raises(FrameTimeout, match=r"^fptl: .* after 2\d\d\.\d s of its passes .*before 'shade'$"):
            r.render(t, deadline=clock.perf_counter() + 150.0)
        assert passes == ["light_aabb", "fptl_lists"]   # stopped before shade, not inside one after the second, not inside one
        monkeypatch.undo()
        got = outputs(r.render(t))
        r.run([])                                     # the window's own passes: no stale deadline
    for a, b in zip(want, got):
        np.testing.assert_array_equal(a, b)


def test_compiles_and_the_build_are_not_counted(gl):
    """A cold renderer's first frame (its one technique pass builds its program) meets a
    deadline 1 ms away: the frame input, G-buffer, CPU build and the compiling pass, which
    take longer, are held back."""
    t = REGISTRY["clustered"]
    with Renderer(scene()) as r:
        start = real_time.perf_counter()
        r.render(t, deadline=start + 1e-3)
        assert real_time.perf_counter() - start > 3e-3
