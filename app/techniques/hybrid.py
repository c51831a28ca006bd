"""hybrid (O'Donnell & Chajdas 2017, 3.3): the clustered 2.5D grid, each cell a list or a
light tree by the overlap heuristic of listing 2 (cpu_prep.hybrid).  A list is a one-node
tree whose root is a leaf, so one buffer layout serves both.

    ranges[cell] = (first node, node count: 1 = list, >1 = tree) -> nodes[] -> entries[] -> lights[]
"""
from dataclasses import dataclass

from cpu_prep import hybrid as hybridmod

from .base import Technique, prepare_binned
from .options import ListOptions, SliceOptions, TreeOptions, WaveOptions, option
from .tree import tree_buffers, tree_passes


class Hybrid(Technique):
    name = "hybrid"
    summary = "2.5D grid, each cell a list or a tree (listing 2 heuristic)"
    views = Technique.views + ("tiles", "slices", "classes")

    @dataclass(frozen=True)
    class Options(SliceOptions, ListOptions, TreeOptions, WaveOptions):
        radius_scale: float = option(1.0, "listing 2's cell.radius = scale x half the cell's "
                                          "depth extent (undefined in the paper)",
                                     lo=1e-3, hi=1e3, study=(0.5, 1.0, 2.0, 4.0))

    def build(self, frame, opts):
        b, offsets, entries = prepare_binned(frame, opts, opts.slices, opts.sort_buckets)
        with b.times.stage("build"):      # listing 2's choice and the trees, one pass
            *built, is_tree = hybridmod.plan_and_build(
                b.grid, offsets, entries, b.lights.depth_lo, b.lights.depth_hi, frame.max_depth,
                opts.radius_scale, opts.lights_per_leaf, opts.max_leaves, frame.arena)
        tree_buffers(b, offsets, entries, is_tree, opts, frame.arena, built)
        return b

    def passes(self, build, opts):
        return tree_passes(build, opts, "shade_hybrid.comp", native_wave=opts.native_wave)
