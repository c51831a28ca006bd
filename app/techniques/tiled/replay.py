"""tiled: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts

from ...model import waves
from ..replay_walks import add_all_lights, add_cell_lists, cell_head
from .. import variants
from . import OVERFLOW


def cull_figures(technique, frame, width):
    """tile_cull.comp: per tile one 16x16 group; the depth reduction, then every light's
    sphere test twice (count, then the ordered fill), 256 lights a round."""
    g, n = frame.build.grid, len(frame.build.lights)
    pixels, covered, *_ = waves.per_tile(frame, g.tile)
    ranges = frame.read("ranges").view(layouts.CELL_RANGE)["offset_count"].astype(np.int64)
    busy = covered > 0
    filled = busy & (ranges[:, 1] != OVERFLOW)
    hits = int(ranges[filled, 1].sum())
    per = 256 // width                           # waves of a 16x16 group
    texels = (-(-g.tile // 16)) ** 2             # a lane's share of the tile's pixels
    rounds = -(-n // 256)
    line = lambda issued, nbytes: issued * width * nbytes // waves.LINE
    depth = (g.cells * per * texels, pixels.sum(), g.cells * per * texels,
             line(g.cells * per * texels, 16))
    tests = int(busy.sum() + filled.sum()) * per * rounds
    cull = (tests, int(busy.sum() + filled.sum()) * n, tests, line(tests, 16))
    return variants.figures_if_on(frame, width, variants.list_scans, {"tile_cull": waves.analytic(
        width, g.cells * per, {"depth": depth, "cull_test": cull},
        {"g_position": int(pixels.sum()) * 16, "bounds": n * 16, "entries": hits * 4,
         "ranges": g.cells * 8},
        barriers=g.cells * (3 + 3 * rounds), atomics=int(busy.sum()),
        shared_atomics=2 * int(covered.sum()) + hits)})


def wave_program(technique, frame, width):
    prog = waves.Program(frame, width)
    lanes = np.nonzero(frame.shading)[0]
    ranges = frame.read("ranges").view(layouts.CELL_RANGE)["offset_count"].astype(np.int64)
    over = ranges[frame.cell[lanes], 1] == OVERFLOW
    listed = np.where(ranges[:, 1] == OVERFLOW, 0, ranges.sum(1))
    entries = frame.read("entries")[:int(listed.max(initial=0))]   # the pool's used part
    prog.add(lanes, head=cell_head(prog, lanes))
    add_cell_lists(prog, lanes[~over], ranges, entries, step=1, head=False)
    add_all_lights(prog, lanes[over], step=1, branch=1)     # an overflowed tile's branch
    return prog
