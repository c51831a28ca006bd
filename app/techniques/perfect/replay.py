"""perfect: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from ...model import waves


def wave_program(technique, frame, width):
    """Each band's per-pixel lists: the pixel's range, then its exact list."""
    prog = waves.Program(frame, width)
    w, row, k = frame.size[0], 0, 0
    while f"perfect_ranges_{k}" in frame.names:
        ranges = frame.read(f"perfect_ranges_{k}").reshape(-1, 2).astype(np.int64)
        pix = row * w + np.arange(len(ranges))
        lanes = pix[frame.shading[pix]]
        band = lanes - row * w
        entries = frame.read(f"perfect_entries_{k}")
        lid = prog.add_list(entries, entry_off=4 * np.arange(len(entries)),
                            entry_buf=f"perfect_entries_{k}")
        prog.add(lanes, head=("cell", f"perfect_ranges_{k}", band * 8, 8, False),
                 lights=(lid, ranges[band, 0], ranges[band, 1], False))
        row, k = row + len(ranges) // w, k + 1
    return prog
