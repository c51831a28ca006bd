"""The feature-variant study (`--feature-variants`, app/techniques/variants.py): per scene
it was run in (the option's study scene and its also_study ones, results.csv's studies
"feature_variants" and "feature_variants@<scene>") and per technique, the GPU time with
variants on against off, the variants (programs) and tiles per variant of the frame, and
the share of shading pixels whose program compiled specular code or a light shape their
cell does not need, with variants and with the one general program.  The time ratios are
this run's (llvmpipe: ratios, not absolute claims); the shares are hardware-neutral."""
from __future__ import annotations

import json

from .common import num, order, sel
from .spread import Spread, ratio_phrase

STUDY = "feature_variants"


def _stats(row) -> dict:
    return json.loads(row.get("stats") or "{}")


def variant_rows(rows, study: str):
    """(technique, on row, off row) of one study of the option, in the registry's order."""
    sub = sel(rows, study=study)
    for t in order(sub, "technique"):
        on = [r for r in sel(sub, technique=t) if num(r.get(STUDY)) == 1.0]
        off = [r for r in sel(sub, technique=t) if num(r.get(STUDY)) == 0.0]
        if on and off:
            yield t, on[0], off[0]


def pct(v) -> str:
    return f"{100 * num(v):.1f}%"


def variant_notes(rows) -> tuple[str, str]:
    """(title, markdown) of the study; empty text when the rows hold none of it."""
    studies = [s for s in order(rows, "study") if s.split("@")[0] == STUDY]
    text = []
    for study in studies:
        lines = list(variant_rows(rows, study))
        if not lines:
            continue
        r0 = lines[0][1]
        text += [f"{r0['scene']}, {int(num(r0['lights']))} lights, {int(num(r0['width']))}x"
                 f"{int(num(r0['height']))}, frame {int(num(r0['frame']))}:", "",
                 "| technique | GPU cull + shade, on / off | variants (programs) | tiles per "
                 "variant, most / fewest (of all) | specular code not needed, on / off | shape "
                 "code not needed, on / off | fallback |", "|---|---|---|---|---|---|---|"]
        for t, on, off in lines:
            s = _stats(on)
            r = Spread.of(on, "gpu_lighting").ratio(Spread.of(off, "gpu_lighting"))
            text.append(
                f"| {t} | {ratio_phrase(r)} | {s.get('feature_variants', 0):.0f} of "
                f"{s.get('variant_masks_seen', 0):.0f} masks | {s.get('variant_tiles_most', 0):.0f} / "
                f"{s.get('variant_tiles_fewest', 0):.0f} ({s.get('variant_tiles_total', 0):.0f}) | "
                f"{pct(s.get('variant_specular_waste'))} / {pct(s.get('variant_specular_waste_off'))} | "
                f"{pct(s.get('variant_shape_waste'))} / {pct(s.get('variant_shape_waste_off'))} | "
                f"{'yes' if s.get('feature_variants', 0) < s.get('variant_masks_seen', 0) else 'none'} |")
        text.append("")
    if not text:
        return "", ""
    head = ("Each tile shaded by the program of its own feature mask (HDRP's deferred feature "
            "variants, dispatched indirectly) against the one program of the frame's features. "
            "A pixel counts as running code it did not need when its program compiled GGX while "
            "its surface is matte, or a light shape its cell's list does not hold. The GPU time "
            "on includes the classification passes (variant_cells, variant_classify, "
            "variant_compact; fptl runs no variant_cells: its list pass writes each cell's "
            "shape word, in its list-building time). The GPU cost model (app/model) counts "
            "the classification passes but no saving in the shading pass: it already charges "
            "a shape's or GGX's code to a wave only where one of its lanes needs it, so what "
            "variants save on a GPU, the smaller program's registers and occupancy, is "
            "outside it.")
    return "feature variants (HDRP deferred)", "\n".join([head, ""] + text).rstrip()
