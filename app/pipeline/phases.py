"""Where a process's time goes, by named phase (the benchmark's per-study breakdown: compile,
render, timing, build, check, replay ...).

Phases nest and their times are exclusive: a phase opened inside another stops the outer
one's clock until it closes, so the totals add up to the time spent inside any phase.  A time
found out only afterwards (a pass that turned out to compile its program) is moved from the
open phase to another with `move`.  The totals are process-wide and only ever grow; a caller
takes `snapshot()` before and after a piece of work and keeps the difference (`since`).
Costs one perf_counter call a boundary; imports nothing of the project.
"""
from __future__ import annotations

from contextlib import contextmanager
from functools import wraps
import time

_totals: dict[str, float] = {}
_open: list[list] = []          # [name, the time its clock last started], innermost last


@contextmanager
def phase(name: str):
    """Count the time inside the block as `name` (not as the phase it is nested in)."""
    now = time.perf_counter()
    if _open:
        outer = _open[-1]
        _totals[outer[0]] = _totals.get(outer[0], 0.0) + now - outer[1]
    _open.append([name, now])
    try:
        yield
    finally:
        now = time.perf_counter()
        inner = _open.pop()
        _totals[inner[0]] = _totals.get(inner[0], 0.0) + now - inner[1]
        if _open:
            _open[-1][1] = now


def timed(name: str):
    """A decorator: every call of the function is phase `name`."""
    def wrap(fn):
        @wraps(fn)
        def inner(*args, **kw):
            with phase(name):
                return fn(*args, **kw)
        return inner
    return wrap


def move(name: str, seconds: float) -> None:
    """Count `seconds` of the open phase's time (already spent) as `name` instead; outside
    any phase, just as `name`."""
    seconds = max(float(seconds), 0.0)
    _totals[name] = _totals.get(name, 0.0) + seconds
    if _open:
        _open[-1][1] += seconds


def snapshot() -> dict[str, float]:
    """The totals so far (the open phases' time up to now included)."""
    now = time.perf_counter()
    out = dict(_totals)
    if _open:
        name, start = _open[-1]
        out[name] = out.get(name, 0.0) + now - start
    return out


def since(before: dict[str, float], after: dict[str, float] | None = None) -> dict[str, float]:
    """Each phase's time between two snapshots (after: now), the phases that took none left
    out, the longest first."""
    after = snapshot() if after is None else after
    spent = {k: v - before.get(k, 0.0) for k, v in after.items()}
    return dict(sorted(((k, v) for k, v in spent.items() if v > 0), key=lambda kv: -kv[1]))


__all__ = ["phase", "timed", "move", "snapshot", "since"]
