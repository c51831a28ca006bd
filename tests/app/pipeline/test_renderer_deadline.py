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


class FakeClock:
    """renderer.time's stand-in: time moves only when the test moves it."""

    def __init__(self):
        self.now = 1000.0

    def perf_counter(self):
        return self.now


def test_compiles_and_the_build_are_not_counted(gl, monkeypatch):
    """A cold renderer's first frame of fptl (three passes, each building its program: a
    deadline check between them) meets a deadline 1 s away on a clock on which its CPU
    build and each program it compiles take 100 s: they are held back, so the frame is whole."""
    t = REGISTRY["fptl"]
    clock = FakeClock()
    monkeypatch.setattr(renderer_module, "time", clock)
    build = t.build

    def slow_build(*args, **kw):
        clock.now += 100.0
        return build(*args, **kw)
    monkeypatch.setattr(t, "build", slow_build)
    with Renderer(scene()) as r:
        for kind in ("compute", "program"):
            made = getattr(r.programs, kind)

            def slow_compile(*args, made=made, **kw):
                before = len(r.programs.sources)
                out = made(*args, **kw)
                clock.now += 100.0 * (len(r.programs.sources) > before)
                return out
            monkeypatch.setattr(r.programs, kind, slow_compile)
        start = clock.now
        res = r.render(t, deadline=start + 1.0)
    assert clock.now - start >= 400.0              # the build and the three passes' compiles
    assert res.meta["gpu_ms"] and (res.contrib_count > 0).any()
