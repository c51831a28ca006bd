"""The report's line on where the run's time went: each study's wall seconds and share of
the studies' total (run.json's study_s; not the report's own time, report_s, which is known
only once the report is written, so that a rebuilt report says the same), and within a study
its phases (run.json's phase_s,
app.pipeline.phases: compile, render, timing, build, check, replay, counts, other), the
longest first."""
from __future__ import annotations


def time_lines(info: dict) -> list[str]:
    """One report line a study, none where run.json has no study_s (an older run)."""
    spent = dict(info.get("study_s") or {})
    if not spent:
        return []
    total = sum(spent.values()) or 1.0
    by_phase = info.get("phase_s") or {}
    out = []
    for name, s in spent.items():
        items = sorted(((k, v) for k, v in (by_phase.get(name) or {}).items() if v >= 0.05),
                       key=lambda kv: -kv[1])
        inside = f": {', '.join(f'{k} {v:.1f} s' for k, v in items)}" if items else ""
        out.append(f"  - {name}: {s:.1f} s ({100 * s / total:.1f}%){inside}")
    return ["- where the time went (wall seconds a study, its share; its phases):"] + out


__all__ = ["time_lines"]
