"""The report's lead figure: every accuracy choice the lab measures, its
image error against its frame cost, with the Pareto front (tradeoff.png).

    points   in one scene at one light count (frame 0), each a configuration a user can pick:
               an exact technique at a light cutoff t = 1/c        study cutoff
               stochastic culling at budget t = 1/N                 cutoff rows with the
                                                                    `stochastic` option set
               a list technique at the scene's radii (exact) and    study caps
               at each engine cap policy                            (app.bench.caps)
             the floor is left out (its lists are built in untimed set-up: no cost a user
             could pay), the unbounded reference (error 0) is the vertical line
    panels   mean FLIP of the tone-mapped images and relative RMSE of radiance, both against
             the unbounded reference; where DIR/temporal.csv holds the same scene and light
             count, the temporal error of the same configurations (app.report.temporal),
             placed at the frame cost this run measured for them
    front    the Pareto front of each panel on the medians (aggregate.pareto)

The text's advice per panel comes from choices(): a configuration is left out when another
one is at least as accurate (errors within ERR_RTOL of each other are one error: the exact
techniques at one cutoff differ only in summation order) and not costlier beyond the measured
spread (app.report.spread.below).  So each step to the next choice costs more beyond the
spread and buys less error; with one timing sample no step is measured, and the text says so.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import json
import math

from ..results import option_specs
from .aggregate import pareto
from .common import DPI, log_axes, mean, ms, num, order, panel_style, plt, save, sel, times
from .spread import Spread, below

ERR_RTOL = 0.02               # errors this close (relative) are the same error
# kind -> (marker, legend label)
KINDS = {"cutoff": ("o", "exact technique, light cutoff t=1/c"),
         "stochastic": ("*", "stochastic culling, budget t=1/N"),
         "radii": ("s", "exact technique, the scene's radii"),
         "cap": ("^", "engine cap policy (scene's radii)")}
# panel -> (point attribute, panel title, axis label)
METRICS = {"flip": ("FLIP", "mean FLIP vs unbounded (tone-mapped, 0-1)"),
           "rmse": ("relative RMSE", "RMSE vs unbounded / mean radiance"),
           "temporal": ("temporal error", "mean |dT - dR| / mean R (%), moving lights")}
EXPLANATION = (
    "Every point is a configuration a user can pick, measured on the same frame: an exact "
    "technique with each light's radius set by the cutoff t (light cutoff study), stochastic "
    "light culling at budget t = 1/N, a list technique at the scene's own radii and under each "
    "engine's cap policy (`--cap-policy`: the over-cap lights dropped in that engine's order). "
    "Error is against the unbounded reference (every light, attenuation 1/(d^2+1), no window): "
    "FLIP between the tone-mapped images, relative RMSE of linear radiance; the temporal panel "
    "takes the temporal series' error of the same configuration on moving lights (a cutoff "
    "level's and a cap policy's measured once, for every technique at it: their images are the "
    "same). Frame cost: "
    "CPU stage + culling passes + shading, the median of the timing samples (bars: min-max); "
    "every culling pass counts in full (serially), fptl's list build too, which its chapter "
    "hides under shadow-map rendering on asynchronous compute (the validation section reads "
    "fptl both ways: serial, and the build hidden up to a shadow-pass budget). "
    "The dashed staircase is the Pareto front; the advice names a step only where its cost "
    "exceeds the cheaper choice's beyond the measured spread.")


@dataclass
class Point:
    label: str
    kind: str                 # a key of KINDS
    technique: str
    value: object             # the cutoff c, budget N or policy name (None: the scene's radii)
    cost: Spread
    flip: float
    rmse: float
    temporal: float = math.nan
    lost_pixels: float = math.nan
    row: dict = field(default_factory=dict, repr=False)

    def err(self, metric: str) -> float:
        return getattr(self, metric)


def _policy(r) -> str:
    spec = option_specs().get("cap_policy")
    v = num(r.get("cap_policy"))
    return spec.label(v) if spec is not None and not math.isnan(v) else "none"


def _point(r) -> Point | None:
    t, cost = r["technique"], Spread.of(r, "frame_cost")
    flip, rmse = num(r.get("image_flip")), num(r["image_error"])
    budget = num(r.get("stochastic"))
    if r["study"] == "cutoff":
        if budget > 0:
            return Point(f"{t}, stochastic 1/{int(budget)}", "stochastic", t, int(budget), cost,
                         flip, rmse, row=r)
        if num(r["cutoff"]) > 0:
            c = int(r["cutoff"])
            return Point(f"{t}, cutoff 1/{c}", "cutoff", t, c, cost, flip, rmse, row=r)
        return None
    pol = _policy(r)
    lost = num(json.loads(r.get("stats") or "{}").get("lost_pixels"))
    if pol == "none":
        return Point(f"{t}, scene radii", "radii", t, None, cost, flip, rmse, lost_pixels=lost,
                     row=r)
    return Point(f"{t}, {pol}", "cap", t, pol, cost, flip, rmse, lost_pixels=lost, row=r)


def gather(rows, trows, roles) -> dict:
    """{(scene, lights): {"points": [Point], "reference": its row or None, "skipped":
    [policies without a row], "temporal": bool}} of the cutoff and caps rows, the temporal
    series' mean error set on the points it matches (same scene and light count)."""
    out: dict = {}
    for r in sel(rows, study="cutoff") + sel(rows, study="caps"):
        if r["technique"] == roles.floor:
            continue
        g = out.setdefault((r["scene"], int(r["lights"])), {"points": [], "reference": None,
                                                            "skipped": [], "temporal": False})
        if r["study"] == "cutoff" and num(r["cutoff"]) < 0:
            g["reference"] = r
            continue
        p = _point(r)
        if p is not None:
            g["points"].append(p)
    spec = option_specs().get("cap_policy")
    for (scene, n), g in out.items():
        have = {p.value for p in g["points"] if p.kind == "cap"}
        if have and spec is not None:
            g["skipped"] = [c for c in spec.choices if c not in have and c != "none"]
        _match_temporal(g, [r for r in trows
                            if r.get("scene") == scene and num(r.get("lights")) == n])
    return out


def _match_temporal(g, trows) -> None:
    """Each point's mean temporal error from the temporal series' configuration of the same
    kind and value: an exact technique's own at the scene's radii; a cutoff level's (the
    series renders it with the reference) and a cap policy's (with one list technique) for
    every technique at that level or policy, whose images are the same: the same light sets,
    summed in another order; a stochastic budget's (the series draws anew every frame with
    the reference) for every technique at that budget, whose draws give the same sets."""
    by = {}
    value = {"cap": lambda r: r.get("policy"), "cutoff": lambda r: int(num(r.get("cutoff"))),
             "stochastic": lambda r: int(num(r.get("stochastic")))}
    for r in trows:
        e = num(r.get("temporal_error_pct"))
        kind = {"technique": "radii", "cap": "cap", "cutoff": "cutoff",
                "stochastic": "stochastic"}.get(r.get("kind"))
        if math.isnan(e) or kind is None:
            continue
        key = (kind, r["technique"]) if kind == "radii" else (kind, value[kind](r))
        by.setdefault(key, []).append(e)
    for p in g["points"]:
        es = by.get((p.kind, p.technique if p.kind == "radii" else p.value))
        if es:
            p.temporal = mean(es)
            g["temporal"] = True


def front(points, metric: str) -> list[Point]:
    """The Pareto front of (median cost, error), cheapest first."""
    pts = {p.label: p for p in points if not math.isnan(p.err(metric))}
    return [pts[k] for k in pareto({k: (p.cost.med, p.err(metric)) for k, p in pts.items()})]


def _same(a: float, b: float) -> bool:
    return abs(a - b) <= ERR_RTOL * max(abs(a), abs(b))


def _dominates(q: Point, p: Point, metric: str) -> bool:
    """q is at least as accurate as p, not costlier beyond the spread, and better in one."""
    eq, ep = q.err(metric), p.err(metric)
    if q is p or not (eq <= ep or _same(eq, ep)) or below(p.cost, q.cost):
        return False
    return (eq < ep and not _same(eq, ep)) or q.cost.med < p.cost.med


def choices(points, metric: str) -> list[tuple[Point, list[Point]]]:
    """(choice, its rivals) cheapest first: the configurations no other dominates (module
    docstring); rivals: the same error and a cost within the choice's spread."""
    pts = [p for p in points if not math.isnan(p.err(metric))]
    keep = [p for p in pts if not any(_dominates(q, p, metric) for q in pts)]
    keep.sort(key=lambda p: p.cost.med)
    return [(p, [q for q in pts if q is not p and _same(q.err(metric), p.err(metric))
                 and not below(p.cost, q.cost) and not below(q.cost, p.cost)]) for p in keep]


def advice(scene: str, n: int, points, metric: str) -> str:
    """Which choice to make for which frame-cost budget, named only beyond the spread."""
    name = METRICS[metric][0]
    ch = choices(points, metric)
    if not ch:
        return ""
    fmt = (lambda e: f"{e:.3g}%") if metric == "temporal" else (lambda e: f"{e:.3g}")
    at = lambda p: f"{p.label} ({ms(p.cost.med)}, {name} {fmt(p.err(metric))})"
    first, rs = ch[0]
    s = f"**{scene}, {n} lights, {name}**: "
    if min(p.cost.n for p in points) < 2:
        return s + (f"one timing sample a configuration, so no cost difference is measured and "
                    f"no budget is advised; the least {name} is {at(first)}.")
    if len(ch) == 1:
        return s + (f"{at(first)}{_rivals(rs)}: no configuration is cheaper than it beyond the "
                    f"measured spread, so it is the choice at every budget measured.")
    s += f"the cheapest choice is {at(first)}{_rivals(rs)}"
    prev = first
    for p, rs in ch[1:]:
        s += (f"; with a budget of {ms(p.cost.med)} ({times(p.cost.med / first.cost.med)} that) "
              f"{p.label} lowers it to {fmt(p.err(metric))} "
              f"({times(prev.err(metric) / max(p.err(metric), 1e-12))} less; costlier than "
              f"{prev.label} beyond spread){_rivals(rs)}")
        prev = p
    return s + "."


def _rivals(rs) -> str:
    if not rs:
        return ""
    more = " ..." if len(rs) > 3 else ""
    return f" (or {', '.join(r.label for r in rs[:3])}{more}: the same error, cost within spread)"


def _panel(ax, pts, metric: str, colors, reference) -> None:
    """One panel: every point with its cost's min-max, the front, the choices labelled (a
    metric no point of this scene has, e.g. the temporal series' in another scene: a note)."""
    pts = [p for p in pts if p.cost.med > 0]          # log axes: a cost of 0 has no place
    if not pts:
        ax.text(0.5, 0.5, f"no {METRICS[metric][0]} in this scene", ha="center", va="center",
                transform=ax.transAxes, fontsize=9, color="0.4")
        ax.set_xticks([])
        ax.set_yticks([])
        return
    y = lambda p: max(p.err(metric), 1e-7)           # log axes: an error of 0 drawn at 1e-7
    for p in pts:
        c = colors(p.technique)
        ax.errorbar([p.cost.med], [y(p)], xerr=[[p.cost.med - p.cost.lo], [p.cost.hi - p.cost.med]],
                    fmt=KINDS[p.kind][0], color=c, ms=7 if p.kind == "stochastic" else 5,
                    mec="k" if p.kind == "cap" else c, mew=0.5, elinewidth=0.6, alpha=0.85)
    fr = front(pts, metric)
    if fr:
        xs, ys = [p.cost.med for p in fr], [y(p) for p in fr]
        ax.plot(xs, ys, color="k", ls="--", lw=1.1, drawstyle="steps-post", zorder=3)
        ax.scatter(xs, ys, s=90, facecolors="none", edgecolors="k", lw=1.0, zorder=4)
    # the text's choices (a step beyond the spread each), staggered against their neighbours
    for i, (p, _) in enumerate(choices(pts, metric)):
        ax.annotate(p.label, (p.cost.med, y(p)), fontsize=7, fontweight="bold",
                    xytext=(6, 5 if i % 2 == 0 else -13), textcoords="offset points",
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
    if reference is not None:
        ax.axvline(num(reference["frame_cost_ms"]), color="0.3", ls=":", lw=1)
    log_axes(ax)


def _notes(scene: str, g, roles) -> list[str]:
    """The skipped cap policies, what each cap loses, and the unbounded reference's cost."""
    pts, text = g["points"], []
    if g["skipped"]:
        vis = mean(p.row["visible"] for p in pts if p.kind == "radii")      # before any cap
        text.append(f"{scene}: cap policies {', '.join(g['skipped'])} drop none of the "
                    f"{vis:.0f} visible lights (every budget holds them): not measured, they "
                    f"are the scene's radii.")
    caps = [p for p in pts if p.kind == "cap" and not math.isnan(p.lost_pixels)]
    if caps:
        px = int(num(pts[0].row["width"]) * num(pts[0].row["height"]))
        bad = int(sum(num(p.row["mismatch_count"]) + num(p.row["mismatch_hash"]) for p in caps))
        exact = ("every technique exact on the lights it kept: 0 pixels differ from brute "
                 "without them" if bad == 0 else
                 f"{bad} pixels differ from brute without the dropped lights: must be 0")
        lost = {pol: mean(p.lost_pixels for p in caps if p.value == pol)
                for pol in dict.fromkeys(p.value for p in caps)}
        text.append(f"{scene}: pixels each cap policy changes against brute ({exact}): " +
                    ", ".join(f"{pol} {v:.0f} of {px}" for pol, v in lost.items()) + ".")
    if g["reference"] is not None:
        text.append(f"{scene}: the unbounded reference ({roles.reference}, error 0, dotted "
                    f"line) costs {ms(g['reference']['frame_cost_ms'])}.")
    return text


def fig_tradeoff(rows, trows, out, colors, roles) -> tuple[str | None, list[str]]:
    groups = {k: g for k, g in gather(rows, trows, roles).items() if g["points"]}
    if not groups:
        return None, []
    from matplotlib.lines import Line2D
    temporal = any(g["temporal"] for g in groups.values())
    metrics = ["flip", "rmse"] + (["temporal"] if temporal else [])
    fig, axes = plt().subplots(len(groups), len(metrics), squeeze=False, dpi=DPI,
                               figsize=(5.8 * len(metrics) + 3.2, 4.6 * len(groups)))
    text, techs = [], []
    for row_axes, ((scene, n), g) in zip(axes, groups.items()):
        pts = g["points"]
        techs += [t for t in order([p.row for p in pts], "technique") if t not in techs]
        res = f"{int(pts[0].row['width'])}x{int(pts[0].row['height'])}"
        for ax, metric in zip(row_axes, metrics):
            shown = [p for p in pts if not math.isnan(p.err(metric))]
            _panel(ax, shown, metric, colors, g["reference"])
            title, ylabel = METRICS[metric]
            panel_style(ax, f"{title} vs frame cost, {scene}, {n} lights, {res}",
                        "frame cost (ms, median; bars min-max)", ylabel)
            text.append(advice(scene, n, shown, metric))
        text += _notes(scene, g, roles)
    handles = [Line2D([], [], color=colors(t), marker="o", ls="", label=t) for t in techs]
    handles += [Line2D([], [], color="0.4", marker=m, ls="", mec="k" if k == "cap" else "0.4",
                       label=lab) for k, (m, lab) in KINDS.items()]
    handles += [Line2D([], [], color="k", ls="--", label="Pareto front (circled; labelled:\n"
                                                         "the choices the text names)"),
                Line2D([], [], color="0.3", ls=":", label=f"unbounded {roles.reference} (error 0)")]
    axes[0][-1].legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return save(fig, out, "tradeoff.png"), [t for t in text if t]


__all__ = ["fig_tradeoff", "gather", "front", "choices", "advice", "Point", "EXPLANATION",
           "ERR_RTOL", "KINDS", "METRICS"]
