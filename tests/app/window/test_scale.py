"""Dynamic resolution's controller (app.window.scale.DynamicScale) on a fake clock: each frame
takes what a model frame of `fixed + per_pixel * scale^2` seconds would, no wall clock."""
from __future__ import annotations

import pytest

from app.window.hud import scale_text
from app.window.scale import MIN_SCALE, STEP, DynamicScale, scaled_size, snap_down


class FakeClock:
    def __init__(self):
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def fly(ctl, clock, moving, full_s, fixed_s=0.0):
    """One frame per entry of `moving`: its scale from the controller, then the clock
    advanced by what that frame costs; the scales, in order."""
    out = []
    for m in moving:
        s = ctl.next(m)
        out.append(s)
        clock.t += fixed_s + (full_s - fixed_s) * s * s
    return out


def test_rest_is_full_size_and_moving_holds_the_target():
    clock = FakeClock()
    ctl = DynamicScale(10.0, clock=clock)
    # a full-size frame of 300 ms (30 ms of it fixed, CPU build and UI): three at rest,
    # then flying
    scales = fly(ctl, clock, [False] * 3 + [True] * 12 + [False], full_s=0.3, fixed_s=0.03)
    assert scales[:3] == [1.0] * 3
    moving = scales[3:-1]
    # the first moving frame already scales down, from the full-size frames' times
    assert moving[0] < 1.0
    assert all(s == pytest.approx(round(s / STEP) * STEP) and MIN_SCALE <= s < 1 for s in moving)
    settled = moving[-4:]
    assert len(set(settled)) == 1                              # it settles, no flicker
    s = settled[0]
    frame_s = 0.03 + 0.27 * s * s
    assert frame_s <= 0.1 + 1e-9                               # the target frame time held
    assert 0.03 + 0.27 * (s + STEP) ** 2 > 0.1 * 0.8           # and not far below it
    assert scales[-1] == 1.0                                   # the camera rests: full size at once


def test_a_fast_frame_stays_full_size_and_a_slow_one_stops_at_the_floor():
    clock = FakeClock()
    fast = DynamicScale(10.0, clock=clock)
    assert fly(fast, clock, [True] * 6, full_s=0.05) == [1.0] * 6
    clock = FakeClock()
    slow = DynamicScale(10.0, clock=clock)
    assert fly(slow, clock, [True] * 8, full_s=20.0)[-1] == MIN_SCALE


def test_the_scale_rises_again_when_frames_get_cheaper():
    clock = FakeClock()
    ctl = DynamicScale(10.0, clock=clock)
    low = fly(ctl, clock, [True] * 8, full_s=1.6)[-1]
    high = fly(ctl, clock, [True] * 12, full_s=0.2)[-1]
    assert low < high and 0.2 * high * high <= 0.1 + 1e-9


def test_a_noisy_clock_does_not_flicker():
    # frame times 15% over and under the model in turn: the scale settles on one step
    for full_s in (0.2, 0.3, 0.45, 0.7, 1.1):
        clock = FakeClock()
        ctl = DynamicScale(10.0, clock=clock)
        scales = []
        for k in range(40):
            s = ctl.next(True)
            scales.append(s)
            clock.t += full_s * s * s * (1.15 if k % 2 else 0.85)
        assert len(set(scales[10:])) == 1, (full_s, scales)


def test_skipped_frames_are_no_measure():
    clock = FakeClock()
    ctl = DynamicScale(10.0, clock=clock)
    ctl.next(False)
    clock.t += 30.0                  # a frame that compiled for half a minute
    ctl.skip()
    ctl.next(False)
    clock.t += 0.1                   # then a frame that meets the target at full size
    assert ctl.next(True) == 1.0


def test_excluded_work_is_not_the_frames():
    clock = FakeClock()
    ctl = DynamicScale(10.0, clock=clock)
    ctl.next(False)
    clock.t += 3.1                   # a frame of 0.1 s, and 3 s of the model's replay
    ctl.exclude(3.0)
    ctl.next(False)
    clock.t += 0.1
    assert ctl.next(True) == 1.0


def test_off_and_fixed():
    clock = FakeClock()
    off = DynamicScale(0.0, clock=clock)
    assert fly(off, clock, [True] * 4, full_s=5.0) == [1.0] * 4
    clock = FakeClock()
    fixed = DynamicScale(10.0, fixed=0.5, clock=clock)
    assert fly(fixed, clock, [True, True, False, True], full_s=5.0) == [0.5, 0.5, 1.0, 0.5]


def test_snap_and_sizes():
    assert snap_down(0.61) == 0.5625 and snap_down(0.1) == MIN_SCALE and snap_down(3.0) == 1.0
    assert scaled_size((960, 540), 0.5) == (480, 270) and scaled_size((960, 540), 1.0) == (960, 540)
    assert scaled_size((7, 3), MIN_SCALE) == (2, 1)


def test_hud_says_the_scale():
    f = {"scale": 0.5, "render_size": [480, 270], "target_fps": 10.0, "move_scale": None,
         "frame_ms": 98.0}
    assert scale_text(f) == "moving: scale 50% (480x270), 10.2 fps (target 10); figures below: full size, at rest"
    assert scale_text(dict(f, scale=1.0)) == "scale 100%"
    assert "(--move-scale);" in scale_text(dict(f, move_scale=0.5))
    assert scale_text(dict(f, target_fps=0.0, scale=1.0)) == ""
