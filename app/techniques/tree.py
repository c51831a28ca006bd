"""tree (O'Donnell & Chajdas 2017): one light tree per 2D screen tile over view depth.

    ranges[tile] = (first node, node count) -> nodes[] (TreeNode, depth-first, skip counts)
    leaf node -> entries[first .. first+count] -> lights[]
    1920x1080 at 48 px: 920 tiles; a tree of 64 leaves is 127 nodes = 2 KiB
"""
from dataclasses import dataclass

import numpy as np

from cpu_prep import frame as cpuframe, tree as treemod

from ..model import waves
from .base import Technique, cell_head, cell_ranges, entry_list, grid_uniforms, prepare_binned, shading_passes
from .clustered import list_buffers, list_reads
from .options import ListOptions, TileOptions, TreeOptions

SHARED_TREE_NODES = 128   # shared-memory copy of one tree: 128 x 16 B = 2 KiB


def tree_buffers(b, offsets, entries, is_tree, opts, arena=None, built=None):
    """built: (ranges, nodes, leaves) already made (the hybrid's cpu_prep.hybrid.plan_and_build)."""
    if built is None:
        with b.times.stage("build"):
            built = treemod.build_trees(
                offsets, entries, b.lights.depth_lo, b.lights.depth_hi, is_tree,
                opts.lights_per_leaf, opts.max_leaves, arena)
    ranges, nodes, leaves = built
    with b.times.stage("pack"):
        list_buffers(b, offsets, entries, opts.duplicated)
        b.buffers["ranges"] = ranges
        b.buffers["nodes"] = nodes
        cpuframe.check_buffer("tree nodes", nodes.nbytes)
    b.stats.update(nodes=len(nodes), trees=int((leaves > 1).sum()),
                   lists=int((leaves == 1).sum()))
    return leaves


def tree_passes(build, opts, shader: str, native_wave: bool = False, defines=None):
    """The shading pass of a technique whose cells hold trees (tree.glsl); a pixel meets at
    most its cell's lights (the leaves split the cell's list)."""
    return shading_passes(build, shader, list_reads(opts.duplicated) + ("nodes",),
                          build.data["longest_list"],
                          defines=dict(defines or {}, LIGHTS_DUPLICATED=int(opts.duplicated),
                                       SHARED_TREE_NODES=SHARED_TREE_NODES),
                          uniforms=grid_uniforms(build.grid), native_wave=native_wave)


class Tree(Technique):
    name = "tree"
    summary = "a light tree per 2D tile (O'Donnell & Chajdas 2017)"
    views = Technique.views + ("tiles", "classes")

    @dataclass(frozen=True)
    class Options(TileOptions, ListOptions, TreeOptions):
        pass

    def build(self, frame, opts):
        b, offsets, entries = prepare_binned(frame, opts, 1, opts.sort_buckets)
        tree_buffers(b, offsets, entries, np.ones(b.grid.cells, bool), opts, frame.arena)
        return b

    def passes(self, build, opts):
        return tree_passes(build, opts, "shade_tree.comp")

    def wave_program(self, frame, width):
        """The tile's record, then listing 3's traversal per lane (one step per node visit)."""
        prog = waves.Program(frame, width)
        b = frame.build
        lanes = np.nonzero(frame.shading)[0]
        ranges = cell_ranges(b)
        cell = frame.cell[lanes]
        prog.add(lanes, head=cell_head(prog, lanes))
        prog.add_tree(lanes, ranges[cell, 0], ranges[cell, 1], b.buffers["nodes"],
                       entry_list(prog, b.buffers["entries"], frame.opts.duplicated))
        return prog
