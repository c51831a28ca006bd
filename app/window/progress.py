"""Console lines for the window's work that can take seconds (a million lights on a software
GL: the start-up probe's frames, a slow frame's estimate, a new light draw): a line before a
step expected to take over AFTER_S (from what was measured so far), and one after any step
that took over it, with its time.  Said before the step, not from a timer thread: moderngl
holds the GIL while the GL works, so a thread could only print once the step has ended."""
from __future__ import annotations

from contextlib import contextmanager
import sys
import time

AFTER_S = 1.0


def say(text: str) -> None:
    print(f"window: {text}", file=sys.stderr, flush=True)


@contextmanager
def step(what: str, expect_s: float | None = None, unknown: bool = False):
    """`what` said before the work when `expect_s` is over AFTER_S (or `unknown`: nothing
    measured yet says how long), and with its time after the work (done or refused) when
    it took over AFTER_S."""
    if expect_s is not None and expect_s > AFTER_S:
        say(f"{what}, about {expect_s:.0f} s ...")
    elif unknown:
        say(f"{what} ...")
    t0 = time.perf_counter()
    try:
        yield
    finally:
        took = time.perf_counter() - t0
        if took > AFTER_S:
            say(f"{what}: {took:.1f} s")
