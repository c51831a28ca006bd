"""The wave replay's walks several techniques' replay modules share (app.model.waves
programs): every light, a cell's record, a cell's index list."""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts


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
