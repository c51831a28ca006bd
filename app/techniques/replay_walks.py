"""The wave replay's walks several techniques' replay modules share (app.model.waves
programs): every light, a cell's record, a cell's index list, draws by a cell's CDF words."""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts, sampling

from .blocks import cell_ranges


_DRAWS: list = []        # [frame, {key: value}]: the last frame's width-independent draws


def per_frame(frame, key, make):
    """make() once per frame and key: the draws a sampler's GPU made (its PCG streams, a
    descent, a CDF search) do not depend on the wave width, and the model replays each frame
    at every width (app.model.predict).  Only the last frame's are kept (by identity)."""
    if not _DRAWS or _DRAWS[0] is not frame:
        _DRAWS[:] = [frame, {}]
    memo = _DRAWS[1]
    if key not in memo:
        memo[key] = make()
    return memo[key]


def add_all_lights(prog, lanes, step=0, branch=0) -> None:
    """evaluate_all_lights (pixel.glsl): every visible light in order, a wave-uniform loop of
    affects tests, then per run of 32 each lane's affecting lights (LightList.runs)."""
    prog.add(lanes, step=step, branch=branch,
             lights=(prog.all_lights(), 0, len(prog.frame.build.lights), True))


def cell_head(prog, lanes, buf: str = "ranges", record=layouts.CELL_RANGE, scalar: bool = False):
    """The head fetch of each lane's cell record `buf[cell]` (cell from out_cell)."""
    cell = prog.frame.cell[np.asarray(lanes, np.int64)]
    return ("cell", buf, cell * record.itemsize, record.itemsize, scalar)


def add_cell_lists(prog, lanes, ranges, entries, duplicated: bool = False, step=0, branch=0,
                   head: bool = True, entry_buf: str = "entries") -> None:
    """Per lane its cell's record ranges[cell] = (first, count) and that index list
    (lists.glsl evaluate_list)."""
    lanes = np.asarray(lanes, np.int64)
    cell = prog.frame.cell[lanes]
    lid = entry_list(prog, entries, duplicated, entry_buf)
    prog.add(lanes, step=step, branch=branch, head=cell_head(prog, lanes) if head else None,
             lights=(lid, ranges[cell, 0], ranges[cell, 1], False))


def entry_list(prog, entries, duplicated: bool = False, entry_buf: str = "entries") -> int:
    """The light list of an index buffer: entry k fetched at 4k, then its light (indexed), or
    the copy at dup_lights[k] (duplicated, paper figure 5)."""
    entries = np.asarray(entries, np.int64)
    k = np.arange(len(entries), dtype=np.int64)
    if duplicated:
        return prog.add_list(entries, slot=k, light_buf="dup_lights")
    return prog.add_list(entries, entry_off=4 * k, entry_buf=entry_buf)


def add_cdf_draws(prog, lanes, first, count, masses, lid: int, step0: int = 0,
                  key=None) -> int:
    """Draws by a cell's CDF words (glsl/sample_cdf.glsl draw_entry), `masses` (D, lanes) the
    GPU's u of each draw in order (or a function giving them): per draw its search probes
    (kind word, a lane whose search ended earlier masked: the d-th draw's j-th probe of every
    lane together), then the drawn light (kind light, one position of list `lid`, the
    entries' positions), from step0 on; returns the step after the last.  `key`: the draws
    are made once per frame under it (per_frame), for every wave width."""
    cdf = prog.frame.build.buffers["sample_cdf"]

    def search():
        return [sampling.draw_entries(cdf, first, count, u)
                for u in (masses() if callable(masses) else masses)]
    searched = search() if key is None else per_frame(prog.frame, ("cdf draws", key), search)
    depth = max((len(p) for _, p in searched), default=0)     # the frame's longest search
    for d, (entry, probes) in enumerate(searched):
        base = step0 + d * (depth + 1)
        for j, probe in enumerate(probes):
            on = probe >= 0
            prog.add(lanes[on], step=base + j, head=("word", "sample_cdf", 4 * probe[on], 4, False))
        prog.add(lanes, step=base + depth, lights=(lid, entry, 1, False))
    return step0 + len(searched) * (depth + 1)


def listed_lanes(prog, frame, step: int = 0):
    """(lanes, first, count): the shading lanes the replay walks, each with its cell record
    fetched at `step`, less those whose cell lists no light (they draw nothing)."""
    ranges = cell_ranges(frame.build)
    lanes = np.nonzero(frame.shading)[0]
    if frame.live is not None:
        lanes = lanes[frame.live[lanes]]
    prog.add(lanes, step=step, head=cell_head(prog, lanes))
    first, count = ranges[frame.cell[lanes], 0], ranges[frame.cell[lanes], 1]
    keep = count > 0
    return lanes[keep], first[keep], count[keep]
