"""tree: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from ...model import waves
from ..replay_walks import cell_head, entry_list
from ..blocks import (SHARED_TREE_NODES, add_shared_load, cell_ranges, live_groups, live_pixels,
                      one_tree_groups)
from . import group_tiles, tile_aligned


def wave_program(technique, frame, width):
    """shade_tree.comp: the tile's record, then listing 3's traversal per lane (one step
    per node visit); shared_tree: the groups that share one tree load it (every
    invocation a node in 64), then traverse it from shared memory."""
    prog = waves.Program(frame, width)
    b, opts = frame.build, frame.opts
    lanes = np.nonzero(frame.shading)[0]
    ranges = cell_ranges(b)
    cell = frame.cell[lanes]
    first, count = ranges[cell, 0], ranges[cell, 1]
    nodes = b.buffers["nodes"]
    lid = entry_list(prog, b.buffers["entries"], opts.duplicated)
    if not opts.shared_tree:
        prog.add(lanes, head=cell_head(prog, lanes))
        prog.add_tree(lanes, first, count, nodes, lid)
        return prog
    live = live_groups(prog)
    if tile_aligned(opts.tile):
        # every invocation reads its group's tile record, from one address: no vote
        gcell = group_tiles(frame, b.grid)
        gfirst, gcount = ranges[gcell, 0], ranges[gcell, 1]
        one = live & (gcount >= 1) & (gcount <= SHARED_TREE_NODES)
        px = live_pixels(frame)
        prog.add(px, head=("cell", "ranges", gcell[frame.group[px]] * 8, 8, True))
    else:
        prog.barriers += 4 * int(live.sum())           # the vote (groupReduce)
        prog.add(lanes, head=cell_head(prog, lanes))
        group = frame.group[lanes]
        one = one_tree_groups(group, cell, count, prog.groups)
        gfirst = np.zeros(prog.groups, np.int64)
        gcount = np.zeros(prog.groups, np.int64)
        gfirst[group], gcount[group] = first, count    # one cell per `one` group
    prog.barriers += int(one.sum())                    # load_shared_tree's barrier
    add_shared_load(prog, gfirst, gcount, one)
    shared = one[frame.group[lanes]]
    prog.add_tree(lanes[shared], first[shared], count[shared], nodes, lid, step0=64,
                  shared=True)
    prog.add_tree(lanes[~shared], first[~shared], count[~shared], nodes, lid)
    return prog
