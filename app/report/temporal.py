"""Temporal stability along a moving path (app.bench.temporal, DIR/temporal.csv): the
temporal error against the unbounded reference and the popping pixels per frame, for every
exact technique, cap policy, light-cutoff level and stochastic budget."""
from __future__ import annotations

import math

from .common import DPI, mean, num, order, panel_style, plt, save, side_legend

CSV = "temporal.csv"          # the series' file in the run's folder (app.bench.temporal writes it)

EXPLANATION = (
    "Consecutive frames of the scene's camera path (a loop of many frames, so the camera moves "
    "a little each frame) with its lights bouncing (`--motion bounce`, scenes/motion.py). "
    "Temporal error: mean |dT - dR| over geometry pixels and channels, dX the change of image "
    "X from the frame before, R the unbounded reference (every light, 1/(d^2+1), no window), "
    "relative to R's mean radiance: the flicker a technique adds to the true change. Popping: "
    "pixels whose light set (contrib_hash) changed while the exact set (brute at the scene's "
    "radii) did not: a light crossed a cap or a cutoff rather than moving into or out of its "
    "volume. A cap policy runs on one list technique: it drops the same lights whatever the "
    "structure. Exact techniques have brute's sets at every pixel, so they never pop. "
    "Stochastic light culling (Tokuyoshi & Harada) draws each light's range anew every frame "
    "(stochastic_frame = the frame): its popping is its noise, its temporal error what that "
    "noise adds to the true change.")


def _groups(rows) -> dict[str, list[dict]]:
    """config -> its rows with temporal figures (frames >= 1), exact techniques as one when
    their figures agree (their images are brute's)."""
    by = {c: sorted((r for r in rows if r["config"] == c and not math.isnan(num(r["temporal_error_pct"]))),
                    key=lambda r: r["frame"]) for c in order(rows, "config")}
    exact = [c for c in by if by[c] and by[c][0]["kind"] == "technique"]
    if exact and all([round(num(r["temporal_error_pct"]), 3) for r in by[c]]
                     == [round(num(r["temporal_error_pct"]), 3) for r in by[exact[0]]] for c in exact):
        first = by[exact[0]]
        for c in exact:
            del by[c]
        by = {f"exact ({len(exact)} techniques)": first, **by}
    # the reference's own error is 0 by definition, and its sets hold every light
    return {c: rs for c, rs in by.items() if rs and rs[0]["kind"] != "reference"}


def fig_temporal(rows, out, colors, roles) -> tuple[str | None, list[str]]:
    if not rows:
        return None, []
    import matplotlib
    from matplotlib.ticker import MaxNLocator
    groups = _groups(rows)
    cmap = matplotlib.colormaps["tab20"]
    fig, axes = plt().subplots(1, 2, squeeze=False, dpi=DPI, figsize=(12.0, 3.8))
    for i, (c, rs) in enumerate(groups.items()):
        x = [int(r["frame"]) for r in rs]
        kind = rs[0]["kind"]
        style = dict(ls="-" if kind == "technique" else "--" if kind == "cap" else
                     "-." if kind == "stochastic" else (0, (5, 1, 1, 1, 1, 1))
                     if kind == "sampler" else ":",
                     marker="s" if kind == "sampler" else "o", ms=3, lw=1.3, color=cmap(i % 20), label=c)
        axes[0][0].plot(x, [num(r["temporal_error_pct"]) for r in rs], **style)
        axes[0][1].plot(x, [num(r["popping_pixels"]) for r in rs], **style)
    r0 = rows[0]
    where = f"{r0['scene']}, {int(r0['lights'])} lights bouncing at {num(r0['motion_speed']):g} m/s"
    panel_style(axes[0][0], f"temporal error, {where}", "path frame",
                "mean |dT - dR| / mean R (%)")
    panel_style(axes[0][1], f"popping pixels, {int(r0['width'])}x{int(r0['height'])}", "path frame",
                "pixels whose set changed, exact set not")
    axes[0][1].set_yscale("symlog", linthresh=1.0)
    for ax in axes[0]:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    side_legend(axes[0][1])
    return save(fig, out, "temporal.png"), _text(groups, r0)


def _text(groups: dict, r0) -> list[str]:
    figs = {c: (mean(r["temporal_error_pct"] for r in rs), sum(num(r["popping_pixels"]) for r in rs),
                mean(r["capped_lights"] for r in rs), rs) for c, rs in groups.items()}
    pairs = len(next(iter(groups.values())))
    text = []
    exact = [c for c in figs if figs[c][3][0]["kind"] == "technique"]
    if exact:
        pops = sum(figs[c][1] for c in exact)
        what = (f"the {exact[0].split('(')[1].split()[0]} exact techniques' temporal error (one "
                f"figure: their images are brute's)" if len(exact) == 1 else
                "the exact techniques' temporal error (mean over them)")
        err = mean(figs[c][0] for c in exact)
        text.append(f"Over {pairs} frame pairs of {r0['scene']}'s path at "
                    f"{int(r0['width'])}x{int(r0['height'])}: {what} against the unbounded "
                    f"reference is {err:.3g}% (the light window cuts each light's tail) and they "
                    f"pop on {int(pops)} pixels (0 by construction).")
    caps = [c for c in figs if figs[c][3][0]["kind"] == "cap"]
    if caps:
        text.append("Cap policies: " + "; ".join(
            f"{c}: {figs[c][0]:.3g}%, {int(figs[c][1])} popping pixels ({figs[c][2]:.0f} lights "
            f"dropped a frame)" for c in caps) + ".")
    cuts = [c for c in figs if figs[c][3][0]["kind"] == "cutoff"]
    if cuts:
        text.append("Light cutoffs: " + "; ".join(
            f"{c}: {figs[c][0]:.3g}%, {int(figs[c][1])} popping pixels" for c in cuts) + ".")
    draws = [c for c in figs if figs[c][3][0]["kind"] == "stochastic"]
    if draws:
        text.append("Stochastic light culling, a new draw every frame: " + "; ".join(
            f"{c}: {figs[c][0]:.3g}%, {int(figs[c][1])} popping pixels" for c in draws) +
            " (its noise: unbiased on average, not steady from frame to frame).")
    samplers = [c for c in figs if figs[c][3][0]["kind"] == "sampler"]
    if samplers:
        text.append("Samplers, a new draw every frame (sample_frame = the frame): " + "; ".join(
            f"{c}: {figs[c][0]:.3g}%, {int(figs[c][1])} popping pixels" for c in samplers) +
            " (their noise from frame to frame; their drawable sets are brute's, so they never pop).")
    inexact = {c: figs[c] for c in caps + cuts + draws + samplers}
    if inexact:
        calm = min(inexact, key=lambda c: inexact[c][0])
        pop = max(inexact, key=lambda c: inexact[c][1])
        text.append(f"Steadiest of the inexact choices: {calm} ({inexact[calm][0]:.3g}%); most "
                    f"popping: {pop} ({int(inexact[pop][1])} pixels over the path). One run, "
                    f"one path: no spread is measured, so these are observations, not rankings.")
    return text


__all__ = ["fig_temporal", "EXPLANATION", "CSV"]
