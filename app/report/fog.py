"""Fog lit from a froxel grid (app.bench.fog, DIR/fog.csv and DIR/fog_banding.npz): per technique
that serves froxels, what its froxel light sets cost (CPU ms of the sets, GPU ms of the fog
passes, with their spread), candidates and not-needed candidates per froxel on the frame's
grid and on the matched grid, exactness against brute's sets; the techniques that refuse a
fog scene; and the banding case (fog_banding.png: the centre-cell shortcut's image against
the exact one on the frame's grid and on the matched grid)."""
from __future__ import annotations

import math

import numpy as np

from .common import DPI, num, order, plt, save, sel
from .spread import Spread, spread_cell, lowest_phrase

CSV = "fog.csv"               # the study's files in the run's folder (app.bench.fog writes them)
BANDING = "fog_banding.npz"
PNG = "fog_banding.png"
KINDS = ("exact", "centre", "difference")

EXPLANATION = (
    "Frame 0 of a fog scene, its medium lit over a froxel grid (app/pipeline/fog.py): each "
    "froxel's light set is built on the CPU from the technique's own structure (froxels from: "
    "`all` every visible light, `cells` the lists of the 2.5D cells the froxel overlaps, "
    "`trees` the leaves of those cells' light trees whose depth interval overlaps the "
    "froxel's) and kept by the exact test; the GPU then lights each froxel from its set, "
    "marches the columns and composites the fog over the frame. Sets CPU ms: building the "
    "froxels' sets; + upload: with their upload; fog GPU ms: the three fog passes; frame ms "
    "without fog: the technique's own frame (CPU stage + timed passes but the G-buffer), for "
    "scale. Per froxel on average: the lights that meet it, the candidates its technique gave "
    "it, and those it did not need (candidates minus lights), on the frame's grid and on the "
    "matched grid (a froxel per cell of the technique's own grid: what a grid of its own "
    "slices would give; blank where the candidates are every visible light). Exact: froxels "
    "whose count or hash of its set differ from brute's on the same grid, and pixels that "
    "differ from brute's frame (both must be 0). Medians with [min-max] over the timing samples.")


_cell = spread_cell


def _fig(v) -> str:
    v = num(v)
    return "" if math.isnan(v) else f"{v:.3g}"


def _text(v) -> str:
    return v if isinstance(v, str) else ""


def exact_cell(row) -> str:
    froxels = int(num(row["froxel_mismatch"]))
    pixels = int(num(row["mismatch_count"]) + num(row["mismatch_hash"]))
    if not froxels and not pixels:
        return "yes"
    return "no (" + ", ".join(p for p in (f"{froxels} froxels" if froxels else "",
                                          f"{pixels} px" if pixels else "") if p) + ")"


def _table(served) -> str:
    lines = ["| technique | froxels from | sets CPU ms | sets + upload ms | fog GPU ms | frame ms "
             "without fog | lights / froxel | candidates / froxel | not needed / froxel | "
             "matched grid | not needed / froxel, matched | exact |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in served:
        lines.append(f"| {r['technique']} | {r['source']} | {_cell(r, 'sets_cpu', 1)} | "
                     f"{_cell(r, 'fog_cpu', 1)} | {_cell(r, 'fog_gpu')} | {_cell(r, 'frame_cost')} | "
                     f"{_fig(r['lights_pf'])} | {_fig(r['candidates_pf'])} | {_fig(r['unneeded_pf'])} | "
                     f"{_text(r.get('froxels_matched'))} | {_fig(r['unneeded_pf_matched'])} | "
                     f"{exact_cell(r)} |")
    return "\n".join(lines)


def _head(served) -> str:
    r0 = served[0]
    n = int(num(r0["samples"]))
    return (f"{r0['scene']}, {int(num(r0['lights'])):,} lights, {int(num(r0['width']))}x"
            f"{int(num(r0['height']))}, froxels {r0['froxels']} "
            f"({int(num(r0['froxel_count_total'])):,}), {n} timing sample{'' if n == 1 else 's'}:")


def banding_line(scene, bands) -> str:
    """The banding case's sentence: the shortcut's pixels off and largest error on each grid."""
    if not bands:
        return ""
    b0 = bands[0]
    parts = [f"on {'the matched grid' if r['grid'] == 'matched' else 'the ' + str(r['grid']) + ' grid'} "
             f"{100 * num(r['pixels_off']):.2f}% of the pixels are more than 1% off and its largest "
             f"error is {100 * num(r['error']):.3g}% of the brightest pixel" for r in bands]
    return (f"{scene}: the banding case, {b0['technique']}'s centre-cell shortcut (each froxel lit "
            f"from the list of the cell its centre falls in, unchecked: `--froxel-lookup centre`) "
            f"against its exact sets, the lights' radii x{num(b0['radius_scale']):g}, "
            f"{int(num(b0['froxel_samples']))} samples a froxel: " + "; ".join(parts) + ".")


def _lines(scene, mine) -> list[str]:
    text = []
    served = sel(mine, kind="froxels")
    cands = {r["technique"]: Spread.of(r, "sets_cpu") for r in served}
    if cands:
        text.append(f"{scene}: " + lowest_phrase(cands, "building the froxel sets") + ".")
    for r in served:
        if not math.isnan(num(r["unneeded_pf_matched"])):
            text.append(f"{scene}: {r['technique']}'s not-needed candidates a froxel: "
                        f"{_fig(r['unneeded_pf'])} on the {r['froxels']} grid, "
                        f"{_fig(r['unneeded_pf_matched'])} on its matched grid "
                        f"({_text(r.get('froxels_matched'))}).")
    bad = [r["technique"] for r in served if exact_cell(r) != "yes"]
    if served:
        text.append(f"{scene}: every serving technique's froxel sets and pixels equal brute's."
                    if not bad else f"{scene}: NOT exact: {', '.join(bad)}.")
    groups: dict[str, list[dict]] = {}     # refusals alike but for the technique's name
    for r in sel(mine, kind="refused"):
        groups.setdefault(str(r["refusal"]).replace(r["technique"], ""), []).append(r)
    for refused in groups.values():
        text.append(f"{scene}: refuse the fog frame: {', '.join(r['technique'] for r in refused)}"
                    f" (\"{refused[0]['refusal']}\").")
    line = banding_line(scene, sel(mine, kind="banding"))
    if line:
        text.append(line)
    return text


def fig_banding(out, scene, bands) -> str | None:
    """The banding case's images (fog_banding.npz): a row a grid, exact / shortcut /
    difference x10; None where the file or the scene's images are missing."""
    path = out / BANDING
    if not path.exists() or not bands:
        return None
    with np.load(path) as z:
        shown = {k: z[k] for k in z.files if k.startswith(f"{scene}/")}
    bands = [r for r in bands if f"{scene}/{r['grid']}/exact" in shown]
    grids = [str(r["grid"]) for r in bands]
    if not grids:
        return None
    p = plt()
    h, w = shown[f"{scene}/{grids[0]}/exact"].shape[:2]
    scale = 3.4 / w
    fig, axes = p.subplots(len(grids), 3, figsize=(3 * 3.4, len(grids) * (h * scale + 0.45)),
                           dpi=DPI, squeeze=False)
    titles = {"exact": "exact sets", "centre": "centre-cell shortcut",
              "difference": "|shortcut - exact| x10"}
    for i, (grid, r) in enumerate(zip(grids, bands)):
        for j, kind in enumerate(KINDS):
            ax = axes[i][j]
            ax.imshow(shown[f"{scene}/{grid}/{kind}"], interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            name = "matched grid" if grid == "matched" else f"{grid} grid"
            extra = (f"\n{100 * num(r['pixels_off']):.1f}% of pixels >1% off, largest "
                     f"{100 * num(r['error']):.2g}%" if kind == "difference" else "")
            ax.set_title(f"{name}: {titles[kind]}{extra}", fontsize=7)
    return save(fig, out, PNG)


def fog_section(rows, out=None) -> tuple[str | None, list[str], str]:
    """(the banding figure of the first scene, the section's lines, one table a scene)."""
    if not rows:
        return None, [], ""
    text, tables, png = [EXPLANATION], [], None
    for scene in order(rows, "scene"):
        mine = sel(rows, scene=scene)
        served = sel(mine, kind="froxels")
        if served:
            tables.append(_head(served) + "\n\n" + _table(served))
        text += _lines(scene, mine)
        if out is not None and png is None:
            png = fig_banding(out, scene, sel(mine, kind="banding"))
    return png, text, "\n\n".join(tables)


__all__ = ["fog_section", "fig_banding", "banding_line", "exact_cell", "CSV", "BANDING", "PNG",
           "EXPLANATION"]
