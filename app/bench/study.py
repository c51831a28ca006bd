"""A study of the sweep: one series of measurements, registered as a technique is
(app.techniques.base): defining a subclass adds it, and a preset names its studies in order.

    name      its key in STUDIES and its line in the timing (for a series of one results.csv
              study, that study: "growth", "gpu_build", "c_reference")
    Config    a frozen dataclass: what the study takes (a preset holds one a study, the
              sweep's overrides replace its fields: app.bench.presets); a study that renders
              the sweep's frames takes the frame settings they share (Shared) as its `shared`
    files     the files it writes itself, beside results.csv (temporal.csv, ...)
    sections  the report modules (app.report.<name>) that read its rows or its file
    run       run(out, sweep) -> rows: its rows for results.csv ([] for a study with its own
              file); `sweep` (app.bench.sweep.Sweep) holds what studies share: the log,
              the progress line, the scenes loaded

A run times each study (`timed`) and ends with one line a study: where its time went, by
phase (app.pipeline.phases) within it.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import time
from typing import Callable, ClassVar

from ..pipeline import phases
from ..results import write_csv

STUDIES: dict[str, type["Study"]] = {}


class Study:
    name: ClassVar[str] = ""
    files: ClassVar[tuple[str, ...]] = ()
    sections: ClassVar[tuple[str, ...]] = ()
    Config: ClassVar[type]

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        # a module run as a script (`python -m app.bench.gpu_build`) registers nothing: the
        # same module imported under its own name does
        if cls.name and cls.__module__ != "__main__":
            assert cls.name not in STUDIES, f"study {cls.name} registered twice"
            STUDIES[cls.name] = cls

    def __init__(self, config):
        self.config = config

    def run(self, out, sweep) -> list[dict]:
        raise NotImplementedError


class FileStudy(Study):
    """A study whose rows go to its own files (files), none to results.csv: run() calls its
    module's series(config, out, log)."""
    series: ClassVar[Callable]

    def run(self, out, sweep) -> list[dict]:
        type(self).series(self.config, Path(out), sweep.log)
        return []


def series_files(out, names: tuple[str, ...], runs: bool) -> tuple[Path, ...] | None:
    """A file study's paths in `out` (the folder made), or None where it has nothing to run:
    its stale files removed, so a report never reads an earlier run's."""
    paths = tuple(Path(out) / n for n in names)
    if not runs:
        for p in paths:
            p.unlink(missing_ok=True)
        return None
    Path(out).mkdir(parents=True, exist_ok=True)
    return paths


def study_scene(name: str, lights: int, seed: int):
    """A study's scene: a builtin scene or variant at `lights` lights drawn with `seed`; a
    scene file with its own lights."""
    from scenes import BUILTIN_SCENES, BUILTIN_VARIANTS, load_scene
    builtin = name in BUILTIN_SCENES or name in BUILTIN_VARIANTS
    return load_scene(name, lights=lights if builtin else None, seed=seed if builtin else 0)


def write_series(rows: list[dict], path: Path, columns, log, also: str = "") -> None:
    """A file study's CSV, and its line in the log (`also`: the other files it wrote)."""
    write_csv(rows, path, columns)
    log.write(f"bench: wrote {path} ({len(rows)} rows){' and ' + also if also else ''}\n")


@dataclass(frozen=True)
class Shared:
    """The frame settings the studies that render the sweep's frames share: the rendered
    size, scenes, light counts, camera-path frames and timing samples, the option studies'
    scene and light count (frame 0; option_studies False: none), the scenes' seed and the
    CPU stage's numba threads (0: numba's default)."""
    size: tuple[int, int]
    scenes: tuple[str, ...]
    lights: tuple[int, ...]
    frames: int                   # frames sampled evenly along the camera-path loop
    repeat: int                   # timing samples of a configuration
    study_scene: str
    study_lights: int
    option_studies: bool = True   # the options' declared studies (app.results.option_studies)
    seed: int = 0
    threads: int = 1


@dataclass(frozen=True)
class CountSeries:
    """The config of a series over light counts in one scene at one size (lights (): none),
    `repeat` samples of each; a study's Config adds its own fields."""
    scene: str
    lights: tuple[int, ...]
    size: tuple[int, int]
    repeat: int


def timed(studies, out, sweep, by_phase: dict | None = None) -> tuple[list[dict], dict[str, float]]:
    """Run each study in order: (their rows in that order, {study: wall seconds});
    `by_phase`, when given, gets {study: {phase: seconds}} (app.pipeline.phases: compile, render,
    timing, build, check, replay ...; "other" the rest of the study's wall time)."""
    rows, seconds = [], {}
    for study in studies:
        t0, before = time.perf_counter(), phases.snapshot()
        rows += study.run(out, sweep)
        wall = time.perf_counter() - t0
        seconds[study.name] = seconds.get(study.name, 0.0) + wall
        if by_phase is not None:
            spent = by_phase.setdefault(study.name, {})
            for k, v in phases.since(before).items():
                spent[k] = spent.get(k, 0.0) + v
            spent["other"] = max(seconds[study.name] - sum(v for k, v in spent.items()
                                                           if k != "other"), 0.0)
    return rows, seconds


def time_lines(seconds: dict[str, float], by_phase: dict | None = None) -> list[str]:
    """One line a study: its wall time and its share of the studies' total, then (by_phase)
    its phases, the longest first."""
    total = sum(seconds.values()) or 1.0
    width = max((len(k) for k in seconds), default=0)
    return [f"bench: time: {k:{width}} {s:8.1f} s {100 * s / total:5.1f}%"
            + phase_text((by_phase or {}).get(k, {}), " (", ")")
            for k, s in seconds.items()]


def phase_text(spent: dict[str, float], before: str = "", after: str = "") -> str:
    """'compile 1.2 s, render 3.4 s, ...' the longest first ('' for none)."""
    items = sorted(((k, v) for k, v in spent.items() if v >= 0.05), key=lambda kv: -kv[1])
    if not items:
        return ""
    return before + ", ".join(f"{k} {v:.1f} s" for k, v in items) + after


__all__ = ["Study", "STUDIES", "Shared", "CountSeries", "timed", "time_lines", "phase_text"]
