"""--build cpu|gpu: where a technique's structures are built.

cpu (the default) is the CPU stage (cpu_prep, numba); gpu builds the same buffers, bit for
bit, as compute passes of the frame graph before the shading pass (app/gpu_build), timed
like every pass (meta gpu_ms: build_cull, build_sort, build_pack, build_bin, build_zbin,
build_tree; the readbacks of the counts that size the next steps in setup_ms).  The dump's
meta says which ran: options.build (the choice's index) and stats.build (its name).

Built on the GPU: the cull, depth sort and pack of every technique here; clustered's
binning; tree's per-tile trees with skip counts; hybrid's listing 2 and its trees; zbin's
Z-bin LUT and tile bit arrays.  Not offered with it (one line, exit 2): --duplicated, --stochastic and
--cap-policy, which the GPU build does not make (docs/cpu_stage.md).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from cpu_prep import caps, grid as gridmod, hybrid as hybridmod, limits, tree as treemod, zbin as zb

from ..errors import UserError
from ..pipeline import features as feat
from ..pipeline.passes import HostStep, Pass
from ..gpu_build import lists as gpulists, prepare, trees as gputrees, zbins as gpuzbins
from .base import check_cpu_light_rows, make_grid, windows
from .bit_arrays import variant_flags
from .options import TechniqueOptions, cap_policy, choice, stochastic

CPU, GPU = "cpu", "gpu"


@dataclass(frozen=True)
class BuildOptions(TechniqueOptions):
    build: int = choice(CPU, (CPU, GPU), "where the culling structures are built (cpu: the CPU "
                                         "stage; gpu: compute passes, bit for bit the same buffers)")

    def check_modes(self) -> None:
        super().check_modes()
        if self.choice_name("build") != GPU:
            return
        taken = [flag for flag, on in (
            ("--duplicated", getattr(self, "duplicated", False)),
            ("--stochastic", stochastic(self) is not None),
            ("--cap-policy", cap_policy(self) != caps.NONE),
            ("--sort-buckets", getattr(self, "sort_buckets", 0) > 0),
            ("--tree-build topdown", getattr(self, "tree_build", treemod.BUILD_BOTTOMUP) != treemod.BUILD_BOTTOMUP))
            if on]
        if taken:
            raise UserError(f"--build gpu with {', '.join(taken)}: not offered together (the GPU "
                            f"build sorts exactly, builds the paper's bottom-up trees and index "
                            f"lists of every visible light; use --build cpu)")

    def check_light_rows(self, frame, visible: int) -> None:
        """The light rows' limit where this build makes them (base.light_rows_refusal): the
        GPU's scene records and visible rows (prepare.check_lights), or the CPU stage's."""
        if self.choice_name("build") == GPU:
            prepare.check_lights(frame)
            prepare.check_lights(frame, visible)
        else:
            check_cpu_light_rows(visible)


def on_gpu(opts) -> bool:
    return isinstance(opts, BuildOptions) and opts.choice_name("build") == GPU


def with_visible_features(b, steps) -> list:
    """The technique's steps compiled for the shapes among the visible lights, as the CPU
    build's are: the renderer's features come from the lights it knows before the steps
    run (every scene type, for a build whose cull runs on the GPU), so each pass brings the
    visible set's features.glsl (a pass's own files, a feature variant's, still win) and
    each host step's later steps get the same."""
    files = feat.virtual_files(feat.feature_set(b.lights.type, b.frame.specular))
    out = []
    for s in steps:
        if isinstance(s, Pass):
            s = replace(s, virtual=dict(files, **s.virtual))
        elif isinstance(s, HostStep):
            s = replace(s, run=lambda read, run=s.run: _later(b, run(read)))
        out.append(s)
    return out


def _later(b, result):
    uploads, more = result
    return uploads, with_visible_features(b, more)


def build_lists(frame, opts, slices: int, shade):
    """A list technique's Build whose cull, sort and binning run on the GPU; its steps
    (build.steps, which the renderer runs in place of the technique's
    passes) end in `shade(b)`: the technique's own passes, once the longest list
    (b.longest_list) is known, then the lists read back for the figures."""
    grid = make_grid(frame, opts, slices)

    def after_pack(b):
        b.grid = grid
        return gpulists.bin_lists(b, lambda longest: with_visible_features(b, shade(b)) + [
            gpulists.readback_step(b, gpulists.list_readback(b))])
    b = prepare.start(frame, after_pack, cells=grid.cells)
    b.buffers["gb_slice_table"] = gpulists.slice_table(grid)
    return b


def build_bits(frame, opts, passes, check_depth_loops):
    """zbin's Build whose cull, sort, Z-bin LUT and tile bit arrays run on the GPU (its
    tile, grid, checks and stats as ZBin.build makes them, once the visible count is read
    back); its steps end in `passes(b)`: the technique's own (the tile depth test, the
    shading), then the structures read back for the figures.  check_depth_loops(frame,
    tile, lights): zbin's loop-budget check (passed in: zbin imports this module)."""
    masked, _ = variant_flags(opts.zbin_variant)
    capacity = len(frame.lights)

    def after_pack(b):
        n, (w, h) = len(b.lights), frame.size
        tile = zb.choose_tile(w, h, n, opts.bit_tile, opts.budget_bytes)
        b.grid = g = gridmod.make_grid(frame.camera, tile, 1, frame.max_depth,
                                       limits.DEFAULT_NEAR_SLICE_DEPTH)
        bits_bytes = 4 * g.tiles_x * g.tiles_y * zb.words_for(n)
        limits.check_buffer("zbin tile bit arrays", bits_bytes)
        if opts.tile_depth:
            check_depth_loops(frame, tile, n)
        lut = gpuzbins.lut_passes(b, opts.zbins, capacity) if masked else []
        wide = zb.is_wide(n)
        b.stats.update(
            variant=opts.choice_name("zbin_variant"), bit_tile_used=tile, tiles=g.tiles_x * g.tiles_y,
            words_per_tile=zb.words_for(n), bits_bytes=bits_bytes, zbins=opts.zbins if masked else 0,
            zbin_bytes=4 * opts.zbins * (2 if wide else 1) if masked else 0,
            zbin_id_bits=32 if wide else zb.ZBIN_ID_BITS)
        readback = dict(gpuzbins.bits_readback(b), **(gpuzbins.lut_readback(b, opts.zbins) if masked else {}))

        def filled(read):
            entries = int(read[prepare.COUNTERS][prepare.ENTRIES])
            return {}, ([gpuzbins.bits_pass(b, capacity, entries)] + with_visible_features(b, passes(b))
                        + [gpulists.readback_step(b, readback)])
        return lut + gpulists.box_passes(b, capacity) + [
            prepare.host("build_bin_entries", (prepare.COUNTERS,), filled)]
    b = prepare.start(frame, after_pack)
    b.buffers["gb_slice_table"] = gpulists.slice_table(gridmod.make_grid(
        frame.camera, opts.bit_tile, 1, frame.max_depth, limits.DEFAULT_NEAR_SLICE_DEPTH))
    return b


def build_trees(frame, opts, slices: int, shade, tree_bit: int | None = None):
    """tree's (every cell a tree) or hybrid's (tree_bit: its ranges' CELL_TREE_BIT; listing
    2 chooses) Build whose cull, sort, binning and trees run on the GPU; its steps end in
    `shade(b)`, then the trees read back for the figures."""
    grid = make_grid(frame, opts, slices)
    leaves = gputrees.frame_leaves(frame, opts)

    def after_pack(b):
        b.grid = grid

        def trees(longest):
            return gputrees.tree_passes(b, opts, leaves, tree_bit, lambda n: windows(frame, n),
                                        lambda: with_visible_features(b, shade(b)) + [
                                            gpulists.readback_step(b, gputrees.tree_readback(b))])
        return gpulists.bin_lists(b, trees, ranges=gputrees.LIST_RANGES)
    b = prepare.start(frame, after_pack, cells=grid.cells)
    b.buffers["gb_slice_table"] = gpulists.slice_table(grid)
    gputrees.upload_tables(b, leaves)
    if tree_bit is not None:
        b.buffers[gputrees.SLICE_DEPTHS] = np.column_stack(hybridmod.cell_depth_ranges(grid, frame.max_depth))
    return b
