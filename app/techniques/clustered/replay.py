"""clustered: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from ...model import waves
from ..replay_walks import add_cell_lists, cell_head, entry_list
from ..blocks import cell_ranges
from .. import variants


def cull_figures(technique, frame, width):
    """The feature variants' passes when on (the lists are CPU-built)."""
    return variants.figures_if_on(frame, width, variants.list_scans, {})


def wave_program(technique, frame, width):
    prog = waves.Program(frame, width)
    b, opts = frame.build, frame.opts
    lanes = np.nonzero(frame.shading)[0]
    ranges = cell_ranges(b)
    if not opts.scalarize:
        add_cell_lists(prog, lanes, ranges, b.buffers["entries"], opts.duplicated)
        return prog
    # one round per distinct cell of the wave: its record and list from a uniform address
    cell = frame.cell[lanes]
    lid = entry_list(prog, b.buffers["entries"], opts.duplicated)
    prog.add(lanes, step=waves.rounds(prog, lanes, cell), head=cell_head(prog, lanes, scalar=True),
             lights=(lid, ranges[cell, 0], ranges[cell, 1], True))
    return prog
