"""What a technique's own paper measured, set beside this run's figures: each technique may
provide `report_notes(rows) -> (title, markdown text)`, reading its results rows (its meta
stats are the `stats` column, JSON), and every technique's rows of the studies it names in
`report_studies` (a shared option's study, set beside another technique's rows: zbin's table
beside raster's rasterized tiles).
The report calls every registered technique (the base class's gives no text); nothing here
names a technique.  Studies of an option several
techniques share add their own section after them (app/report/variants.py)."""
from __future__ import annotations


def technique_notes(rows) -> list[tuple[str, str]]:
    from ..techniques import REGISTRY, parts
    out = []
    present = {r["technique"] for r in rows}
    for name, t in REGISTRY.items():
        if name not in present:
            continue
        title, text = parts.report_notes(t, _rows_of(rows, t))
        if text:
            out.append((f"{name}: {title}", text))
    from .variants import variant_notes
    title, text = variant_notes(rows)
    if text:
        out.append((title, text))
    return out


def _rows_of(rows, technique) -> list[dict]:
    """The technique's own rows, and every technique's rows of the studies it names in
    `report_studies` (study "<name>" or "<name>@<scene>")."""
    shared = set(getattr(technique, "report_studies", ()))
    return [r for r in rows if r["technique"] == technique.name or r["study"].split("@")[0] in shared]
