"""hybrid: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from ...model import waves
from ..replay_walks import cell_head, entry_list
from .. import variants
from ..blocks import add_shared_load, live_groups, one_tree_groups
from . import CELL_TREE_BIT


def cull_figures(technique, frame, width):
    """The feature variants' passes when on (the cells are CPU-built)."""
    return variants.figures_if_on(frame, width, variants.node_scans, {})


def wave_program(technique, frame, width):
    """shade_hybrid.comp: the cell record, then (specialised) the group vote and one of
    the three paths per wave, else the general traversal for every lane."""
    prog = waves.Program(frame, width)
    b, opts = frame.build, frame.opts
    lanes = np.nonzero(frame.shading)[0]
    rng = b.buffers["ranges"]["offset_count"].astype(np.int64)
    cell = frame.cell[lanes]
    first, count = rng[cell, 0], rng[cell, 1] & ~np.int64(CELL_TREE_BIT)
    nodes = b.buffers["nodes"]
    lid = entry_list(prog, b.buffers["entries"], opts.duplicated)
    prog.add(lanes, head=cell_head(prog, lanes))
    if not opts.specialised:
        prog.add_tree(lanes, first, count, nodes, lid)
        return prog
    tree = count > 1
    group = frame.group[lanes]
    # the group vote (groupReduce: 4 barriers): one tree, read from shared memory?
    prog.barriers += 4 * int(live_groups(prog).sum())
    one = one_tree_groups(group[tree], cell[tree], count[tree], prog.groups, group[~tree])
    shared = one[group]
    prog.barriers += 5 * int(one.sum())          # the base's vote, the load's barrier
    gfirst = np.zeros(prog.groups, np.int64)
    gcount = np.zeros(prog.groups, np.int64)
    gfirst[group[shared]], gcount[group[shared]] = first[shared], count[shared]
    add_shared_load(prog, gfirst, gcount, one)
    prog.add_tree(lanes[shared], first[shared], count[shared], nodes, lid, step0=64,
                   shared=True)
    # the other groups: per wave all lists, all trees or mixed (native: a wave vote)
    rest = ~shared
    w = prog.wave[lanes]
    has_tree = np.zeros(prog.waves, bool)
    has_tree[w[rest & tree]] = True
    has_other = np.zeros(prog.waves, bool)
    has_other[w[rest & ~tree]] = True
    mixed = has_tree[w] & has_other[w]
    lists = rest & ~tree
    if opts.scalarize:          # all-list waves walk their distinct list cells (rounds)
        walk = lists & ~mixed
        r = waves.rounds(prog, lanes[walk], cell[walk])
        v = waves.tree_visits(frame.position[lanes[walk], 3], first[walk],
                              np.minimum(count[walk], 1), nodes)
        prog.add(lanes[walk][v[:, 0]], step=1 + r[v[:, 0]],
                 head=("node", "nodes", v[:, 2] * 16, 16, True), lights=(lid, v[:, 3], v[:, 4], True))
        lists &= mixed
    prog.add_tree(lanes[lists], first[lists], count[lists], nodes, lid)
    trees = rest & tree
    prog.add_tree(lanes[trees], first[trees], count[trees], nodes, lid,
                   branch=1)               # in a mixed wave, after its list lanes
    return prog
