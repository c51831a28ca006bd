"""The headline figure: culling accuracy (lights evaluated per affecting light) against
frame cost (CPU stage + every timed GPU pass but the G-buffer), mean over the path, with
the Pareto front of the two."""
from __future__ import annotations

import math

from .aggregate import aggregate_path, pareto
from .common import DPI, log_axes, ms, panel_style, plt, save, side_legend
from .spread import below


def fig_accuracy(rows, out, colors, roles) -> tuple[str | None, list[str]]:
    agg = aggregate_path(rows)
    if not agg:
        return None, []
    keys = list(agg)
    cols = min(2, len(keys))
    rws = math.ceil(len(keys) / cols)
    fig, axes = plt().subplots(rws, cols, squeeze=False, dpi=DPI,
                               figsize=(5.2 * cols + 1.4, 3.6 * rws))
    for ax in axes.ravel()[len(keys):]:
        ax.axis("off")
    text = []
    for ax, key in zip(axes.ravel(), keys):
        d = agg[key]
        for t, v in d.items():
            if math.isnan(v["waste"]):
                continue
            c = v["cost"]
            floor = t == roles.floor
            ax.errorbar([c.med], [v["waste"]], xerr=[[c.med - c.lo], [c.hi - c.med]],
                        color=colors(t), fmt="*" if floor else "o", ms=10 if floor else 6,
                        zorder=3, label=t, elinewidth=1, capsize=2)
            ax.annotate(t, (c.med, v["waste"]), fontsize=7, xytext=(4, 3),
                        textcoords="offset points")
        pts = {t: (v["cost"].med, v["waste"]) for t, v in d.items()
               if t != roles.floor and not math.isnan(v["waste"])}
        front = pareto(pts)
        if front:
            ax.step([pts[t][0] for t in front], [pts[t][1] for t in front], where="post",
                    color="0.4", lw=1, ls=":", zorder=2, label="Pareto front")
        log_axes(ax)
        panel_style(ax, f"{key[0]}, {key[1]} lights",
                    "frame cost: CPU stage + GPU cull + shade (ms, mean over path)",
                    "lights evaluated / lights affecting")
        if front:
            text.append(_finding(key, d, pts, front, roles))
    handles, labels = axes[0][0].get_legend_handles_labels()
    side_legend(axes[0][-1], handles, labels)
    return save(fig, out, "accuracy_cost.png"), text


def _finding(key, d, pts, front, roles) -> str:
    s = f"**{key[0]}, {key[1]} lights**: the Pareto front is " + " -> ".join(
        f"{t} ({ms(pts[t][0])}, waste {pts[t][1]:.3g})" for t in front)
    off = []
    for t in pts:
        if t in front:
            continue
        f = next(f for f in front if pts[f][0] <= pts[t][0] and pts[f][1] <= pts[t][1])
        if below(d[f]["cost"], d[t]["cost"]):
            off.append(f"{t} is dominated by {f}")
        else:
            off.append(f"{t} costs the same as {f} within spread, with more waste")
    if off:
        s += "; " + ", ".join(off)
    close = [(a, b) for a, b in zip(front, front[1:]) if not below(d[a]["cost"], d[b]["cost"])]
    if close:
        s += "; on the front, " + ", ".join(f"{a} and {b}" for a, b in close) + \
             " cost the same within spread"
    if roles.floor in d:
        s += (f". The floor ({roles.floor}) would cost {ms(d[roles.floor]['cost'].med)}: the "
              f"CPU steps it shares + shading over exact lists built untimed")
    return s + "."
