"""What the sampling techniques (role "sampler") share: the cluster lists with their
sampling CDF (cpu_prep.sampling) and the support pass over them (glsl/sampling.glsl), so
that sample-list and sample-ris draw from one structure."""
from __future__ import annotations

from cpu_prep import sampling

from .base import grid_uniforms, prepare_binned, shading_passes
from .blocks import list_buffers

LIST_READS = ("ranges", "entries", "sample_cdf")
SAMPLE_DEFINES = {"LIGHTS_DUPLICATED": 0, "SAMPLE_MASS_BITS": sampling.MASS_BITS}


def build_sample_lists(frame, opts):
    """Clustered's lists (no duplicated copies) and the sampling CDF of every cell."""
    b, offsets, entries = prepare_binned(frame, opts, opts.slices)
    with b.times.stage("pack"):
        list_buffers(b, offsets, entries, False)
    with b.times.stage("sample_cdf"):
        b.buffers["sample_cdf"] = sampling.list_cdf(offsets, entries, b.lights.gpu, b.grid,
                                                    frame.camera)
    return b


def support_passes(build) -> list:
    """The support pass (untimed, figures only): every cell light of nonzero mass evaluated,
    its affecting set's count and hash written (glsl/sampling.glsl), in the dispatch windows
    of the longest list; the estimate's outputs and wave statistics kept."""
    return shading_passes(build, "sample_support.comp", LIST_READS, build.longest_list,
                          defines=SAMPLE_DEFINES, uniforms=grid_uniforms(build.grid),
                          name="support", waves_cleared=False, timed=False, figures=True)
