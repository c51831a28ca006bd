"""Dynamic resolution: while the camera moves, the window renders at a scale that holds a
target frame time, and at full size when it rests (as engines' dynamic resolution does).  No GL.

    DynamicScale  the controller: called once at the start of each frame with whether the
                  camera moves; it times the frame before (its own clock: tests give a fake
                  one) and returns this frame's scale.
    scaled_size   a window size at a scale

The model: a frame's time grows with its pixels, so a frame of t seconds at scale s
(s^2 of the pixels) says a full-size frame takes about t / s^2; the scale that meets the
target T is sqrt(T / that).  The estimate is smoothed over frames (EMA_WEIGHT) and counts
the frame's fixed part (the CPU build, the UI: not fewer at a lower scale) as if it
scaled, so it errs towards the smaller scale, and the steps below it do not overshoot.
Scales are snapped down to STEP (1/16) between MIN_SCALE and 1: a handful of sizes, each
allocated once, not a new one every frame; it falls as soon as a frame is over the target
and rises only when the estimate clears RISE steps (no flicker between two neighbours on
a noisy clock).  Every size is
one every technique takes (their grids cover any size: the edge tiles and 8x8 groups are
partial, as at full size); MIN_SCALE keeps a tile's worth of pixels in view."""
from __future__ import annotations

import math
import time

from ..display import DEFAULT_FPS     # the panel's and --target-fps's default

MIN_SCALE = 0.25
STEP = 1.0 / 16.0
EMA_WEIGHT = 0.5              # the newest frame's share of the full-size estimate
RISE = 1.5                    # the scale rises once the estimate clears this many steps


def snap_down(scale: float) -> float:
    """The largest step at or below `scale`, within MIN_SCALE..1."""
    s = math.floor(scale / STEP + 1e-9) * STEP
    return min(1.0, max(MIN_SCALE, s))


def scaled_size(size, scale: float) -> tuple[int, int]:
    """`size` (w, h) at `scale`, rounded, at least one pixel a side."""
    if scale >= 1.0:
        return int(size[0]), int(size[1])
    return max(1, int(round(size[0] * scale))), max(1, int(round(size[1] * scale)))


class DynamicScale:
    """target_fps: the frame rate moving frames hold (0: off, every frame full size);
    fixed: the scale every moving frame takes instead, whatever the target (None: held by
    the target)."""

    def __init__(self, target_fps: float = DEFAULT_FPS, fixed: float | None = None,
                 clock=time.perf_counter):
        self.target_fps = float(target_fps)
        self.fixed = fixed
        self.clock = clock
        self.scale = 1.0              # this frame's scale (the last next()'s answer)
        self.moving_scale = 1.0       # the scale moving frames take now
        self.full_s = None            # smoothed estimate of a full-size frame's seconds
        self.last_s = None            # the last frame's seconds, as timed
        self._since = None            # the clock at the last next()
        self._skip = False
        self._excluded = 0.0

    def skip(self) -> None:
        """This frame's time is no measure (it compiles, takes a screenshot ...)."""
        self._skip = True

    def exclude(self, seconds: float) -> None:
        """Work in this frame that is not the frame's (the modelled GPU time's replay)."""
        self._excluded += seconds

    def next(self, moving: bool) -> float:
        """This frame's scale: full size at rest; moving, the scale the target allows.
        The frame before (since the last call) is timed at the scale it had."""
        now = self.clock()
        if self._since is not None:
            self.last_s = now - self._since
            if not self._skip:
                self.measured(self.scale, self.last_s - self._excluded)
        self._since, self._skip, self._excluded = now, False, 0.0
        self.scale = self._moving() if moving else 1.0
        return self.scale

    def measured(self, scale: float, seconds: float) -> None:
        """A frame at `scale` took `seconds`: the full-size estimate, then the moving scale."""
        if seconds <= 0.0:
            return
        full = seconds / (scale * scale)
        self.full_s = full if self.full_s is None else \
            EMA_WEIGHT * full + (1.0 - EMA_WEIGHT) * self.full_s
        if self.target_fps <= 0.0 or self.fixed is not None:
            return
        ideal = math.sqrt(1.0 / self.target_fps / self.full_s)
        if ideal < self.moving_scale:
            self.moving_scale = snap_down(ideal)
        elif ideal >= self.moving_scale + RISE * STEP:      # up by a step at least
            self.moving_scale = snap_down(ideal - (RISE - 1.0) * STEP)

    def _moving(self) -> float:
        if self.fixed is not None:
            return float(self.fixed)
        return self.moving_scale if self.target_fps > 0.0 else 1.0
