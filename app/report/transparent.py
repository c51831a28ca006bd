"""Transparent layers (app.bench.transparent, DIR/transparent.csv): per technique, how it serves
the layers (looked up in its structure, or its structure rebuilt per layer), what the layers
cost over the same technique's opaque-only frame (CPU and GPU ms with their spread), the
bytes it writes again per layer, the waste per sample kind (an opaque pixel, a layer
fragment) and its exactness per layer; one figure (transparent.png) of the layers' GPU ms
beside the opaque frame's and of the waste per kind."""
from __future__ import annotations

import json
import math

from .common import DPI, log_axes, num, order, panel_style, plt, save, sel, side_legend
from .spread import Spread, spread_cell, below, lowest_phrase

CSV = "transparent.csv"       # the study's file in the run's folder (app.bench.transparent writes it)
PNG = "transparent.png"
LOOKED_UP = "looked up"       # the study's `serves` values (app.bench.transparent)
CULLING = "technique"         # the role of the culling techniques (app.techniques.base.ROLES)

EXPLANATION = (
    "Frame 0 of a scene with transparent surfaces, every technique, the frame with its layers "
    "against the same technique's opaque-only frame (the scene with its transparent meshes "
    "dropped: the same G-buffer, lights and structure). Layers: per pixel, the nearest "
    "transparent fragments in front of the opaque surface, peeled front to back, each shaded "
    "by the technique's own passes and composited back to front (app/pipeline/transparent.py). "
    "Serves: *looked up* (a structure built from the lights alone: each fragment reads its own "
    "cell of it, the CPU build is not redone) or *rebuilt per layer* (a structure its GPU passes "
    "bound by the depth they read: those passes run again over each layer's fragments). CPU ms: "
    "the CPU stage; extra CPU ms: the layered frame's minus the opaque-only frame's, a timing "
    "round's pair at a time (no layer redoes the CPU stage, so this is the spread of two equal "
    "stages). Extra GPU ms: the layers' own passes, the peel, the technique's passes over every "
    "layer and the compositing (the peel and compositing timed by this study with the "
    "renderer's timer: the renderer runs them untimed). With layers / opaque-only: the frame "
    "costs' ratio (CPU stage + timed GPU passes but the G-buffer), called higher only beyond "
    "the spread. Bytes a layer: what the technique's GPU passes write again over each layer "
    "(its rebuilt structure; a looked-up technique's per-pixel scratch; 0: none). Waste: "
    "lights evaluated / lights that affect the sample (exact), summed over the opaque pixels "
    "and over every layer's fragments; a sampler's evaluations are its draws. Exact: opaque "
    "pixels and every layer's fragments whose contrib_count or contrib_hash differ from "
    "brute's frame with layers (must be 0). Medians with [min-max] over the timing samples.")


_cell = spread_cell


def _text(v) -> str:
    """A text cell as read back ("" for a blank one, which reads as NaN)."""
    return v if isinstance(v, str) else ""


def _count(v) -> str:
    v = num(v)
    return "" if math.isnan(v) else f"{int(v):,}"


def _fig(v) -> str:
    v = num(v)
    return "" if math.isnan(v) else f"{v:.3g}"


def _kind(row, ev: str, ex: str, waste: str) -> str:
    return f"{_fig(row[ev])} / {_fig(row[ex])} ({_fig(row[waste])}x)"


def frame_ratio(row) -> str:
    """The layered frame's cost over the opaque-only frame's, with whether it is a finding."""
    a, b = Spread.of(row, "frame_cost"), Spread.of(row, "opaque_frame_cost")
    if math.isnan(a.med) or math.isnan(b.med):
        return ""
    r = a.ratio(b)
    word = "higher" if below(b, a) else "lower" if below(a, b) else "within spread"
    return f"{r.med:.2f} [{r.lo:.2f}-{r.hi:.2f}] {word}"


def exact_cell(row) -> str:
    """"yes", or the opaque pixels and the layers that differ from brute's."""
    bad = []
    opaque = int(num(row["mismatch_count"]) + num(row["mismatch_hash"]))
    if opaque:
        bad.append(f"opaque {opaque} px")
    for layer in json.loads(row.get("per_layer") or "[]"):
        if layer["mismatch"]:
            bad.append(f"layer {layer['layer']} {layer['mismatch']} px")
    if not bad and int(num(row["layer_mismatch_count"]) + num(row["layer_mismatch_hash"])):
        bad.append(f"layers {int(num(row['layer_mismatch_count']) + num(row['layer_mismatch_hash']))} px")
    return "yes" if not bad else "no (" + ", ".join(bad) + ")"


def _table(mine) -> str:
    lines = ["| technique | serves | opaque-only frame ms | CPU ms | extra CPU ms | opaque-only GPU ms "
             "| extra GPU ms (layers) | with layers / opaque-only | bytes a layer | opaque px: "
             "evaluated / exact (waste) | layer fragment: evaluated / exact (waste) | exact |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in mine:
        lines.append(f"| {r['technique']} | {r['serves']} | {_cell(r, 'opaque_frame_cost')} | "
                     f"{_cell(r, 'cpu_total')} | {_cell(r, 'extra_cpu')} | "
                     f"{_cell(r, 'opaque_gpu_lighting')} | {_cell(r, 'layers_gpu')} | "
                     f"{frame_ratio(r)} | {_count(r['layer_bytes'])} | "
                     f"{_kind(r, 'evaluated_pp', 'exact_pp', 'waste')} | "
                     f"{_kind(r, 'evaluated_pf', 'exact_pf', 'waste_layers')} | {exact_cell(r)} |")
    return "\n".join(lines)


def _head(r0) -> str:
    layers = json.loads(r0.get("per_layer") or "[]")
    frags = ", ".join(f"{layer['fragments']:,}" for layer in layers)
    n = int(num(r0["samples"]))
    return (f"{r0['scene']}, {int(num(r0['lights'])):,} lights, {int(num(r0['width']))}x"
            f"{int(num(r0['height']))}, {int(num(r0['layers']))} of at most "
            f"{int(num(r0['max_layers']))} layers used ({frags} fragments, front to back; "
            f"{int(num(r0['opaque_pixels'])):,} opaque pixels), {n} timing "
            f"sample{'' if n == 1 else 's'}:")


def _lines(scene, mine) -> list[str]:
    text = []
    how = {}
    for r in mine:
        how.setdefault(r["serves"], []).append(
            r["technique"] + (f" ({r['rebuilt']})" if _text(r.get("rebuilt")) else ""))
    for serves, names in how.items():
        text.append(f"{scene}: {serves}: {', '.join(names)}.")
    culling = [r for r in mine if r.get("role") == CULLING] or mine
    cands = {r["technique"]: Spread.of(r, "layers_gpu") for r in culling
             if not math.isnan(num(r["layers_gpu_ms"]))}
    if cands:
        among = " among the culling techniques" if culling is not mine else ""
        text.append(f"{scene}: " + lowest_phrase(cands, f"the layers' extra GPU time{among}") + ".")
    kinds = [(r["technique"], num(r["waste_layers"]) / num(r["waste"])) for r in mine
             if num(r["waste"]) > 0 and not math.isnan(num(r["waste_layers"]))]
    if kinds:
        hi = max(kinds, key=lambda k: k[1])
        lo = min(kinds, key=lambda k: k[1])
        text.append(f"{scene}: a layer fragment's waste against an opaque pixel's ranges from "
                    f"{lo[1]:.2f}x ({lo[0]}) to {hi[1]:.2f}x ({hi[0]}).")
    bad = [r["technique"] for r in mine if exact_cell(r) != "yes"]
    text.append(f"{scene}: every technique's opaque pixels and layers equal brute's."
                if not bad else f"{scene}: NOT exact: {', '.join(bad)}.")
    differs = [r["technique"] for r in mine if num(r.get("opaque_differs", 0)) > 0]
    if differs:
        text.append(f"{scene}: the opaque-only frame's opaque pixels differ from the layered "
                    f"frame's for {', '.join(differs)}.")
    return text


def fig_transparent(rows, out, scene) -> str:
    """Per technique: the opaque-only frame's GPU ms and the layers' extra GPU ms (bars,
    min-max whiskers), and the waste per opaque pixel and per layer fragment."""
    mine = sel(rows, scene=scene)
    p = plt()
    names = [r["technique"] for r in mine]
    y = list(range(len(names)))
    fig, (a, b) = p.subplots(1, 2, figsize=(11, 0.32 * len(names) + 1.6), dpi=DPI, sharey=True)
    for ax, pairs, xlabel, title in (
            (a, (("opaque_gpu_lighting", "opaque-only frame"), ("layers_gpu", "the layers (extra)")),
             "GPU ms (log)", "GPU time: the opaque frame and what the layers add"),
            (b, (("waste", "opaque pixel"), ("waste_layers", "layer fragment")),
             "lights evaluated / exact (log)", "Waste per sample kind")):
        for k, (base, label) in enumerate(pairs):
            off = [v + (k - 0.5) * 0.38 for v in y]
            if base.startswith("waste"):
                vals = [max(num(r[base]), 1e-3) for r in mine]
                ax.barh(off, vals, height=0.38, label=label)
            else:
                s = [Spread.of(r, base) for r in mine]
                vals = [max(x.med, 1e-3) for x in s]
                err = [[max(x.med - x.lo, 0) for x in s], [max(x.hi - x.med, 0) for x in s]]
                ax.barh(off, vals, height=0.38, xerr=err, capsize=2, label=label)
        log_axes(ax, x=True, y=False)
        panel_style(ax, title, xlabel)
    a.set_yticks(y)
    a.set_yticklabels(names, fontsize=7)
    a.invert_yaxis()
    a.legend(fontsize=7, loc="lower right")
    side_legend(b, fontsize=7)
    return save(fig, out, PNG)


def transparent_section(rows, out=None) -> tuple[str | None, list[str], str]:
    """(the figure of the first scene, the section's lines, one table a scene)."""
    if not rows:
        return None, [], ""
    text, tables, png = [EXPLANATION], [], None
    for scene in order(rows, "scene"):
        mine = sel(rows, scene=scene)
        tables.append(_head(mine[0]) + "\n\n" + _table(mine))
        text += _lines(scene, mine)
        if out is not None and png is None:
            png = fig_transparent(rows, out, scene)
    return png, text, "\n\n".join(tables)


__all__ = ["transparent_section", "fig_transparent", "frame_ratio", "exact_cell", "CSV", "PNG",
           "EXPLANATION"]
