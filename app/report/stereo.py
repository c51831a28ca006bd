"""Two eyes, two ways (app.bench.stereo, DIR/stereo.csv): per technique, the per-view and the
union way's structure entries, bytes, CPU and GPU ms of the two-eye frame, and the ratio
union / per-view; a timing ratio is called a finding only beyond the measured spread
(app.report.spread)."""
from __future__ import annotations

import math

from .common import num, order, sel
from .spread import Spread, spread_cell, below

CSV = "stereo.csv"            # the study's file in the run's folder (app.bench.stereo writes it)

EXPLANATION = (
    "Both eyes of frame 0, the centre camera moved by -sep/2 and +sep/2 along its right "
    "vector. per-view: the technique's structure built once per eye. union: one CPU stage over "
    "the union camera (the centre pulled back by (sep/2)/tan(fov_x/2), its frustum holding both "
    "eyes'); what it shares is the technique's declaration: `structure` (the structure itself, "
    "each eye's shading mapping its pixels into the union camera's cells; only the light records "
    "are packed per eye) or `cull-sort` (a structure made per pixel of a view: screen tiles, "
    "per-tile trees, z-bins over tiles, rasterized tiles; only the CPU cull and sort are shared). "
    "Entries: structure list entries of the two-eye frame (blank: no lists). Bytes: culling "
    "buffers both eyes bind, shared ones once. CPU ms: the shared stage and both eyes' CPU "
    "stages (the renderer uploads a frame's buffers with each eye's frame, so a shared structure "
    "is uploaded twice: its upload is in both eyes' ms); GPU ms: both eyes' timed passes but the "
    "G-buffer; medians over the timing samples "
    "with [min-max]. Exact: pixels of both eyes whose contrib_count or contrib_hash differ from "
    "brute rendered in that eye (must be 0).")


_cell = spread_cell


def _count(v) -> str:
    v = num(v)
    return "" if math.isnan(v) else f"{int(v):,}"


def _ratio(a, b) -> str:
    a, b = num(a), num(b)
    return "" if math.isnan(a) or math.isnan(b) or b == 0 else f"{a / b:.2f}"


def _timing_ratio(u, p, base: str) -> str:
    su, sp = Spread.of(u, base), Spread.of(p, base)
    if math.isnan(su.med) or math.isnan(sp.med):
        return ""
    r = su.ratio(sp)
    word = "lower" if below(su, sp) else "higher" if below(sp, su) else "within spread"
    return f"{r.med:.2f} [{r.lo:.2f}-{r.hi:.2f}] {word}"


def stereo_section(rows) -> tuple[None, list[str], str]:
    """(no plot, the section's lines, its tables): one table a scene."""
    if not rows:
        return None, [], ""
    text, tables = [EXPLANATION], []
    for scene in order(rows, "scene"):
        mine = sel(rows, scene=scene)
        r0 = mine[0]
        head = (f"{scene}, {int(num(r0['lights'])):,} lights, {int(num(r0['width']))}x"
                f"{int(num(r0['height']))} an eye, eyes {num(r0['separation']):g} m apart, "
                f"{int(num(r0['samples']))} timing sample{'' if int(num(r0['samples'])) == 1 else 's'}:")
        lines = [head, "",
                 "| technique | union shares | way | entries | bytes | CPU ms | GPU ms | exact |",
                 "|---|---|---|---|---|---|---|---|"]
        for t in order(mine, "technique"):
            ways = {r["way"]: r for r in sel(mine, technique=t)}
            share = ways.get("union", {}).get("share", "")
            for way, r in ways.items():
                bad = int(num(r["mismatch_count"]) + num(r["mismatch_hash"]))
                lines.append(f"| {t} | {share} | {way} | {_count(r['entries'])} | "
                             f"{_count(r['bytes'])} | {_cell(r, 'cpu_total')} | "
                             f"{_cell(r, 'gpu_lighting')} | {'yes' if bad == 0 else f'no ({bad} px)'} |")
            if {"union", "per-view"} <= set(ways):
                u, p = ways["union"], ways["per-view"]
                lines.append(f"| {t} | {share} | union / per-view | {_ratio(u['entries'], p['entries'])} | "
                             f"{_ratio(u['bytes'], p['bytes'])} | {_timing_ratio(u, p, 'cpu_total')} | "
                             f"{_timing_ratio(u, p, 'gpu_lighting')} | |")
        tables.append("\n".join(lines))
        shared = [t for t in order(mine, "technique")
                  if any(r["way"] == "union" and r.get("share") == "structure"
                         for r in sel(mine, technique=t))]
        per = {t: {r["way"]: r for r in sel(mine, technique=t)} for t in shared}
        for t in shared:
            if {"union", "per-view"} <= set(per[t]):
                text.append(f"{scene}: {t} shares its structure: union / per-view entries "
                            f"{_ratio(per[t]['union']['entries'], per[t]['per-view']['entries'])}, "
                            f"CPU ms {_timing_ratio(per[t]['union'], per[t]['per-view'], 'cpu_total')}.")
    return None, text, "\n\n".join(tables)


__all__ = ["stereo_section", "CSV", "EXPLANATION"]
