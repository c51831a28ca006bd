"""What a technique's own paper measured, set beside this run's figures: each technique may
provide `report_notes(rows) -> (title, markdown text)`, reading its results rows (its meta
stats are the `stats` column, JSON).  The report calls every registered technique that
has one; nothing here names a technique."""
from __future__ import annotations


def technique_notes(rows) -> list[tuple[str, str]]:
    from ..techniques import REGISTRY
    out = []
    present = {r["technique"] for r in rows}
    for name, t in REGISTRY.items():
        notes = getattr(t, "report_notes", None)
        if notes is None or name not in present:
            continue
        title, text = notes([r for r in rows if r["technique"] == name])
        if text:
            out.append((f"{name}: {title}", text))
    return out
