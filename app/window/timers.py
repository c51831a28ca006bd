"""Timer history: per GPU pass and per CPU stage, the last HISTORY frames of one
configuration (technique, options, lights, size); the panel shows the rolling median and
minimum over the last WINDOW of them and a graph of the history.  A new configuration starts
a new history (its first frame, which compiles shaders and kernels, is left out).  No GL."""
from __future__ import annotations

from collections import deque
import statistics

HISTORY = 120          # frames kept for the graph
WINDOW = 30            # frames of the rolling median / min


class Timers:
    def __init__(self):
        self.key = None
        self.series: dict[str, deque] = {}
        self.skip_first = True

    def add(self, key, gpu_ms: dict, cpu_ms: dict, wall_ms: float) -> None:
        """One frame of configuration `key`: its GPU ms per pass, CPU ms per stage and the
        window's whole frame (wall clock)."""
        if key != self.key:
            self.key, self.series, self.skip_first = key, {}, True
            return                  # the first frame of a configuration compiles: not kept
        rows = {f"gpu {k}": v for k, v in gpu_ms.items()}
        rows["cpu total"] = float(sum(cpu_ms.values()))
        rows.update({f"cpu {k}": v for k, v in cpu_ms.items()})
        rows["frame (wall)"] = wall_ms
        for name, v in rows.items():
            self.series.setdefault(name, deque(maxlen=HISTORY)).append(float(v))

    def summary(self) -> dict[str, tuple[float, float, int]]:
        """{series: (median, min over the last WINDOW frames, frames)}."""
        out = {}
        for name, values in self.series.items():
            recent = list(values)[-WINDOW:]
            out[name] = (statistics.median(recent), min(recent), len(recent))
        return out

    def history(self, name: str) -> list[float]:
        return list(self.series.get(name, ()))

    def rows(self) -> list[tuple]:
        """The panel's rows: (series, median, min, frames, history to graph or None); the
        GPU passes, the CPU total and the whole frame are graphed."""
        graphed = lambda n: n.startswith("gpu") or n in ("cpu total", "frame (wall)")
        return [(name, med, lo, n, self.history(name) if graphed(name) else None)
                for name, (med, lo, n) in self.summary().items()]
