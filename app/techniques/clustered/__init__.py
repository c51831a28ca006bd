"""clustered (Persson 2013, "Practical clustered shading"): a 2.5D frustum grid of screen
tiles x depth slices (a near slice, then exponential slices: tree paper listing 4), each
cell an index list of the lights whose conservative box of cells contains it.

    ranges[cell] = (first entry, count) -> entries[] (uint) -> lights[] (GpuLight)
    cell = (ty * tiles_x + tx) * slices + slice;   960x540 at 48 px, 16 slices: 3,520 cells

`scalarize` walks each wave's distinct cells one at a time (Drobot 2017, "hierarchical
container scalarized over containers"): the same lights per pixel, loads from a
wave-uniform address; the wave's scalar iterations (rounds + entries of every cell walked)
go to WAVE_STATS.iterations instead of the longest lane's loop.
"""
from dataclasses import dataclass


from ..base import Technique, grid_uniforms, prepare_binned, shading_passes
from ..blocks import list_buffers, list_reads
from ..gpu_build import BuildOptions, build_lists, on_gpu
from ..options import (CapOptions, FeatureVariantOptions, ListOptions, ScalarizeOptions, SliceOptions,
                      StochasticOptions, WaveOptions)
from .. import variants


class Clustered(Technique, register_at=30):
    name = "clustered"
    summary = "2.5D grid of index lists (Persson 2013)"
    views = Technique.views + ("tiles", "slices", "variants")
    stereo_union = "structure"     # a 2.5D grid: both eyes shade from the union camera's cells
    froxels = "cells"       # a fog scene: a froxel's candidates are the cells it overlaps

    @dataclass(frozen=True)
    class Options(SliceOptions, ListOptions, WaveOptions, ScalarizeOptions, CapOptions,
                  StochasticOptions, BuildOptions, FeatureVariantOptions):
        def ignored(self) -> dict[str, str]:
            """Only the scalarized walk uses wave operations (options.py's rule)."""
            out = dict(super().ignored())
            if not self.scalarize:
                out["native_wave"] = "without --scalarize (the per-lane loop has no wave operation)"
            return out

    def build(self, frame, opts):
        if on_gpu(opts):
            return build_lists(frame, opts, opts.slices, lambda b: self.passes(b, opts))
        b, offsets, entries = prepare_binned(frame, opts, opts.slices)
        with b.times.stage("pack"):
            list_buffers(b, offsets, entries, opts.duplicated)
        return b

    def passes(self, build, opts):
        # scalarized, the wave walks its cells one round each: its lanes' lists run at
        # different rounds (base.windows' steps)
        shade = shading_passes(build, "shade_clustered.comp", list_reads(opts.duplicated),
                               build.longest_list, steps=64 if opts.scalarize else 1,
                               defines={"LIGHTS_DUPLICATED": int(opts.duplicated),
                                        "SCALARIZED": int(opts.scalarize)},
                               uniforms=grid_uniforms(build.grid), native_wave=opts.native_wave)
        return variants.with_variants(build, opts, shade,
                                      variants.CellSource(variants.CELL_LISTS, ("ranges", "entries")))


