"""sample-tree: S light samples a shading pixel drawn by a stochastic descent of its tile's
light tree (the `tree` technique's trees: O'Donnell & Chajdas 2017, one depth-first tree a
2D tile over view depth), as Stochastic Lightcuts (Yuksel 2019, "Stochastic Lightcuts")
samples with a cut of one node, the root: an unbiased estimate of brute's radiance at every
pixel for S light evaluations and a few node visits each, however many lights the tile holds.

    ranges[tile] = (first node, node count) -> nodes[] (TreeNode, tree.glsl) -> entries[] -> lights[]
    sample_nodes[node], depth_pieces[]: each subtree's power, light-centre box and the union
    of its leaves' depth intervals (cpu_prep.sample_tree)

A descent starts at the root and, at each inner node, takes a child that can hold a light
reaching the pixel (its depth in one of the child's depth pieces: the depth test of
tree.glsl's traversal on the same float32 bounds; any other child gets p = 0) with p
proportional to its importance, power / (d^2 + 1) for d the distance from the pixel to the
child's box of light centres (0 past its lights' longest reach), mixed with the uniform
choice (NODE_DEFENSIVE).  At the leaf it takes one light proportional to I / (d^2 + 1)
(d: pixel to light centre; 0 past the light's reach) mixed with the uniform choice
(cpu_prep.sampling.DEFENSIVE), so every leaf light keeps p > 0; a leaf of more than
LEAF_SCAN lights (a tile past max_leaves x lights_per_leaf) draws uniformly, keeping a
sample's loops in a driver's loop limit.  p is the product of the choices and the sample
adds f / (S p).  Yuksel descends with one random
number rescaled at each node; here each choice draws its own from the pixel's stream.

The support pass (figures only, untimed) is tree.glsl's exact traversal: every light of a
leaf the depth test reaches, i.e. every light a descent reaches with p > 0, evaluated; its
count and hash are held to brute's (the exactness check), the estimate to brute's
statistically (app.sampling_check).  `evaluated` is S where the pixel's tree reaches a leaf
(else 0); `nodes` counts the node records read: the root's once a pixel (is any leaf
reached?), then per descent the root and both children at each inner node.
"""
from dataclasses import dataclass

import numpy as np

from cpu_prep import layouts, limits, sampling, sample_tree as st

from ...errors import UserError
from ..base import Technique, grid_uniforms, prepare_binned, shading_pass, shading_passes
from ..blocks import SHARED_TREE_NODES, list_reads, tree_buffers
from ..options import ListOptions, SampleOptions, TileOptions, TreeOptions, sample_uniforms

READS = ("nodes", "sample_nodes", "depth_pieces")


def constants_glsl() -> str:
    """sample_tree.glsl: the descent's struct and constants, written once in cpu_prep.sample_tree."""
    return (layouts.glsl_struct("SampleNode", st.SAMPLE_NODE) + "\n"
            + layouts.glsl_defines({"SAMPLE_LEAF_SCAN": st.LEAF_SCAN})
            + f"const float SAMPLE_NODE_DEFENSIVE = {st.NODE_DEFENSIVE!r};\n"
            + f"const float SAMPLE_LEAF_DEFENSIVE = {sampling.DEFENSIVE!r};\n")


class SampleTree(Technique, register_at=94):
    name = "sample-tree"
    summary = "S light samples a pixel by stochastic descents of its tile's light tree (unbiased)"
    role = "sampler"
    views = Technique.views + ("tiles",)
    glsl = {"sample_tree.glsl": constants_glsl()}

    @dataclass(frozen=True)
    class Options(TileOptions, ListOptions, TreeOptions, SampleOptions):
        pass

    def build(self, frame, opts):
        b, offsets, entries = prepare_binned(frame, opts, 1, opts.sort_buckets)
        tree_buffers(b, offsets, entries, np.ones(b.grid.cells, bool), opts, frame.arena)
        with b.times.stage("sample_nodes"):
            nodes, pieces, levels = st.sample_nodes(b.buffers["nodes"], b.buffers["entries"],
                                                    b.lights.gpu)
        b.buffers["sample_nodes"], b.buffers["depth_pieces"] = nodes, pieces
        b.stats["depth_pieces"] = len(pieces)
        leaf, count, _ = layouts.unpack_node_bits(b.buffers["nodes"]["bits"])
        check_loops(frame, opts, levels, nodes["pieces"][:, 1], count[leaf])
        return b

    def passes(self, build, opts):
        defines = {"LIGHTS_DUPLICATED": int(opts.duplicated),
                   "SAMPLE_MASS_BITS": sampling.MASS_BITS, "SHARED_TREE_NODES": SHARED_TREE_NODES}
        reads = list_reads(opts.duplicated) + READS
        grid = grid_uniforms(build.grid)
        return [shading_pass(build, "sample_tree.comp", reads, defines=defines,
                             uniforms=dict(grid, **sample_uniforms(opts)))
                ] + shading_passes(build, "sample_tree_support.comp", reads, build.longest_list,
                                   uniforms=grid, steps=limits.NODE_MAX_SKIP + 1, defines=defines,
                                   name="support", waves_cleared=False, timed=False, figures=True)


def sample_loop_bound(samples: int, levels, piece_counts, leaf_counts) -> int:
    """The most loop iterations one invocation of sample_tree.comp runs: per sample, per
    level its two children's piece searches (log2 + 1 each) and the step, and the leaf's two
    passes over its lights (none past LEAF_SCAN: those draw uniformly)."""
    deepest = int(np.max(levels, initial=0))
    search = int(np.ceil(np.log2(max(int(np.max(piece_counts, initial=1)), 1) + 1))) + 1
    counts = np.asarray(leaf_counts)
    scan = int(counts[counts <= st.LEAF_SCAN].max(initial=0))
    return samples * (deepest * (2 * search + 1) + 2 * scan + 1)


def check_loops(frame, opts, levels, piece_counts, leaf_counts) -> None:
    """A frame whose descents could pass the driver's loop limit is refused with one line
    (the sampling pass is one dispatch: a sample cannot be split over windows)."""
    samples = sample_uniforms(opts)["u_samples"]
    bound = sample_loop_bound(samples, levels, piece_counts, leaf_counts)
    if frame.loop_budget is not None and bound > frame.loop_budget:
        raise UserError(f"sample-tree: {samples} descents of trees {int(np.max(levels))} "
                        f"levels deep may loop {bound} times a pixel, past this driver's loop "
                        f"limit ({frame.loop_budget}): fewer samples or a smaller leaf cap")
