"""A technique's parts beside its frame: the `replay` module of its folder (what the GPU
cost model needs) and its `paper` module (the report's notes).  The frame never imports
them (it stays free of app.model); the model and the report find them here by the
technique's own package, so adding a technique stays one new folder."""
from __future__ import annotations

from importlib import import_module
from importlib.util import find_spec


def part(technique, name: str):
    """The module `name` of the technique's folder, or None (none there, or a technique
    defined in a plain module, as tests do)."""
    full = f"{type(technique).__module__}.{name}"
    try:
        found = find_spec(full)
    except ModuleNotFoundError:          # the technique's module is no package
        return None
    return import_module(full) if found else None


def wave_program(technique, frame, width: int):
    """app.model.waves.Program of the technique's shading pass on waves of `width` lanes."""
    replay = part(technique, "replay")
    if replay is None:
        raise NotImplementedError(f"{technique.name} has no wave replay (its folder's replay.py)")
    return replay.wave_program(technique, frame, width)


def cull_figures(technique, frame, width: int) -> dict:
    """{timed pass name: app.model.waves.Figures} of the GPU passes before the shading pass
    (none: a structure the CPU built)."""
    figures = getattr(part(technique, "replay"), "cull_figures", None)
    return figures(technique, frame, width) if figures else {}


def report_notes(technique, rows) -> tuple[str, str]:
    """(title, markdown) of its paper's figures beside a benchmark run's, from this
    technique's results rows (its meta stats in the `stats` column, JSON); empty text: no
    section (app.report.notes)."""
    notes = getattr(part(technique, "paper"), "report_notes", None)
    return notes(technique, rows) if notes else ("", "")
