"""Tree paper figure 7: GPU lighting time (culling passes + shading) per frame along the
camera path, every technique, each scene and light count; the band is each frame's
min-max over its samples.  And the CPU stage's rebuild per frame along the moving path of
the temporal series (fig_path_cpu)."""
from __future__ import annotations

import statistics

from .common import log_axes, ms, order, panel_style, plt, save, sel, side_legend, times, DPI
from .spread import Spread, below, lowest


def fig_path(rows, out, colors, roles) -> tuple[str | None, list[str]]:
    from matplotlib.ticker import MaxNLocator
    path = sel(rows, study="path")
    if not path:
        return None, []
    scenes, counts = order(path, "scene"), sorted(set(int(r["lights"]) for r in path))
    fig, axes = plt().subplots(len(scenes), len(counts), squeeze=False, dpi=DPI,
                               figsize=(4.2 * len(counts) + 1.6, 2.7 * len(scenes) + 0.4))
    text = []
    for i, sc in enumerate(scenes):
        for j, n in enumerate(counts):
            ax = axes[i][j]
            sub = sel(path, scene=sc, lights=float(n))
            gm = {}
            for t in order(sub, "technique"):
                tr = sorted(sel(sub, technique=t), key=lambda r: r["frame"])
                sp = [Spread.of(r, "gpu_lighting") for r in tr]
                gm[t] = Spread.gmean(sp)
                x = [r["frame"] for r in tr]
                ax.plot(x, [s.med for s in sp], color=colors(t), lw=1.3, ms=3, label=t,
                        **colors.style(t))
                ax.fill_between(x, [s.lo for s in sp], [s.hi for s in sp], color=colors(t),
                                alpha=0.15, lw=0)
            log_axes(ax, x=False)
            frames = sorted(set(int(r["frame"]) for r in sub))
            if len(frames) <= 12:
                ax.set_xticks(frames)
            else:
                ax.xaxis.set_major_locator(MaxNLocator(integer=True))
            panel_style(ax, f"{sc}, {n} lights", "camera path frame", "GPU cull + shade (ms)")
            cands = {t: v for t, v in gm.items() if t != roles.floor}
            if cands:
                text.append(_finding(sc, n, cands, gm.get(roles.floor), sub, roles))
    side_legend(axes[0][-1])
    return save(fig, out, "gpu_path.png"), text


def _finding(sc, n, cands: dict, floor: Spread | None, sub, roles) -> str:
    """The fastest technique over the path (geometric mean), if beyond spread."""
    best, rivals = lowest(cands)
    b = cands[best]
    if rivals:
        s = (f"**{sc}, {n} lights**: {best} has the lowest geometric mean over the path "
             f"({ms(b.med)}), within spread of {', '.join(rivals)}")
    else:
        s = f"**{sc}, {n} lights**: fastest over the path (geometric mean) is **{best}** ({ms(b.med)}"
        second = min((t for t in cands if t != best), key=lambda t: cands[t].med, default=None)
        if second is not None:
            s += f", {times(cands[second].med / b.med)} ahead of {second}"
        ref = cands.get(roles.reference)
        if ref is not None and best != roles.reference and second != roles.reference and below(b, ref):
            s += f", {times(ref.med / b.med)} ahead of {roles.reference}"
        s += ")"
    if floor is not None:
        s += f"; the floor ({roles.floor}) is {ms(floor.med)}"
        if below(floor, b):
            s += f", {times(b.med / floor.med)} below {best}"
        elif below(b, floor):
            s += (f", {times(floor.med / b.med)} above {best} beyond spread (its exact lists "
                  f"evaluate the fewest lights, yet shade slower here)")
        else:
            s += f", within spread of {best}"
    spread = {}
    for t in cands:
        y = [Spread.of(r, "gpu_lighting").med for r in sel(sub, technique=t)]
        if len(y) > 1 and min(y) > 0:
            spread[t] = (min(y), max(y))
    if len(spread) > 1:
        worst = max(spread, key=lambda t: spread[t][1] / spread[t][0])
        steady = min(spread, key=lambda t: spread[t][1] / spread[t][0])
        s += (f". Along the path {worst} varies most ({ms(spread[worst][0])} to "
              f"{ms(spread[worst][1])}), {steady} least ({ms(spread[steady][0])} to "
              f"{ms(spread[steady][1])})")
    return s + "."


def fig_path_cpu(trows, out, colors, roles) -> tuple[str | None, list[str]]:
    """The CPU stage's rebuild, every frame, along the moving path of the temporal series
    (app.bench.temporal): each technique's CPU ms per frame, and the sentence that says it."""
    rows = [r for r in trows if r.get("kind") in ("technique", "sampler")]
    if not rows:
        return None, []
    fig, ax = plt().subplots(1, 1, dpi=DPI, figsize=(7.0, 3.2))
    med = {}
    for t in order(rows, "technique"):
        tr = sorted(sel(rows, technique=t), key=lambda r: r["frame"])
        y = [float(r["cpu_total_ms"]) for r in tr]
        med[t] = (statistics.median(y), min(y), max(y))
        ax.plot([int(r["frame"]) for r in tr], y, color=colors(t), lw=1.3, ms=3, label=t,
                **colors.style(t))
    r0 = rows[0]
    where = (f"{r0['scene']}, {int(r0['lights'])} lights bouncing at {float(r0['motion_speed']):g} "
             f"m/s, {int(r0['width'])}x{int(r0['height'])}")
    log_axes(ax, x=False)
    panel_style(ax, f"CPU stage per frame along the moving path ({where})", "path frame",
                "CPU stage ms (cull ... upload)")
    side_legend(ax)
    dear = max(med, key=lambda t: med[t][0])
    text = [f"The lights move, so the CPU stage rebuilds every frame from the frame's lights "
            f"(cull, sort, bin, build, pack, upload; nothing is kept from the frame before): "
            f"along the moving path ({where}) a frame's rebuild costs " + ", ".join(
                f"{t} {ms(m[0])} ({ms(m[1])} to {ms(m[2])})" for t, m in med.items())
            + f" (median over the frames, min to max); the dearest is {dear}."]
    return save(fig, out, "cpu_moving_path.png"), text
