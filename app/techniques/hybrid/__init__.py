"""hybrid (O'Donnell & Chajdas 2017, 3.3): the clustered 2.5D grid, each cell a list or a
light tree by the overlap heuristic of listing 2 (cpu_prep.hybrid).  A list is a one-node
tree whose root is a leaf, so one buffer layout serves both.

    ranges[cell] = (first node, node count: 1 = list, >1 = tree; top bit: listing 2 chose a
                    tree) -> nodes[] -> entries[] -> lights[]

The shading pass (app/techniques/hybrid/shade_hybrid.comp) takes the paper's three wave paths: a) every lane
a list, b) every lane a tree (from shared memory when the group shares one), c) mixed;
`specialised=False` runs the one general traversal instead, so the report can set each
path's wave iterations and node visits against it.  Waves are classified by listing 2's
choice, not by the stored structure (a chosen list of more than 65,535 lights is stored as a
small tree of lists).  `scalarize` walks the wave's distinct list cells in path a) (Drobot
2017's container scalarization).  `tree_build` (TreeOptions): the tree cells built
bottom-up (full trees) or top-down (cpu_prep.tree_topdown; a top-down cell that stays one
leaf is read as a list by structure, as a list of any cell is).
"""
from dataclasses import dataclass

import numpy as np

from cpu_prep import hybrid as hybridmod, layouts

from ...pipeline.passes import OUT_STATS, WAVE_DIM, WAVE_STATS, HostStep
from ..base import Technique, prepare_binned
from ..gpu_build import BuildOptions, build_trees, on_gpu
from ..options import (CapOptions, ListOptions, ScalarizeOptions, SliceOptions, StochasticOptions, TreeOptions,
                      WaveOptions, FeatureVariantOptions, option)
from .. import variants
from ...pipeline import features as feat
from ..blocks import tree_buffers, tree_passes

CELL_TREE_BIT = np.uint32(1 << 31)     # a cell's count word: listing 2 chose a tree


class Hybrid(Technique, register_at=50):
    name = "hybrid"
    summary = "2.5D grid, each cell a list or a tree (listing 2 heuristic)"
    views = Technique.views + ("tiles", "slices", "classes", "variants")
    stereo_union = "structure"     # a 2.5D grid of lists and trees over its cells' depth
    froxels = "trees"       # a fog scene: the leaves of the cells it overlaps, by depth
    glsl = {"hybrid_cells.glsl": layouts.glsl_defines({"CELL_TREE_BIT": CELL_TREE_BIT})}

    @dataclass(frozen=True)
    class Options(SliceOptions, ListOptions, TreeOptions, WaveOptions, ScalarizeOptions,
                  CapOptions, StochasticOptions, BuildOptions, FeatureVariantOptions):
        radius_scale: float = option(1.0, "listing 2's cell.radius = scale x half the cell's "
                                          "depth extent (undefined in the paper)",
                                     lo=1e-3, hi=1e3, study=(0.5, 1.0, 2.0, 4.0))
        specialised: bool = option(True, "the paper's three wave paths (all lists, all trees "
                                         "with the shared-memory tree, mixed); off: one general "
                                         "traversal for every wave", study=(True, False))

    def build(self, frame, opts):
        if on_gpu(opts):
            return build_trees(frame, opts, opts.slices, lambda b: self.passes(b, opts), CELL_TREE_BIT)
        b, offsets, entries = prepare_binned(frame, opts, opts.slices, opts.sort_buckets)
        with b.times.stage("build"):      # listing 2's choice and the trees, one pass
            *built, is_tree = hybridmod.plan_and_build(
                b.grid, offsets, entries, b.lights.depth_lo, b.lights.depth_hi, frame.max_depth,
                opts.radius_scale, opts.lights_per_leaf, opts.max_leaves, frame.arena,
                opts.tree_build)
        leaves = tree_buffers(b, offsets, entries, is_tree, opts, frame.arena, built)
        with b.times.stage("pack"):       # the choice, for the wave classification
            b.buffers["ranges"]["offset_count"][:, 1] |= is_tree.astype(np.uint32) * CELL_TREE_BIT
        used = np.diff(offsets) > 0
        b.stats.update(trees=int((is_tree & used).sum()), lists=int((~is_tree & used).sum()),
                       lists_stored_as_trees=int((~is_tree & (leaves > 1)).sum()))
        return b

    def passes(self, build, opts):
        shade = tree_passes(build, opts, "shade_hybrid.comp", native_wave=opts.native_wave,
                            defines={"SPECIALISED": int(opts.specialised),
                                     "SCALARIZED": int(opts.scalarize)})
        steps = shade + [HostStep("wave cases", (WAVE_STATS, OUT_STATS),
                                  lambda got: _case_counters(build, got[WAVE_STATS], got[OUT_STATS]),
                                  figures=True)]
        return variants.with_variants(build, opts, steps, variants.CellSource(
            variants.CELL_NODES, ("ranges", "entries", "nodes"), count_mask=int(~CELL_TREE_BIT),
            mask_defines=lambda m: {"CELL_KINDS": (m >> feat.CELL_KIND_SHIFT) & 3}))


def _case_counters(build, waves, pixels):
    """Meta stats per wave path (untimed, after the frame): waves, mean scalar iterations and
    tree nodes visited per pixel, by listing 2's classification."""
    w, h = build.frame.size
    gx, gy = -(-w // WAVE_DIM), -(-h // WAVE_DIM)
    wv = np.asarray(waves).view(layouts.WAVE_STATS).reshape(gy, gx)
    st = np.asarray(pixels).view(layouts.PIXEL_STATS).reshape(h, w)
    pad = lambda a: np.pad(a.astype(np.float64), ((0, gy * WAVE_DIM - h), (0, gx * WAVE_DIM - w)))
    per_group = lambda a: pad(a).reshape(gy, WAVE_DIM, gx, WAVE_DIM).sum((1, 3))
    nodes, busy = per_group(st["nodes"]), per_group((st["evaluated"] + st["nodes"]) > 0)
    case = wv["case_bits"] & layouts.CASE_MIXED
    for k, name in layouts.CASES.items():
        m = case == k
        build.stats[f"waves_{name}"] = int(m.sum())
        build.stats[f"iterations_{name}"] = float(wv["iterations"][m].mean()) if m.any() else 0.0
        build.stats[f"nodes_{name}"] = float(nodes[m].sum() / max(busy[m].sum(), 1.0))
    build.stats["waves_shared_tree"] = int(((wv["case_bits"] & layouts.CASE_SHARED_TREE) != 0).sum())
    return {}, []


