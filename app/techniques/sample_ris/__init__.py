"""sample-ris: resampled importance sampling of a pixel's lights (Talbot et al. 2005,
"Importance resampling for global illumination"), as ReSTIR DI's first and spatial passes
(Bitterli et al. 2020, "Spatiotemporal reservoir resampling for real-time ray tracing with
dynamic direct lighting"), over the cluster lists and integer CDF that sample-list draws
from (app/techniques/sampling.py, cpu_prep.sampling).

Per shading pixel and reservoir (S = --light-samples, averaged), one round of passes:

    shade       the candidates (ris_candidates.comp): M (--candidates) lights drawn from the
                pixel's cell by the source pdf p (the cell's CDF words), each weighted
                w = p-hat / p with p-hat the luminance of its unshadowed contribution at the
                pixel; one kept by weighted reservoir sampling (Algorithms 2 and 3),
                W = (1 / p-hat(y)) (1 / M) sum w                           -> ris_reservoirs
    spatial     (--spatial-reuse biased | unbiased) k neighbours' reservoirs within a radius,
                the paper's normal and depth test, combined by Algorithm 4 (1 / M: biased
                where a neighbour cannot draw what this pixel can, i.e. darker) or 6
                (1 / Z: unbiased)                                           -> ris_reused
    resolve     the final shading: f(y) W added to the pixel's sum; the last round stores
                the mean (the frame outputs, store_estimate)

A pixel whose cell holds no light adds nothing (no light there affects it: clustered's lists
are exact).  One reservoir a pixel at a time, S rounds: the reservoir buffers stay one
record a pixel (32 bytes) at any S, as the paper's one-reservoir frame does (past the
storage-block limit, llvmpipe's 128 MiB at about 4.2 M pixels, the renderer refuses the
buffer in one line).  The candidates pass is named "shade": it is the pass that evaluates
lights, the one the cost model's replay (replay.py) stands for.

`evaluated` counts the target's evaluations: M a reservoir, plus the spatial pass's p-hat
of each neighbour's sample here and, unbiased, of the kept sample at each neighbour; the
resolve costs none (it reuses f(y), kept with p-hat(y): this lab's lights cast no shadows,
so the contribution is the target's own vector; a renderer with shadows traces one ray
there).

Departures from the paper: S independent rounds of one reservoir each (the paper keeps one
reservoir a pixel; S > 1 here averages S such estimates, as sample-list's S samples); a
neighbour that fails the similarity test is skipped, not redrawn.  Temporal reuse is left
out: it combines each pixel's reservoir with the previous frame's at the reprojected pixel,
which needs last frame's reservoirs (and its G-buffer and motion, to reproject and test
similarity) kept across frames, and the renderer lets a pass read only what this frame
provided (app/pipeline/renderer.py), by design.

The support pass is sample-list's (app/techniques/sampling.py): every light of the cell with
nonzero source mass can be a candidate, so the exactness check holds its affecting set to
brute's; the estimate is held to brute statistically (app.sampling_check) with spatial reuse
off or unbiased; biased is consistent only (its error falls as S grows; the check fails it).
"""
from dataclasses import dataclass

import numpy as np

from cpu_prep import layouts

from ...pipeline.passes import Buffer, Pass, frame_outputs, image_groups
from ..base import Technique, grid_uniforms
from ..options import SampleOptions, SliceOptions, choice, option, sample_uniforms
from ..sampling import LIST_READS, SAMPLE_DEFINES, build_sample_lists, support_passes

# One reservoir (ris.glsl): the kept light (index into lights[], NO_LIGHT: none), the
# candidates it stands for, the pixel's evaluations this round, W, p-hat(y) and f(y) here.
RESERVOIR = np.dtype([("light", np.uint32), ("M", np.uint32), ("evaluated", np.uint32),
                      ("W", np.float32), ("p_hat", np.float32), ("f_r", np.float32),
                      ("f_g", np.float32), ("f_b", np.float32)])
NO_LIGHT = 0xFFFFFFFF
SPATIAL = ("off", "biased", "unbiased")
REUSED, RESERVOIRS = "ris_reused", "ris_reservoirs"
# the passes after the candidates' read no lists (lists.glsl's define)
UNLISTED = {k: v for k, v in SAMPLE_DEFINES.items() if k != "LIGHTS_DUPLICATED"}


def structs_glsl() -> str:
    return (layouts.glsl_struct("Reservoir", RESERVOIR) + "\n"
            + layouts.glsl_defines({"RIS_NO_LIGHT": NO_LIGHT}))


class SampleRis(Technique, register_at=93):
    name = "sample-ris"
    summary = "RIS: M candidates a reservoir from the cluster's CDF, one kept ~ p-hat (ReSTIR DI)"
    role = "sampler"
    paper = ("Bitterli et al. 2020, \"Spatiotemporal reservoir resampling for real-time ray "
             "tracing with dynamic direct lighting\" (its RIS and spatial passes); Talbot et al. "
             "2005, \"Importance resampling for global illumination\"")
    views = Technique.views + ("tiles", "slices")
    stereo_union = "structure"     # the clustered grid and its CDF words, shared by the eyes
    glsl = {"ris_structs.glsl": structs_glsl()}

    @dataclass(frozen=True)
    class Options(SliceOptions, SampleOptions):
        candidates: int = option(8, "RIS candidates a reservoir, drawn by the cell's CDF (M)",
                                 lo=1, hi=256, study=(1, 2, 4, 8, 16, 32, 64))
        spatial_reuse: int = choice("off", SPATIAL, "ReSTIR spatial reuse of k neighbours' "
                                    "reservoirs (biased: Algorithm 4, 1/M, darker where a "
                                    "neighbour cannot draw this pixel's lights; unbiased: "
                                    "Algorithm 6, 1/Z)", study=True)
        # no study of k or the radius: a study sets one option over the defaults, where
        # spatial reuse is off and both are ignored (Options.ignored)
        reuse_neighbours: int = option(5, "neighbours a reservoir combines (k; the paper: 5)",
                                       lo=1, hi=32)
        reuse_radius: float = option(30.0, "radius of the neighbours' disk, pixels (the paper: "
                                           "30)", lo=1.0, hi=512.0)

        def ignored(self):
            if self.spatial_reuse:
                return {}
            why = "without spatial reuse (--spatial-reuse off)"
            return {"reuse_neighbours": why, "reuse_radius": why}

    def build(self, frame, opts):
        return build_sample_lists(frame, opts)

    def passes(self, build, opts):
        steps = []
        for k in range(opts.light_samples):
            steps += reservoir_round(build, opts, k)
        return steps + support_passes(build)


def reservoir_round(build, opts, k: int) -> list:
    """Reservoir k's passes: its candidates ("shade": the pass that evaluates lights, the one
    the cost model's replay stands for), spatial reuse (if on), its resolve."""
    w, h = build.frame.size
    sampled = dict(sample_uniforms(opts), u_reservoir=k)
    grid = dict(grid_uniforms(build.grid), **sampled)
    record = Buffer(w * h * RESERVOIR.itemsize, RESERVOIR)
    bound = frame_outputs(w, h, waves_cleared=False)     # common.glsl binds them; not written

    def step(name, shader, reads, writes, uniforms, sources):
        return Pass(name, shader, reads=("lights",) + reads, writes=writes,
                    groups=image_groups(w, h), uniforms=uniforms, sources=sources,
                    defines=SAMPLE_DEFINES if "ranges" in reads else UNLISTED)
    steps = [step("shade", "ris_candidates.comp", LIST_READS, dict(bound, ris_out=record),
                  dict(grid, u_candidates=opts.candidates), {"ris_out": RESERVOIRS})]
    last = RESERVOIRS
    if opts.spatial_reuse:
        unbiased = int(opts.choice_name("spatial_reuse") == "unbiased")
        steps.append(step("spatial", "ris_spatial.comp", ("ris_in",), dict(bound, ris_out=record),
                          dict(sampled, u_neighbours=opts.reuse_neighbours,
                               u_reuse_radius=float(opts.reuse_radius), u_unbiased=unbiased),
                          {"ris_in": RESERVOIRS, "ris_out": REUSED}))
        last = REUSED
    steps.append(step("resolve", "ris_resolve.comp", ("ris_in",),
                      frame_outputs(w, h, waves_cleared=k == 0), grid, {"ris_in": last}))
    return steps
