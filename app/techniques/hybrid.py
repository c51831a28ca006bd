"""hybrid (O'Donnell & Chajdas 2017, 3.3): the clustered 2.5D grid, each cell a list or a
light tree by the overlap heuristic of listing 2 (cpu_prep.hybrid).  A list is a one-node
tree whose root is a leaf, so one buffer layout serves both.

    ranges[cell] = (first node, node count: 1 = list, >1 = tree) -> nodes[] -> entries[] -> lights[]
"""
from cpu_prep import frame as cpuframe, grid as gridmod, hybrid as hybridmod

from .base import Technique, grid_uniforms, prepare
from .tree import tree_buffers


class Hybrid(Technique):
    name = "hybrid"
    summary = "2.5D grid, each cell a list or a tree (listing 2 heuristic)"
    shader = "shade_hybrid.comp"

    def build(self, frame, opts):
        b = prepare(frame, opts)
        cam = frame.camera
        b.grid = gridmod.make_grid(cam, opts.tile, opts.slices, frame.max_depth, opts.near_slice_depth)
        offsets, entries = cpuframe.bin_cells(b.lights, cam, b.grid, b.times)
        with b.times.stage("build"):
            is_tree = hybridmod.choose_trees(b.grid, offsets, entries, b.lights.depth_lo,
                                             b.lights.depth_hi, frame.max_depth, opts.radius_scale)
        tree_buffers(b, offsets, entries, is_tree, opts)
        b.uniforms.update(grid_uniforms(b.grid))
        b.stats["cells"] = b.grid.cells
        return b
