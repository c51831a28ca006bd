"""perfect: the physical limit on every cost plot.  Outside the measured cost (untimed
passes), it builds for every pixel the exact list of the lights that affect it; then its
timed shading pass runs the loop every technique runs (evaluate_light) over exactly those
lists.  Its shading time is the floor no culling structure can beat with this shading loop,
and its culling waste (evaluated / contrib_count) is exactly 1.0.

    untimed  count   perfect_count.comp   G-buffer x lights[] -> perfect_counts[pixel]
    untimed  plan    (host step)          prefix sums -> bands of whole 8-row groups,
                                          perfect_ranges_k[band pixel] = (first, count)
    untimed  fill    perfect_fill.comp    -> perfect_entries_k[] (light indices, depth order)
    timed    shade   shade_perfect.comp   perfect_ranges_k -> perfect_entries_k -> lights[]

Both set-up passes decide "affects" with evaluate_light itself, so the lists are exact by
construction (the same float32 function on the same inputs).  A band's entries fit one
storage block (65,536 lights at 1920x1080 are ~50 lights a pixel = 400 MiB: several bands);
the shading time is the sum of the bands' dispatches.  Where the driver limits loop
iterations, count and fill run in dispatch windows over the lights, and shading in windows
over each pixel's list (base.windows; perfect_cursor carries a pixel's fill position).
"""
from __future__ import annotations

import numpy as np

from cpu_prep.limits import MAX_STORAGE_BYTES

from ...errors import UserError
from ...pipeline.passes import Buffer, HostStep, Pass, image_groups
from ..base import TRANSPARENT_REBUILT, Technique, prepare, shading_passes, windows
from ..options import StochasticOptions


def bands(counts: np.ndarray, max_band_bytes: int) -> list[tuple[int, int, int]]:
    """(first row, end row, entries) of each band of `counts` (GL row order): rows in whole
    groups of 8, so that a band's dispatch lines up with the 8x8 waves."""
    h = counts.shape[0]
    per_group_row = np.add.reduceat(counts.sum(1, dtype=np.int64), np.arange(0, h, 8)) if h else []
    cap = max_band_bytes // 4
    out, start, total = [], 0, 0
    for g, n in enumerate(int(v) for v in per_group_row):
        if n > cap:
            raise UserError(f"perfect: 8 image rows need {n * 4 / 2**20:.2f} MiB of light indices, "
                            f"over the {max_band_bytes / 2**20:.2f} MiB limit of a storage block")
        if total + n > cap:
            out.append((start * 8, g * 8, total))
            start, total = g, 0
        total += n
    out.append((start * 8, h, total))
    return out


class Perfect(Technique, register_at=90):
    name = "perfect"
    transparent = TRANSPARENT_REBUILT.format(what="its per-pixel lists are")
    summary = "exact per-pixel light lists built untimed (the shading floor)"
    role = "floor"
    max_band_bytes = MAX_STORAGE_BYTES     # one band's entries: one storage block

    class Options(StochasticOptions):
        pass

    def build(self, frame, opts):
        return prepare(frame, opts=opts)

    def passes(self, build, opts):
        w, h = build.frame.size
        counts = [Pass("count", "perfect_count.comp", reads=("lights",),
                       writes={"perfect_counts": Buffer(w * h * 4, np.dtype(np.uint32))},
                       groups=image_groups(w, h), uniforms={"u_row0": 0, "u_window": win},
                       timed=False)
                  for win in windows(build.frame, len(build.lights))]
        plan = HostStep("plan", ("perfect_counts",),
                        lambda got: self._plan(build, got["perfect_counts"].reshape(h, w)))
        return counts + [plan]

    def _plan(self, build, counts: np.ndarray):
        """Per band: its ranges (uploaded), an untimed fill pass, a timed shading pass."""
        w, h = build.frame.size
        uploads, fills, shades = {}, [], []
        for k, (y0, y1, n) in enumerate(bands(counts, self.max_band_bytes)):
            c = counts[y0:y1].ravel().astype(np.int64)
            ranges = np.zeros((len(c), 2), np.uint32)
            ranges[1:, 0] = np.cumsum(c)[:-1]
            ranges[:, 1] = c
            uploads[f"perfect_ranges_{k}"] = ranges
            src = {"perfect_ranges": f"perfect_ranges_{k}", "perfect_entries": f"perfect_entries_{k}"}
            groups = (image_groups(w, h)[0], -(-(y1 - y0) // 8), 1)
            fills += [Pass("fill", "perfect_fill.comp", reads=("lights", "perfect_ranges"),
                           writes={"perfect_entries": Buffer(n * 4, np.dtype(np.uint32)),
                                   "perfect_cursor": Buffer(len(c) * 4, np.dtype(np.uint32))},
                           groups=groups, uniforms={"u_row0": y0, "u_window": win}, timed=False,
                           sources=src)
                      for win in windows(build.frame, len(build.lights))]
            # every band stores (not accumulates) its own groups' wave statistics: no clear
            shades += shading_passes(build, "shade_perfect.comp", ("perfect_ranges", "perfect_entries"),
                                     int(c.max(initial=0)), uniforms={"u_row0": y0}, groups=groups,
                                     waves_cleared=False, sources=src)
        build.stats.update(bands=len(fills), list_entries=int(counts.sum(dtype=np.int64)))
        return uploads, fills + shades

