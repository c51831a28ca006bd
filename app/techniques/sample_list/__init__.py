"""sample-list: a fixed budget of S light samples a shading pixel, drawn from the pixel's
clustered cell list (the 2.5D grid clustered builds, Persson 2013) with probability
proportional to a cheap bound of each light over the cell, weighted 1/(S p): an unbiased
estimate of brute's radiance at every pixel, for S light evaluations however many lights the
cell holds (the sampling side of MegaLights-style renderers: a budget a pixel, not a list).

    ranges[cell] = (first entry, count) -> entries[] -> lights[]   (clustered's lists)
    sample_cdf[entry]: the cell's cumulative masses, 2^31 a cell (cpu_prep.sampling)

A sample draws u in [0, 2^31) and binary-searches its cell's words (log2 n reads), shades
that light and adds f / (S p); p = mass / 2^31, from the same words.  Every light of the
cell has mass >= 1 (a defensive mixture with the uniform distribution), so every light that
affects the pixel can be drawn: the support pass (figures only, untimed) walks the cell's
lights of nonzero mass and writes their affecting set's count and hash, which the exactness
check holds to brute's; the estimate itself is held to brute statistically
(app.sampling_check).
"""
from dataclasses import dataclass

from ..base import Technique, grid_uniforms, shading_pass
from ..options import SampleOptions, SliceOptions, sample_uniforms
from ..sampling import LIST_READS, SAMPLE_DEFINES, build_sample_lists, support_passes


class SampleList(Technique, register_at=92):
    name = "sample-list"
    summary = "S light samples a pixel from its cluster's list, p ~ a bound (unbiased)"
    role = "sampler"
    views = Technique.views + ("tiles", "slices")
    stereo_union = "structure"     # the clustered grid and its CDF words, shared by the eyes

    @dataclass(frozen=True)
    class Options(SliceOptions, SampleOptions):
        pass

    def build(self, frame, opts):
        return build_sample_lists(frame, opts)

    def passes(self, build, opts):
        return [shading_pass(build, "sample_list.comp", LIST_READS, defines=SAMPLE_DEFINES,
                             uniforms=dict(grid_uniforms(build.grid), **sample_uniforms(opts)))
                ] + support_passes(build)
