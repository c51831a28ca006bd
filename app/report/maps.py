"""Per-block maps of one frame (maps.npz): lights evaluated per pixel for every technique
(tree paper figure 1), and each wave's traversal case, list / tree / mixed (figure 3).

The heat maps use the lab's one heat-map definition (app.images: the turbo ramp, the scale
log2(1 + n) / log2(1 + max), zero counts grey), the one capture's --heatmap and the window's
heat view use; the top of the scale is the largest block mean over all panels, so the panels
of one figure compare.  The values are block means (the sweep keeps those in maps.npz)."""
from __future__ import annotations

import math

import numpy as np

from .common import DPI, plt, save, sel, times


def heat_scene(info: dict) -> str:
    """The heat maps' scene: run.json's config of the rendered study (a run written before
    the presets were their studies: its flat config)."""
    config = info.get("config", {})
    return config.get("rendered", config).get("heat_scene", "")


def fig_heat(maps, out, info, roles) -> tuple[str | None, list[str]]:
    from ..images import heat_bar_ticks, heat_cmap, heat_norm, heat_top
    keys = [k for k in maps if k.startswith("evaluated/")]
    if not keys:
        return None, []
    panels = [(k.split("/", 1)[1], maps[k]) for k in keys]
    if "exact" in maps and f"evaluated/{roles.floor}" not in maps:
        panels.append(("exact (lights affecting)", maps["exact"]))
    vals = np.concatenate([m.ravel() for _, m in panels])
    vmax = heat_top(float(vals.max()))
    cmap = heat_cmap(zero_grey=True)
    cols = min(3, len(panels))
    rws = math.ceil(len(panels) / cols)
    h, w = panels[0][1].shape
    fig, axes = plt().subplots(rws, cols, squeeze=False, dpi=DPI,
                               figsize=(cols * 3.4 + 0.8, rws * 3.4 * h / w + 0.6))
    im = None
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (t, m) in zip(axes.ravel(), panels):
        shown = np.ma.masked_less_equal(m, 0.0)     # a zero mean: grey, as in the window
        im = ax.imshow(shown, cmap=cmap, norm=heat_norm(vmax), interpolation="nearest")
        ax.set_title(f"{t}: {m.mean():.3g}/px", fontsize=8)
    bar = fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.8)
    heat_bar_ticks(bar, vmax)
    bar.set_label("lights / pixel, log2(1 + n)", fontsize=8)
    scene = heat_scene(info)
    b = int(maps.get("block", 16))
    fig.suptitle(f"lights evaluated per pixel, {b}x{b} block means, {scene} frame 0", fontsize=9)
    name = save(fig, out, "heatmaps.png", tight=False)
    means = {t: float(m.mean()) for t, m in panels}
    exact = float(maps["exact"].mean()) if "exact" in maps else math.nan
    ranked = sorted((t for t, _ in panels[:len(keys)] if t != roles.floor), key=means.get)
    text = ["On this frame the loop evaluates, per pixel on average: " +
            ", ".join(f"{t} {means[t]:.3g}" for t in ranked) +
            (f"; {exact:.3g} lights actually affect a pixel." if not math.isnan(exact) else ".")]
    if len(ranked) > 1 and not math.isnan(exact) and exact > 0:
        text.append(f"The tightest structure, {ranked[0]}, evaluates {times(means[ranked[0]] / exact)} "
                    f"the exact count; {ranked[-1]} evaluates {times(means[ranked[-1]] / exact)}.")
    return name, text


def fig_classification(rows, maps, out) -> tuple[str | None, list[str]]:
    """Every technique whose waves take more than one path: per 8x8 wave, list (blue),
    tree (green), mixed (white), empty (grey)."""
    from matplotlib.patches import Patch
    from ..images import CASE_COLORS, CASE_NAMES
    path = sel(rows, study="path")
    if not path:
        return None, []
    w, h = int(path[0]["width"]), int(path[0]["height"])
    chosen = []
    for k in [k for k in maps if k.startswith("cases/")]:
        cases = maps[k]
        if len(np.unique(cases[cases > 0])) >= 2:
            chosen.append((k.split("/", 1)[1], cases))
    if not chosen:
        return None, []
    fig, axes = plt().subplots(1, len(chosen), squeeze=False, dpi=DPI,
                               figsize=(4.2 * len(chosen) + 1.8, 4.2 * h / w + 0.7))
    text = []
    for ax, (t, cases) in zip(axes[0], chosen):
        rgb = np.zeros(cases.shape + (3,), np.uint8)
        for k, c in CASE_COLORS.items():
            rgb[cases == k] = c
        ax.imshow(np.repeat(np.repeat(rgb, 8, 0), 8, 1)[:h, :w], interpolation="nearest")
        ax.set_xticks([]), ax.set_yticks([])
        ax.set_title(f"{t}: traversal per 8x8 wave", fontsize=9)
        shares = {CASE_NAMES[k]: float((cases == k).mean()) for k in CASE_COLORS}
        busy = 1.0 - shares["empty"]
        text.append(f"{t}: of the waves that shade, " + ", ".join(
            f"{shares[n] / busy:.0%} {n}" for n in ("list", "tree", "mixed")) +
            (f" ({shares['empty']:.0%} of all waves are empty)." if busy > 0 else "."))
    axes[0][-1].legend(handles=[Patch(facecolor=np.array(CASE_COLORS[k]) / 255, edgecolor="0.5",
                                      label=CASE_NAMES[k]) for k in (1, 2, 3, 0)],
                       fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return save(fig, out, "classification.png"), text


def fig_own_maps(maps, out, info) -> tuple[str | None, list[str]]:
    """Each technique's maps of its own structure (Technique.maps: fptl's coarse and pruned
    lists per tile, the chapter's figures 2.4-2.6; zbin's bit arrays and z-bin ranges; the
    rasterized bits), on one heat scale per technique."""
    from ..images import heat_bar_ticks, heat_cmap, heat_norm, maps_top
    keys = sorted(k for k in maps if k.startswith("own/"))
    if not keys:
        return None, []
    cmap = heat_cmap(zero_grey=True)
    cols = min(3, len(keys))
    rws = math.ceil(len(keys) / cols)
    fig, axes = plt().subplots(rws, cols, squeeze=False, dpi=DPI, figsize=(cols * 3.6 + 0.4, rws * 2.6 + 0.6))
    for ax in axes.ravel():
        ax.axis("off")
    techniques = {k.split("/")[1] for k in keys}
    tops = {t: maps_top({k: maps[k] for k in keys if k.split("/")[1] == t}) for t in techniques}
    text = []
    for ax, k in zip(axes.ravel(), keys):
        _, t, name = k.split("/", 2)
        m = np.asarray(maps[k], np.float64)
        label = str(maps.get(f"ownlabel/{t}/{name}", name))
        im = ax.imshow(np.ma.masked_less_equal(m, 0.0), cmap=cmap, norm=heat_norm(tops[t]),
                       interpolation="nearest")
        lit = m[m > 0]
        ax.set_title(f"{t}: {label}", fontsize=8)
        heat_bar_ticks(fig.colorbar(im, ax=ax, shrink=0.8), tops[t])
        text.append(f"{t}, {label}: {lit.mean():.3g} where non-zero, at most {m.max():.0f}"
                    if lit.size else f"{t}, {label}: all zero")
    scene = heat_scene(info)
    fig.suptitle(f"each technique's own structure, {scene} frame 0 (log2(1 + n) scale)", fontsize=9)
    return save(fig, out, "technique_maps.png", tight=False), text
