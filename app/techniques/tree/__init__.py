"""tree (O'Donnell & Chajdas 2017): one light tree per 2D screen tile over view depth.

    ranges[tile] = (first node, node count) -> nodes[] (TreeNode, depth-first, skip counts)
    leaf node -> entries[first .. first+count] -> lights[]
    1920x1080 at 48 px: 920 tiles; a tree of 64 leaves is 127 nodes = 2 KiB

`shared_tree` (on by default): the tree paper's shared-memory tree (3.4, the hybrid's tree
path), a group whose shading pixels all read one tree of at most SHARED_TREE_NODES nodes
loads it into shared memory once and traverses it from there (app/techniques/tree/shade_tree.comp).  With
8x8 groups in tiles of a multiple of 8 pixels (48) every group lies in one tile and knows
its tree without a vote; other tile sizes vote (4 barriers a group).  `tree_build`: the
trees bottom-up (the paper's full trees) or top-down (cpu_prep.tree_topdown).
"""
from dataclasses import dataclass

import numpy as np

from ...pipeline.passes import WAVE_DIM
from ..base import Technique, prepare_binned
from ..blocks import SHARED_TREE_NODES, tree_buffers, tree_passes
from ..gpu_build import BuildOptions, build_trees, on_gpu
from ..options import CapOptions, ListOptions, StochasticOptions, TileOptions, TreeOptions, option

class Tree(Technique, register_at=40):
    name = "tree"
    summary = "a light tree per 2D tile (O'Donnell & Chajdas 2017)"
    views = Technique.views + ("tiles", "classes")
    froxels = "trees"       # a fog scene: the leaves of the cells it overlaps, by depth

    @dataclass(frozen=True)
    class Options(TileOptions, ListOptions, TreeOptions, CapOptions, StochasticOptions, BuildOptions):
        shared_tree: bool = option(True, "a group whose pixels all read one tree of at "
                                         f"most {SHARED_TREE_NODES} nodes loads it into shared "
                                         "memory once and traverses it there (tree paper 3.4); "
                                         "off: every pixel reads its nodes from global memory",
                                   study=(True, False))

    def build(self, frame, opts):
        if on_gpu(opts):
            return build_trees(frame, opts, 1, lambda b: self.passes(b, opts))
        b, offsets, entries = prepare_binned(frame, opts, 1, opts.sort_buckets)
        tree_buffers(b, offsets, entries, np.ones(b.grid.cells, bool), opts, frame.arena)
        return b

    def passes(self, build, opts):
        return tree_passes(build, opts, "shade_tree.comp",
                           defines={"SHARED_TREE": int(opts.shared_tree),
                                    "TILE_ALIGNED": int(tile_aligned(opts.tile))})


def tile_aligned(tile: int) -> bool:
    """Every 8x8 group of the shading pass lies in one tile (app/techniques/tree/shade_tree.comp TILE_ALIGNED)."""
    return tile % WAVE_DIM == 0


def group_tiles(frame, grid) -> np.ndarray:
    """The tile of each 8x8 group's first pixel (dispatch order; a 2D grid's cell)."""
    gx = -(-frame.size[0] // WAVE_DIM)
    g = np.arange(gx * -(-frame.size[1] // WAVE_DIM), dtype=np.int64)
    return (g // gx * WAVE_DIM // grid.tile) * grid.tiles_x + g % gx * WAVE_DIM // grid.tile
