"""What a technique's own paper measured, set beside this run's figures: each technique may
provide `report_notes(rows) -> (title, markdown text)`, reading its results rows (its meta
stats are the `stats` column, JSON).  The report calls every registered technique (the base
class's gives no text); nothing here names a technique.  Studies of an option several
techniques share add their own section after them (app/report/variants.py)."""
from __future__ import annotations


def technique_notes(rows) -> list[tuple[str, str]]:
    from ..techniques import REGISTRY
    out = []
    present = {r["technique"] for r in rows}
    for name, t in REGISTRY.items():
        if name not in present:
            continue
        title, text = t.report_notes([r for r in rows if r["technique"] == name])
        if text:
            out.append((f"{name}: {title}", text))
    from .variants import variant_notes
    title, text = variant_notes(rows)
    if text:
        out.append((title, text))
    return out
