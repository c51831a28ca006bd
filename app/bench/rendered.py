"""The rendered study: every configuration the sweep renders and times (app.bench.plan: the
path, the option studies, the light cutoff; app.bench.caps: the light caps), measured by
app.bench.sweep.Sweep; rows of results.csv (the report's GPU, cutoff, trade-off and
heat-map sections)."""
from __future__ import annotations

from dataclasses import dataclass

from .study import Shared, Study

REPLAY_BUDGET = 4_000_000     # lane iterations a width (replay_budget's default)


@dataclass(frozen=True)
class RenderedConfig:
    shared: Shared                # the size, scenes, counts, frames, samples, option studies
    study_repeat: int             # timing samples of an option study's configuration (its one
                                  # frame is all it has: with 3 samples, 1 in 10 comparisons of
                                  # two identical configurations passes the min-max rule, with
                                  # 5 under 1%)
    heavy_repeat: int             # samples of one evaluating > heavy_eval_pp lights a pixel
    heavy_eval_pp: float
    cutoffs: tuple[int, ...]      # light cutoff t = 1 / value, relative to the brightest light
    cutoff_scenes: tuple[str, ...]
    cutoff_lights: int
    heat_scene: str               # the frame of the heat maps and classification (figures 1, 3)
    also_studies: bool = True     # the option studies' second scenes (OptionSpec.also_study)
    # the engines' light caps (app.bench.caps): every list technique at each cap policy
    # that drops lights, in caps_scenes at caps_lights (the cutoff study's count, so the
    # report's lead figure holds both); () none
    caps_scenes: tuple[str, ...] = ()
    caps_lights: int = 2048
    # the wave replay of a row walks about this many lane iterations (the lights and nodes
    # its pixels visited) a width: a heavier frame is replayed over a lattice of its 8x8
    # groups, scaled (app.model.predict.frame_figures)
    replay_budget: int = REPLAY_BUDGET
    # the path frames whose rows the wave replay models, the first of each path (0: every
    # frame): a section reads a path row's modelled columns on a real GPU alone (measured
    # against modelled), every row's counted steps on any (the first row of each program)
    model_frames: int = 0
    # studies whose rows the wave replay leaves out ("cutoff", "caps": their sections read
    # measured costs and errors, and their programs are the path's)
    unmodelled: tuple[str, ...] = ()
    # the wave replay's limit on a shading program's segments (0: none): a program past it
    # (sample-ris's CDF searches) is replayed over a sparser sample of 8x8 groups, scaled
    replay_segments: int = 0


class RenderedStudy(Study):
    name = "rendered"
    sections = ("tradeoff", "accuracy", "gpu", "path", "tables", "options", "maps", "cutoff")
    Config = RenderedConfig

    def run(self, out, sweep) -> list[dict]:
        return sweep.render_jobs(self.config)


__all__ = ["RenderedConfig", "RenderedStudy"]
