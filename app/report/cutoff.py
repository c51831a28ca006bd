"""The light cutoff: image error against the unbounded reference vs frame cost, over the
threshold t that sets each light's radius (app.bench.cutoff), and stochastic light culling
at a few budgets t beside it (rows of the study with the option stochastic = 1/t)."""
from __future__ import annotations

from .common import DPI, log_axes, mean, ms, num, order, panel_style, plt, save, sel, side_legend, times
from .spread import Spread, lowest

EXPLANATION = (
    "Each light's radius is set where its unbounded falloff I/(d^2+1) drops to t times the "
    "brightest light's peak: radius_i = sqrt(I_i / (t I_max) - 1), I_i = intensity x "
    "brightest colour channel; lights never that bright are dropped.  radius ~ sqrt(I), "
    "and the builtin scenes draw I ~ r^2, so the many-small-few-large law is kept.  The "
    "reference renders every light with UNBOUNDED_FALLOFF=1 (attenuation 1/(d^2+1), no "
    "window).  Stochastic light culling (Tokuyoshi & Harada 2016, dashed, x) at budget t "
    "draws each light's range once a frame, sqrt(1/(alpha xi) - 1) with alpha = t I_max / I "
    "(at xi = 1 the cutoff's radius at t), and weights a kept light by 1/p: unbiased against "
    "the reference, so its error is noise, not missing energy; one draw (seed 0) is shown.")


def stochastic_budget(row) -> int:
    """The row's stochastic budget N (t = 1/N); 0 when off."""
    v = num(row.get("stochastic", 0))
    return 0 if v != v else int(v)


def fig_cutoff(rows, out, colors, roles) -> tuple[str | None, list[str]]:
    cut = sel(rows, study="cutoff")
    if not cut:
        return None, []
    scenes = order(cut, "scene")
    fig, axes = plt().subplots(1, len(scenes), squeeze=False, dpi=DPI,
                               figsize=(5.6 * len(scenes) + 1.4, 3.6))
    text = []
    for ax, sc in zip(axes[0], scenes):
        sub = sel(cut, scene=sc)
        ref = [r for r in sub if r["cutoff"] < 0]
        bounded = [r for r in sub if r["cutoff"] > 0]
        stoch = [r for r in sub if r["cutoff"] == 0 and stochastic_budget(r) > 0]
        cutoffs = sorted(set(int(r["cutoff"]) for r in bounded))
        for t in order(bounded, "technique"):
            tr = sorted(sel(bounded, technique=t), key=lambda r: r["cutoff"])
            ax.plot([num(r["frame_cost_ms"]) for r in tr],
                    [max(num(r["image_error"]), 1e-7) for r in tr],
                    color=colors(t), label=t, **colors.style(t))
            if t == roles.reference:
                for r in tr:
                    ax.annotate(f"1/{int(r['cutoff'])}", (num(r["frame_cost_ms"]), num(r["image_error"])),
                                fontsize=7, xytext=(3, 3), textcoords="offset points")
        for k, t in enumerate(order(stoch, "technique")):
            tr = sorted(sel(stoch, technique=t), key=stochastic_budget)
            ax.plot([num(r["frame_cost_ms"]) for r in tr],
                    [max(num(r["image_error"]), 1e-7) for r in tr],
                    color=colors(t), label=f"{t} stochastic", ls="--", marker="x")
            if k == 0:
                for r in tr:
                    ax.annotate(f"s 1/{stochastic_budget(r)}",
                                (num(r["frame_cost_ms"]), num(r["image_error"])),
                                fontsize=7, xytext=(3, -9), textcoords="offset points")
        if ref:
            ax.axvline(num(ref[0]["frame_cost_ms"]), color="0.3", ls=":", lw=1,
                       label=f"unbounded {roles.reference}")
        log_axes(ax)
        panel_style(ax, f"light cutoff, {sc}, {int(sub[0]['lights'])} lights", "frame cost (ms)",
                    "RMSE vs unbounded / mean radiance")
        if cutoffs:
            text.append(_finding(sc, bounded, ref, cutoffs, roles) + _stochastic_finding(stoch, bounded))
    side_legend(axes[0][-1])
    return save(fig, out, "cutoff.png"), text


def _finding(sc, bounded, ref, cutoffs, roles) -> str:
    at = lambda c: [r for r in bounded if int(r["cutoff"]) == c]
    errs = {c: mean([r["image_error"] for r in at(c)]) for c in cutoffs}
    flips = {c: mean([r.get("image_flip", float("nan")) for r in at(c)]) for c in cutoffs}
    vis = {c: mean([r["visible"] for r in at(c) if r["technique"] == roles.reference]) for c in cutoffs}
    ratio = {c: mean([r["radiance_ratio"] for r in at(c)]) for c in cutoffs}
    s = f"**{sc}**: image error against the unbounded reference (relative RMSE of radiance; " \
        f"mean FLIP of the tone-mapped images) is " + ", ".join(
            f"{errs[c]:.2g}; {flips[c]:.2g} at t=1/{c}" for c in cutoffs)
    s += " (the bounded image holds " + ", ".join(f"{100 * ratio[c]:.0f}%" for c in cutoffs) + \
         " of the reference's mean radiance"
    c0 = cutoffs[-1]
    if errs[c0] > 0 and 1.0 - ratio[c0] >= 0.5 * errs[c0]:
        s += "; most of the error is energy missing from the cut tails"
    s += ")"
    cheapest = {}
    for c in cutoffs:
        cands = {r["technique"]: Spread.of(r, "frame_cost") for r in at(c)
                 if r["technique"] not in (roles.reference, roles.floor)}
        if cands:
            best, rivals = lowest(cands)
            cheapest[c] = (best, cands[best].med, rivals)
    if cheapest:
        s += "; the cheapest technique costs " + ", ".join(
            f"{ms(v[1])} ({v[0]}{', within spread of ' + ', '.join(v[2]) if v[2] else ''}) at 1/{c}"
            for c, v in cheapest.items())
    if len(cutoffs) > 1 and cutoffs[0] in cheapest and cutoffs[-1] in cheapest:
        s += f": {times(cheapest[cutoffs[-1]][1] / cheapest[cutoffs[0]][1])} the cost for " \
             f"{times(errs[cutoffs[0]] / max(errs[cutoffs[-1]], 1e-12))} less error"
    if ref:
        s += f". Visible lights grow from {vis[cutoffs[0]]:.0f} to {vis[cutoffs[-1]]:.0f}; the " \
             f"unbounded reference ({int(ref[0]['visible'])} lights, no window) costs " \
             f"{ms(ref[0]['frame_cost_ms'])}"
    return s + "."


def _stochastic_finding(stoch, bounded) -> str:
    """A sentence on stochastic culling beside the cutoff level of the same t, where run."""
    budgets = sorted(set(stochastic_budget(r) for r in stoch))
    if not budgets:
        return ""
    parts = []
    for b in budgets:
        at = [r for r in stoch if stochastic_budget(r) == b]
        techs = {r["technique"] for r in at}
        det = [r for r in bounded if int(r["cutoff"]) == b and r["technique"] in techs]
        s = f"{mean([r['image_error'] for r in at]):.2g} at t=1/{b} (mean radiance " \
            f"{100 * mean([r['radiance_ratio'] for r in at]):.0f}% of the reference's"
        if det:
            cost = mean([r["frame_cost_ms"] for r in at]) / mean([r["frame_cost_ms"] for r in det])
            s += f"; the cutoff at t=1/{b}: {mean([r['image_error'] for r in det]):.2g}, at " \
                 f"{times(cost)} its cost for {', '.join(sorted(techs))}"
        parts.append(s + ")")
    return " Stochastic culling (one draw) has error " + ", ".join(parts) + "."
