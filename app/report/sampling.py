"""Sampling against culling on one frame (app.bench.sampling, DIR/sampling.csv): image error
against brute over evaluations per pixel, frame cost and a visibility-weighted work, the
crossover of each sampler against an engine cap, and a table (sampling.png).

The crossover (crossover()) reads only the study's rows: on each frame the named cap is the
cap policy of least nonzero frame error that the sampler's median error reaches at a
measured S, else the least nonzero (named_cap); for each S and seed,
n is the largest light-count bin edge such that sampling only the pixels that at most n
lights affect (brute's radiance elsewhere) keeps the frame error within the cap's; S* is
where the sampler's whole frame error meets the cap's, interpolated in log S / log error
(app.bench.sampling's docstring defines both on its columns).
"""
from __future__ import annotations

import json
import math

import numpy as np

from .common import DPI, Colors, log_axes, ms, num, order, panel_style, plt, save, sel
from .spread import Spread, below

CSV = "sampling.csv"          # the study's file in the run's folder (app.bench.sampling writes it)
VISIBILITY_C = 8.0            # a shadow test in light evaluations, the work panel's c
WORK_C = (0.0, VISIBILITY_C)

EXPLANATION = (
    "One frame a scene (frame 0, the scene's own radii), everything against brute's image on "
    "that frame: the exact techniques (error 0), each engine cap policy that drops lights "
    "(`--cap-policy`, on the first technique that takes it), and each sampler (role "
    "\"sampler\", an unbiased estimate of brute's image) at each S over K seeds "
    "(`--sample-seed` 0..K-1), the error's median with its min-max over the seeds as bars. "
    "Error: relative RMSE of linear radiance over geometry pixels (RMSE / brute's mean "
    "radiance). Evaluations per pixel: mean of `evaluated` over geometry pixels. Shadow tests "
    "per pixel: a culling configuration tests each light that affects the pixel (its "
    "contrib_count); a sampler each of its draws that hits a light affecting the pixel (its "
    "wave replay's count of the GPU's draws; where it has no replay, at most each draw at a "
    "pixel some light affects, marked <=). Frame work "
    "in light evaluations = evaluations + c x shadow tests, at c = 0 and c = "
    f"{VISIBILITY_C:g}: visibility itself is not simulated (no shadow ray is traced in this "
    "lab), c only prices it. Frame cost: CPU stage + timed GPU passes, median of the timing "
    "samples (a sampler's: its seed renders). Crossover: the named cap is the cap policy of "
    "least nonzero frame error on that frame that the sampler's median frame error reaches at "
    "a measured S (else simply the least nonzero); geometry pixels are binned by how many lights "
    "affect them (brute's contrib_count in [2^k, 2^(k+1)), pixels no light affects left out); "
    "E_S(n) is the frame error (RMSE over every geometry pixel / brute's mean radiance) of "
    "sampling at S only the pixels that at most n lights affect, brute's radiance elsewhere; "
    "for each S and seed, n is the largest bin edge with E_S(n) at most the cap's frame error "
    "(0: not even the first bin; \"every bin\": the sampler's whole frame is within it), "
    "given as median [min, max] over seeds; S* is the S "
    "where the sampler's median frame error equals the cap's (log-log interpolation between "
    "the two measured S around it; in brackets from the seeds' min and max errors), also "
    "against each other cap that loses light, and by FLIP against the named cap's FLIP. Close: "
    "a difference inside the measured spread (the seeds' min-max of an error, the timing "
    "samples' min-max of a cost) is not a finding; the text says *within spread* there.")


def _scenes(rows) -> list[str]:
    return order(rows, "scene")


def _sampler_curves(rows, scene) -> dict[str, list[dict]]:
    """{sampler technique: its rows in the scene, S ascending}."""
    rs = sel(rows, scene=scene, kind="sampler")
    return {t: sorted(sel(rs, technique=t), key=lambda r: num(r["samples_per_pixel"]))
            for t in order(rs, "technique")}


def losing_caps(rows, scene) -> list[dict]:
    """The scene's cap rows of nonzero image_error, mildest first."""
    caps = [r for r in sel(rows, scene=scene, kind="cap") if num(r["image_error"]) > 0]
    return sorted(caps, key=lambda r: num(r["image_error"]))


def named_cap(rows, scene, curve=()) -> dict | None:
    """The cap the crossover is against: the mildest that loses light whose error the
    sampler's median frame error reaches at a measured S (`curve`: its rows), else the
    mildest that loses light; None where no cap loses light."""
    caps = losing_caps(rows, scene)
    best = min((num(r["image_error"]) for r in curve), default=math.inf)
    return next((r for r in caps if num(r["image_error"]) >= best), caps[0] if caps else None)


def bin_reach(row, threshold: float) -> list[tuple[int, bool]]:
    """(n, every bin within) of each seed of a sampler row: n the largest bin edge with
    E_S(n) <= threshold, E_S(n) the frame error of sampling only the pixels of the bins up
    to n (their squared bin errors weighted by pixels over the frame's geometry pixels)."""
    b = json.loads(row["bins"])
    pixels = np.asarray(b["pixels"], np.float64)
    out = []
    for errs in b["err"]:
        e = np.sqrt(np.cumsum(pixels * np.asarray(errs, np.float64) ** 2) / max(b["geometry"], 1))
        within = e <= threshold
        k = int(np.argmin(within)) if not within.all() else len(e)   # the first bin beyond
        out.append((int(b["hi"][k - 1]) if k else 0, bool(within.all())))
    return out


def meet(s, e, threshold: float) -> float:
    """S where the error curve e(s) first falls to `threshold` (log-log interpolation between
    the measured S around it); 0 where e(s_min) is already there, inf where e(s_max) is not."""
    for i, (si, ei) in enumerate(zip(s, e)):
        if ei <= threshold:
            if i == 0:
                return 0.0
            sa, ea = s[i - 1], e[i - 1]
            if ei <= 0 or ea <= ei:
                return float(si)
            t = (math.log(threshold) - math.log(ea)) / (math.log(ei) - math.log(ea))
            return float(math.exp(math.log(sa) + t * (math.log(si) - math.log(sa))))
    return math.inf


def _s_star(curve, threshold: float, metric: str = "image_error") -> tuple[float, float, float]:
    """S* of the median error curve, and of the seeds' min and max curves."""
    s = [int(num(r["samples_per_pixel"])) for r in curve]
    return tuple(meet(s, [num(r[metric + k]) for r in curve], threshold)
                 for k in ("", "_min", "_max"))


def cost_spread(row) -> Spread:
    """A row's frame cost: median, min, max over its timing samples."""
    return Spread(num(row["frame_cost_ms"]), num(row["frame_cost_min_ms"]),
                  num(row["frame_cost_max_ms"]), int(num(row["timing_samples"]) or 1))


def cost_phrase(mine: Spread, other: Spread) -> str:
    """"lower" / "higher" beyond the measured spread, else "within spread"."""
    return "lower beyond spread" if below(mine, other) else \
        "higher beyond spread" if below(other, mine) else "within spread"


def _closest(curve, threshold: float) -> dict:
    """The measured S whose median error is nearest the cap's (in log), and whether the
    cap's error lies inside that S's spread over seeds (then it is no finding)."""
    r = min(curve, key=lambda r: abs(math.log(max(num(r["image_error"]), 1e-12) / threshold)))
    lo, hi = num(r["image_error_min"]), num(r["image_error_max"])
    return dict(s=int(num(r["samples_per_pixel"])), err=num(r["image_error"]), lo=lo, hi=hi,
                within=lo <= threshold <= hi, cost=cost_spread(r))


def crossover(rows) -> list[dict]:
    """Per scene and sampler: the named cap, the bin reach of each S over seeds, S* against
    it and against every other cap that loses light (module docstring); cap None for a
    scene without a cap that loses light."""
    out = []
    for scene in _scenes(rows):
        for tech, curve in _sampler_curves(rows, scene).items():
            cap = named_cap(rows, scene, curve)
            if cap is None or not curve:
                out.append(dict(scene=scene, technique=tech, cap=None))
                continue
            thr = num(cap["image_error"])
            reach = []
            for r in curve:
                per = bin_reach(r, thr)
                ns = [n for n, _ in per]
                reach.append(dict(s=int(num(r["samples_per_pixel"])), med=float(np.median(ns)),
                                  lo=min(ns), hi=max(ns), whole=all(w for _, w in per)))
            # the other losing caps, one entry per error as the text prints it (the engines
            # whose policies drop the same lights here give one image)
            others: dict[str, list] = {}
            for r in losing_caps(rows, scene):
                others.setdefault(f"{num(r['image_error']):.3g}", [num(r["image_error"])]).append(r)
            same = [r["policy"] for r in others.pop(f"{thr:.3g}")[1:] if r is not cap]
            out.append(dict(scene=scene, technique=tech, cap=cap["config"], cap_error=thr,
                            same=same, reached=min(num(r["image_error"]) for r in curve) <= thr,
                            reach=reach, s_star=_s_star(curve, thr), row=curve[0],
                            closest=_closest(curve, thr), cap_cost=cost_spread(cap),
                            cap_flip=num(cap["image_flip"]),
                            flip_star=_s_star(curve, num(cap["image_flip"]), "image_flip")
                            if num(cap["image_flip"]) > 0 else None,
                            others=[([r["policy"] for r in g[1:]], g[0], _s_star(curve, g[0])[0])
                                    for g in others.values()]))
    return out


def _s_text(v: float, s_lo: int, s_hi: int) -> str:
    return f"below S={s_lo}" if v == 0 else f"beyond S={s_hi}" if math.isinf(v) else f"{v:.3g}"


def crossover_sentences(rows) -> list[str]:
    """One sentence per scene (and sampler) from crossover()."""
    out = []
    for c in crossover(rows):
        if c["cap"] is None:
            out.append(f"{c['scene']}: no cap policy loses light on this frame, so {c['technique']} "
                       f"has no cap error to cross.")
            continue
        r0, reach = c["row"], c["reach"]
        lo_s, hi_s = reach[0]["s"], reach[-1]["s"]
        parts = "; ".join(f"S={x['s']}: {x['med']:g} [{x['lo']}, {x['hi']}]"
                          + (" (every bin)" if x["whole"] else "") for x in reach)
        med, best, worst = (_s_text(v, lo_s, hi_s) for v in c["s_star"])
        near = c["closest"]
        close = (f"at S={near['s']} its error {near['err']:.3g} [{near['lo']:.3g}, "
                 f"{near['hi']:.3g}] holds the cap's within its spread over seeds: no finding"
                 if near["within"] else
                 f"at S={near['s']} its error {near['err']:.3g} [{near['lo']:.3g}, "
                 f"{near['hi']:.3g}] is {'below' if near['hi'] < c['cap_error'] else 'above'} "
                 f"the cap's beyond that spread")
        mine, theirs = near["cost"], c["cap_cost"]
        close += (f"; its frame cost there {ms(mine.med)} [{ms(mine.lo)}, {ms(mine.hi)}] against "
                  f"the cap's {ms(theirs.med)} [{ms(theirs.lo)}, {ms(theirs.hi)}]: "
                  f"{cost_phrase(mine, theirs)}")
        rest = "; ".join(f"{'/'.join(names)} ({e:.3g}): {_s_text(v, lo_s, hi_s)}"
                         for names, e, v in c["others"])
        out.append(
            f"{c['scene']} ({int(num(r0['lights']))} lights, {int(num(r0['width']))}x"
            f"{int(num(r0['height']))}): against {c['cap']}"
            + (f" (and {'/'.join(c['same'])}, the same error)" if c["same"] else "")
            + f" (frame error {c['cap_error']:.3g}: the mildest cap that loses light "
            + (f"whose error the sampler reaches by S={hi_s}" if c["reached"] else
               f"here; the sampler reaches no cap's error by S={hi_s}")
            + f"), {c['technique']} sampling only the pixels that at most n "
            f"lights affect (brute's shading elsewhere) keeps the frame within that error up to "
            f"n = median [min, max] over {int(num(r0['seeds']))} seeds: {parts}; its frame "
            f"error equals the cap's at S* = {med} [{best}, {worst}] ({close})"
            + (f"; by FLIP (the cap's {c['cap_flip']:.3g}) S* = "
               + " [".join(_s_text(v, lo_s, hi_s) for v in c["flip_star"][:2])
               + f", {_s_text(c['flip_star'][2], lo_s, hi_s)}]" if c["flip_star"] else "")
            + (f"; S* against the other caps that lose light: {rest}" if rest else "") + ".")
    return out


def _err_text(r) -> str:
    e, lo, hi = (num(r[k]) for k in ("image_error", "image_error_min", "image_error_max"))
    return "0" if e == 0 and hi == 0 else f"{e:.3g}" if lo == hi else f"{e:.3g} [{lo:.3g}, {hi:.3g}]"


def sampling_table(rows) -> str:
    """Technique, S, evaluations / shadow tests a pixel, error, frame cost, per scene."""
    head = ("| scene | configuration | S | evaluations/px | shadow tests/px | error median "
            "[min, max] | FLIP | frame cost median [min, max] | modelled frame |\n"
            "|---|---|---|---|---|---|---|---|---|")
    lines = [head]
    for r in rows:
        s = num(r["samples_per_pixel"])
        bound = "<= " if num(r["shadow_bound"]) == 1 else ""
        flip = num(r["image_flip"])
        lines.append(
            f"| {r['scene']} | {r['config']} | {'' if math.isnan(s) else int(s)} | "
            f"{num(r['evaluated_pp']):.3g} | {bound}{num(r['shadow_pp']):.3g} | {_err_text(r)} | "
            f"{'-' if math.isnan(flip) else f'{flip:.3g}'} | {ms(r['frame_cost_ms'])} "
            f"[{ms(r['frame_cost_min_ms'])}, {ms(r['frame_cost_max_ms'])}] | "
            f"{ms(r.get('model_frame_ms'))} |")
    return "\n".join(lines)


def _work(r, c: float) -> float:
    return num(r["evaluated_pp"]) + c * num(r["shadow_pp"])


AXES = (("evaluations a geometry pixel (= work at c=0)", lambda r: _work(r, 0.0)),
        ("frame cost (ms, median; bars min-max)", lambda r: num(r["frame_cost_ms"])),
        (f"work: evaluations + {VISIBILITY_C:g} x shadow tests a pixel", lambda r: _work(r, VISIBILITY_C)))


def _panel(ax, rows, scene, x_of, colors, xlabel) -> None:
    rs = sel(rows, scene=scene)
    errs = [num(r["image_error"]) for r in rs if num(r["image_error"]) > 0]
    floor = min(errs) / 3 if errs else 1e-3
    labels: dict[tuple, list[str]] = {}         # caps at one point: one label
    for r in (r for r in rs if r["kind"] != "sampler"):
        zero = num(r["image_error"]) == 0
        ax.plot([max(x_of(r), 1e-3)], [floor if zero else num(r["image_error"])],
                ls="", marker="v" if zero else "^", ms=6, color=colors(r["technique"]),
                mec="k" if not zero else None)
        if not zero:
            at = (max(x_of(r), 1e-3), num(r["image_error"]))
            labels.setdefault((f"{at[0]:.2g}", f"{at[1]:.2g}"), [at]).append(r["policy"])
    for at, *names in labels.values():
        ax.annotate("/".join(names), at, fontsize=6, xytext=(3, 3), textcoords="offset points")
    for tech, curve in _sampler_curves(rows, scene).items():
        x = [max(x_of(r), 1e-3) for r in curve]
        y = np.array([num(r["image_error"]) for r in curve])
        lo = y - np.array([num(r["image_error_min"]) for r in curve])
        hi = np.array([num(r["image_error_max"]) for r in curve]) - y
        ax.errorbar(x, y, yerr=[lo, hi], marker="o", ms=4, lw=1.3, capsize=2,
                    color=colors(tech), label=tech)
        for xi, r in zip(x, curve):
            ax.annotate(f"S={int(num(r['samples_per_pixel']))}", (xi, num(r["image_error"])),
                        fontsize=6, xytext=(3, -8), textcoords="offset points")
    log_axes(ax)
    r0 = rs[0]
    panel_style(ax, f"{scene}, {int(num(r0['lights']))} lights, {int(num(r0['width']))}x"
                f"{int(num(r0['height']))}", xlabel, "relative RMSE vs brute")


def fig_sampling(rows, out, roles) -> tuple[str | None, list[str]]:
    """sampling.png (a row a scene: error against evaluations, frame cost and the work at
    c = VISIBILITY_C) and the crossover sentences."""
    if not rows:
        return None, []
    from matplotlib.lines import Line2D
    colors = Colors(order(rows, "technique"), roles)
    scenes = _scenes(rows)
    fig, axes = plt().subplots(len(scenes), len(AXES), squeeze=False, dpi=DPI,
                               figsize=(5.2 * len(AXES) + 3.0, 4.2 * len(scenes)))
    for row_axes, scene in zip(axes, scenes):
        for ax, (xlabel, x_of) in zip(row_axes, AXES):
            _panel(ax, rows, scene, x_of, colors, xlabel)
    handles = [Line2D([], [], color=colors(t), marker="o" if t in {r["technique"] for r in
               rows if r["kind"] == "sampler"} else "v", ls="", label=t)
               for t in order(rows, "technique")]
    handles += [Line2D([], [], color="0.4", marker="v", ls="", label="exact (error 0), drawn at "
                       "the panel's bottom"),
                Line2D([], [], color="0.4", marker="^", mec="k", ls="", label="engine cap policy"),
                Line2D([], [], color="0.4", marker="o", ls="-", label="sampler over S (bars: "
                       "min-max over seeds)")]
    axes[0][-1].legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    text = crossover_sentences(rows)
    bound = any(num(r["shadow_bound"]) == 1 for r in rows)
    text.append(f"Visibility is not simulated: the right-hand panels price each shadow test at "
                f"c = {VISIBILITY_C:g} light evaluations (the left-hand ones at c = 0); a "
                f"sampler's tests are its draws that hit an affecting light"
                + (" (an upper bound where marked <= in the table: no replay)" if bound else "")
                + ".")
    return save(fig, out, "sampling.png"), text


def sampling_section(rows, out, roles) -> tuple[str | None, list[str], str]:
    """(png, text lines, the table) of the report's section; (None, [], "") without rows."""
    if not rows:
        return None, [], ""
    png, text = fig_sampling(rows, out, roles)
    return png, text, EXPLANATION + "\n\n" + sampling_table(rows)


__all__ = ["fig_sampling", "sampling_section", "sampling_table", "crossover",
           "crossover_sentences", "named_cap", "losing_caps", "cost_phrase", "bin_reach", "meet", "EXPLANATION", "CSV",
           "VISIBILITY_C"]
