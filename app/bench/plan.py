"""What the sweep measures: the jobs (configurations) of a preset, in order.

Which techniques an option study covers comes from the options' declarations
(app.results.option_studies: every option with study values, over the techniques that
declare it), and the exactness reference from its role: nothing here names a technique.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..results import option_studies
from ..techniques import REGISTRY, with_role
from ..techniques.options import TechniqueOptions
from .cutoff import STOCHASTIC_BUDGETS, STOCHASTIC_TECHNIQUES


@dataclass(frozen=True)
class Job:
    study: str                    # "path", "cutoff" or an option's name
    scene: str
    lights: int
    frame: int
    technique: str                # a REGISTRY id
    opts: TechniqueOptions        # that technique's own Options
    cutoff: int = 0               # 0: the scene's own radii; -1: unbounded reference; t = 1/cutoff
                                  # (a stochastic job of the cutoff study: 0, opts.stochastic N)

    def describe(self) -> str:
        if self.study == "cutoff":
            budget = getattr(self.opts, "stochastic", 0)
            extra = "unbounded" if self.cutoff < 0 else f"stochastic t=1/{budget}" if budget \
                else f"t=1/{self.cutoff}"
        elif self.study == "caps":
            extra = self.opts.choice_name("cap_policy")
        elif self.study.split("@")[0] in self.opts.as_dict():
            name = self.study.split("@")[0]
            extra = f"{name}={getattr(self.opts, name)}"
        else:
            extra = ""
        return f"{self.study} {self.scene} {self.lights} lights f{self.frame} {self.technique} {extra}".strip()


def technique_order() -> list[str]:
    """Every technique, the exactness reference first (the others' checks need its frame)."""
    ref = with_role("reference").name
    return [ref] + [t for t in REGISTRY if t != ref]


def study_scene(p, spec) -> str:
    """Where an option's study runs: its own study scene when the run has it, else the
    run's study scene (p: the studies' Shared config)."""
    return spec.study_scene if spec.study_scene in p.scenes else p.study_scene


def plan(c, light_counts: Callable[[str, tuple], tuple[int, ...]]) -> list[Job]:
    """The rendered study's jobs (c: its RenderedConfig, app.bench.rendered);
    `light_counts(scene, counts)` gives the light counts a scene is run with (a scene file
    has its own)."""
    p = c.shared
    names = technique_order()
    ref = names[0]
    default = {t: REGISTRY[t].Options() for t in names}
    jobs: list[Job] = []
    for scene in p.scenes:
        for n in light_counts(scene, p.lights):
            for f in range(p.frames):
                jobs += [Job("path", scene, n, f, t, default[t]) for t in names]
        n = light_counts(scene, (p.study_lights,))[0]
        for study, (spec, techs) in (option_studies().items() if p.option_studies else ()):
            if scene == study_scene(p, spec):
                for v in spec.study:
                    jobs += [Job(study, scene, n, 0, t, default[t].with_(**{study: v}))
                             for t in techs]
        if scene in c.cutoff_scenes:
            n = light_counts(scene, (c.cutoff_lights,))[0]
            jobs.append(Job("cutoff", scene, n, 0, ref, default[ref], cutoff=-1))
            for k in c.cutoffs:
                jobs += [Job("cutoff", scene, n, 0, t, default[t], cutoff=k) for t in names]
            jobs += [Job("cutoff", scene, n, 0, t, default[t].with_(stochastic=k))
                     for k in STOCHASTIC_BUDGETS for t in STOCHASTIC_TECHNIQUES if t in default]
    # studies that also run in a scene of their own (OptionSpec.also_study), rendered last
    for study, (spec, techs) in (option_studies().items() if p.option_studies and c.also_studies
                                 else ()):
        for scene in spec.also_study:
            n = light_counts(scene, (p.study_lights,))[0]
            for v in spec.study:
                jobs += [Job(f"{study}@{scene}", scene, n, 0, t, default[t].with_(**{study: v}))
                         for t in techs]
    return jobs
